"""RuggedTerrainWorld: Perlin-noise hills that fade out toward the edges."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments.heightmaps import rugged_heightmap, smooth_edges_heightmap

__all__ = ["DEFAULT_TERRAIN_SEED", "RuggedTerrainWorld"]

#: Terrain worlds are reproducible by default; pass `seed=` for another terrain.
DEFAULT_TERRAIN_SEED = 42


class RuggedTerrainWorld(CompoundWorld):
    """Heightmap = Perlin noise (`scale_of_noise` pixels per lattice cell) x a smooth edge mask.

    With the default floor_size (10, 10, 1) the hills span 0.5 m. Deterministic by default
    (seed 42); ``seed=None`` draws a fresh terrain each time. ``floor_tilt`` (Euler degrees,
    default none) tilts the whole terrain.
    """

    name = "rugged-world"
    default_floor_tilt: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        floor_tilt: Sequence[float] | None = None,
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
            floor_tilt=self.default_floor_tilt if floor_tilt is None else floor_tilt,
            floor_rot_sequence=floor_rot_sequence,
            dims=dims,
            floor_heightmap=heightmap,
            terrain_color=terrain_color,
            checker_floor=checker_floor,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )
