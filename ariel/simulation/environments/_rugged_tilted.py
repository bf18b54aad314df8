"""RuggedTiltedWorld: rugged Perlin terrain on a tilted heightfield."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments._rugged import DEFAULT_TERRAIN_SEED
from ariel.simulation.environments.heightmaps import rugged_heightmap, smooth_edges_heightmap

__all__ = ["RuggedTiltedWorld"]


class RuggedTiltedWorld(CompoundWorld):
    """RuggedTerrainWorld's terrain tilted by `floor_tilt` (default 15 degrees about x)."""

    name = "rugged-tilted-world"

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        floor_tilt: Sequence[float] = (15.0, 0.0, 0.0),
        floor_rot_sequence: str = "XYZ",
        checker_floor: bool = False,
        dims: Sequence[int] = (100, 100),
        scale_of_noise: float = 4.0,
        normalize: str = "none",
        edge_width: float = 0.2,
        seed: int | None = DEFAULT_TERRAIN_SEED,
        terrain_color: Sequence[float] = TERRAIN_COLOR,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
    ) -> None:
        self.seed = seed
        self.scale_of_noise = scale_of_noise
        self.normalize = normalize
        self.edge_width = edge_width
        dims = as_dims(dims)
        heightmap = rugged_heightmap(dims, scale_of_noise, normalize, seed=seed)
        heightmap = heightmap * smooth_edges_heightmap(dims, edge_width)
        super().__init__(
            name=name,
            floor_size=floor_size,
            floor_tilt=floor_tilt,
            floor_rot_sequence=floor_rot_sequence,
            dims=dims,
            floor_heightmap=heightmap,
            terrain_color=terrain_color,
            checker_floor=checker_floor,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )
