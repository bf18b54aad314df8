"""CraterTerrainWorld: a cone-shaped bowl (lowest at the centre) with noise."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments._rugged import DEFAULT_TERRAIN_SEED, check_seed
from ariel.simulation.environments.heightmaps import crater_heightmap

__all__ = ["CraterTerrainWorld"]


class CraterTerrainWorld(CompoundWorld):
    """A central crater: height rises linearly from the centre (about 0) to the corners
    (floor_size[2] / 2 = 1 m by default), plus Perlin noise.

    The map is `crater_heightmap`'s.

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"crater-world"``.
        floor_size: ``(width, length, depth)`` in metres: the terrain covers width x length
            and its surface spans z in [0, depth / 2] (default (10, 10, 2): 1 m of relief).
        floor_tilt: Euler angles in DEGREES (in ``floor_rot_sequence``) that tilt the whole
            terrain about the origin; the floor must stay below 90 degrees from level.
        floor_rot_sequence: the Euler sequence: 3 letters from ``xyzXYZ`` (MuJoCo's
            convention: lower case rotates about the tilted axes, upper case about fixed ones).
        checker_floor: a checkered floor instead of the plain ``terrain_color``.
        dims: the heightmap's ``(rows, cols)``, each >= 2 (rows run along y).
        height_of_noise: the weight of the Perlin noise added to the shape (same units as the
            shape's height before MuJoCo rescales the map).
        scale_of_noise: the Perlin noise's feature size, in heightmap pixels per lattice cell
            (larger: broader hills).
        normalize: how the raw noise (about +-0.7) is scaled: ``"none"``, ``"linear"``
            (``v * 0.5 + 0.5``) or ``"clip"`` (clipped to [0, 1]).
        crater_depth: the slope of the cone: its height per ``crater_radius`` of distance from
            the centre (>= 0).
        crater_radius: the cone's radius unit, as a fraction of the terrain's size (> 0).
        seed: the terrain's noise seed (same seed, same terrain); ``None`` draws a fresh one.
        terrain_color: the floor's RGBA colour (4 numbers in [0, 1]) without the checker.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: an option's value is not allowed (see `crater_heightmap` and
            `CompoundWorld`).
    """

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
        self.seed = seed = check_seed(type(self).__name__, seed)
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
