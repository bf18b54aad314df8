"""CraterTerrainWorld: a cone-shaped bowl (lowest at the centre) with noise."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments._rugged import DEFAULT_TERRAIN_SEED
from ariel.simulation.environments.heightmaps import crater_heightmap

__all__ = ["CraterTerrainWorld"]


class CraterTerrainWorld(CompoundWorld):
    """A central crater: height rises linearly from the centre (about 0) to the corners
    (floor_size[2] / 2 = 1 m by default), plus Perlin noise."""

    name = "crater-world"

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 2.0),
        floor_tilt: Sequence[float] = (0.0, 0.0, 0.0),
        floor_rot_sequence: str = "XYZ",
        checker_floor: bool = False,
        dims: Sequence[int] = (100, 100),
        height_of_noise: float = 0.3,
        scale_of_noise: float = 5.0,
        normalize: str = "none",
        crater_depth: float = 1.0,
        crater_radius: float = 0.3,
        seed: int | None = DEFAULT_TERRAIN_SEED,
        terrain_color: Sequence[float] = TERRAIN_COLOR,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
    ) -> None:
        self.seed = seed
        self.height_of_noise = height_of_noise
        self.scale_of_noise = scale_of_noise
        self.normalize = normalize
        self.crater_depth = crater_depth
        self.crater_radius = crater_radius
        dims = as_dims(dims)
        heightmap = crater_heightmap(
            dims,
            crater_depth=crater_depth,
            crater_radius=crater_radius,
            height_of_noise=height_of_noise,
            scale_of_noise=scale_of_noise,
            normalize=normalize,
            seed=seed,
        )
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
