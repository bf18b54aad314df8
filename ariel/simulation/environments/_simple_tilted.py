"""SimpleTiltedWorld: a flat plane tilted about the origin."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from ariel.simulation.environments._base import (
    PLAIN_FLOOR_RGBA,
    BaseWorld,
    as_bool,
    as_rotation_sequence,
    as_vector,
    euler_to_quat,
    quat_to_mat,
)

__all__ = ["SimpleTiltedWorld"]


class SimpleTiltedWorld(BaseWorld):
    """A plane through the origin tilted by `floor_tilt` (Euler DEGREES, `floor_rot_sequence`).

    The default (15, 0, 0) is a 15 degree slope about the x axis: the floor rises toward +y,
    z = tan(15 deg) * y.
    """

    name = "simple-tilted-world"
    ground_geoms = ("floor",)

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        floor_tilt: Sequence[float] = (15.0, 0.0, 0.0),
        floor_rot_sequence: str = "XYZ",
        checker_floor: bool = True,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
    ) -> None:
        self.floor_size = as_vector(floor_size, 3, "floor_size", positive=True)
        self.floor_tilt = as_vector(floor_tilt, 3, "floor_tilt")
        self.floor_rot_sequence = as_rotation_sequence(floor_rot_sequence)
        self.checker_floor = as_bool(checker_floor, "checker_floor")
        self._quat = euler_to_quat(self.floor_tilt, self.floor_rot_sequence)
        self._normal = quat_to_mat(self._quat)[:, 2]
        if self._normal[2] <= 1e-6:
            raise ValueError(
                f"floor_tilt {self.floor_tilt} leaves the floor vertical or upside down; "
                "allowed: tilts below 90 degrees",
            )
        super().__init__(
            name=name,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )

    def _build(self) -> None:
        width, length, depth = self.floor_size
        floor = self.spec.worldbody.add_body(name="floor")
        geom = floor.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[width / 2, length / 2, depth / 2],
            quat=self._quat.tolist(),
        )
        if self.checker_floor:
            geom.material = self._add_checker_material("floor")
        else:
            geom.rgba = list(PLAIN_FLOOR_RGBA)

    def _ground_height_array(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        # The plane n . p = 0 through the origin, solved for z.
        nx, ny, nz = self._normal
        return -(nx * x + ny * y) / nz
