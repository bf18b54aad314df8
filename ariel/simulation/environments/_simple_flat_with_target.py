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
    at `target_position` (default (5, 0, 0.5), upstream's)."""

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
