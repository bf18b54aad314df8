"""SimpleTiltedWorld: a flat plane tilted about the origin."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ariel.simulation.environments._base import (
    as_rotation_sequence,
    as_vector,
    euler_to_quat,
    quat_to_mat,
)
from ariel.simulation.environments._simple_flat import SimpleFlatWorld

__all__ = ["SimpleTiltedWorld"]


class SimpleTiltedWorld(SimpleFlatWorld):
    """A plane through the origin tilted by `floor_tilt` (Euler DEGREES, `floor_rot_sequence`).

    The default (15, 0, 0) is a 15 degree slope about the x axis: the floor rises toward +y,
    z = tan(15 deg) * y.

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"simple-tilted-world"``.
        floor_size: ``(width, length, depth)`` in metres, as in `SimpleFlatWorld`.
        floor_tilt: Euler angles in DEGREES (in ``floor_rot_sequence``) that tilt the plane
            about the origin; the floor must stay below 90 degrees from level.
        floor_rot_sequence: the Euler sequence: 3 letters from ``xyzXYZ`` (MuJoCo's
            convention: lower case rotates about the tilted axes, upper case about fixed ones).
        checker_floor: a checkered floor (``True``) or a plain-coloured one.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: ``floor_tilt`` is not three finite numbers or leaves the floor vertical or
            upside down, or ``floor_rot_sequence`` is not a valid sequence (and see
            `SimpleFlatWorld`).
    """

    name = "simple-tilted-world"

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
        self.floor_tilt = as_vector(floor_tilt, 3, "floor_tilt")
        self.floor_rot_sequence = as_rotation_sequence(floor_rot_sequence)
        self._quat = euler_to_quat(self.floor_tilt, self.floor_rot_sequence)
        self._normal = quat_to_mat(self._quat)[:, 2]
        if self._normal[2] <= 1e-6:
            raise ValueError(
                f"floor_tilt {self.floor_tilt} leaves the floor vertical or upside down; "
                "allowed: tilts below 90 degrees",
            )
        super().__init__(
            name=name,
            floor_size=floor_size,
            checker_floor=checker_floor,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )

    def _ground_height_array(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        # The plane n . p = 0 through the origin, solved for z.
        nx, ny, nz = self._normal
        return -(nx * x + ny * y) / nz
