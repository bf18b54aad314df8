"""SimpleFlatWorldWithTarget: the flat world plus a red target cube (not exported upstream)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mujoco

from ariel.simulation.environments._base import as_vector
from ariel.simulation.environments._simple_flat import SimpleFlatWorld

__all__ = ["SimpleFlatWorldWithTarget"]


class SimpleFlatWorldWithTarget(SimpleFlatWorld):
    """Flat world with body "target_marker" (a see-through red cube that nothing collides with)
    at `target_position` (default (5, 0, 0.5), upstream's).

    Args:
        name: the world's name (a non-empty string); ``None`` gives
            ``"simple-flat-world-with-target"``.
        floor_size: ``(width, length, depth)`` in metres, as in `SimpleFlatWorld`.
        checker_floor: a checkered floor (``True``) or a plain-coloured one.
        target_position: the centre of the 0.2 m target cube, ``(x, y, z)`` in metres.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: ``target_position`` is not three finite numbers (and see
            `SimpleFlatWorld`).
    """

    name = "simple-flat-world-with-target"

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        checker_floor: bool = True,
        target_position: Sequence[float] = (5.0, 0.0, 0.5),
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
    ) -> None:
        self.target_position = as_vector(target_position, 3, "target_position")
        super().__init__(
            name=name,
            floor_size=floor_size,
            checker_floor=checker_floor,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )

    def _build(self) -> None:
        super()._build()
        marker = self.spec.worldbody.add_body(name="target_marker", pos=list(self.target_position))
        marker.add_geom(
            name="target_geom",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.1, 0.1, 0.1],
            rgba=[1.0, 0.0, 0.0, 0.6],
            contype=0,
            conaffinity=0,
        )
