"""SimpleFlatWorld: a flat (checkered) plane."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from ariel.simulation.environments._base import (
    PLAIN_FLOOR_RGBA,
    BaseWorld,
    as_bool,
    as_vector,
)

__all__ = ["SimpleFlatWorld"]


class SimpleFlatWorld(BaseWorld):
    """A flat floor: body "floor" holding a plane geom "floor" at z = 0.

    `floor_size` is (width, length, depth) in metres (the plane is width x length; the third
    value sets the plane's render grid). `checker_floor=False` gives a plain-coloured floor.
    """

    name = "simple-flat-world"
    ground_geoms = ("floor",)
    #: Orientation (w, x, y, z) of the floor plane; SimpleTiltedWorld sets its own.
    _quat: np.ndarray = np.array([1.0, 0.0, 0.0, 0.0])

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        checker_floor: bool = True,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
    ) -> None:
        self.floor_size = as_vector(floor_size, 3, "floor_size", positive=True)
        self.checker_floor = as_bool(checker_floor, "checker_floor")
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
        # MuJoCo planes are infinite for collisions, so the ground is z = 0 everywhere.
        return np.zeros_like(x)
