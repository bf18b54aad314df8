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

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"simple-flat-world"``.
        floor_size: ``(width, length, depth)`` in metres, all > 0: the plane is width x length
            (drawn; for collisions MuJoCo planes are infinite) and the third value sets the
            plane's render grid.
        checker_floor: a checkered floor (``True``) or a plain-coloured one.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: ``floor_size`` is not three positive numbers, or ``checker_floor`` is not a
            bool (and see `BaseWorld`).
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
