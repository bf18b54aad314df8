"""RuggedTerrainWorld: Perlin-noise hills that fade out toward the edges."""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments.heightmaps import rugged_heightmap, smooth_edges_heightmap

__all__ = ["DEFAULT_TERRAIN_SEED", "RuggedTerrainWorld", "check_seed"]

#: Terrain worlds are reproducible by default; pass `seed=` for another terrain.
DEFAULT_TERRAIN_SEED = 42


def check_seed(world: str, seed: Any) -> int | None:
    """``seed`` as an int (or None), or a one-line ValueError naming the world and argument."""
    if seed is None:
        return None
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool) and seed >= 0:
        return int(seed)
    raise ValueError(f"{world}: seed must be None or an int >= 0, not {seed!r}")


class RuggedTerrainWorld(CompoundWorld):
    """Heightmap = Perlin noise (`scale_of_noise` pixels per lattice cell) x a smooth edge mask.

    With the default floor_size (10, 10, 1) the hills span 0.5 m. Deterministic by default
    (seed 42); ``seed=None`` draws a fresh terrain each time, from NumPy's global RNG
    (``np.random.seed`` makes it repeat).

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"rugged-world"``.
        floor_size: ``(width, length, depth)`` in metres: the terrain covers width x length
            and its surface spans z in [0, depth / 2] (default (10, 10, 1): 0.5 m of relief).
        floor_tilt: Euler angles in DEGREES (in ``floor_rot_sequence``) that tilt the whole
            terrain about the origin; ``None`` gives the class's ``default_floor_tilt`` (no tilt
            here, 15 degrees about x in `RuggedTiltedWorld`).
        floor_rot_sequence: the Euler sequence: 3 letters from ``xyzXYZ`` (MuJoCo's
            convention: lower case rotates about the tilted axes, upper case about fixed ones).
        checker_floor: a checkered floor instead of the plain ``terrain_color``.
        dims: the heightmap's ``(rows, cols)``, each >= 2 (rows run along y).
        scale_of_noise: the Perlin noise's feature size, in heightmap pixels per lattice cell
            (larger: broader hills).
        normalize: how the raw noise (about +-0.7) is scaled: ``"none"``, ``"linear"``
            (``v * 0.5 + 0.5``) or ``"clip"`` (clipped to [0, 1]).
        edge_width: the width of the border over which the hills fade to 0, as a fraction of
            the terrain's size (see `smooth_edges_heightmap`).
        seed: the terrain's noise seed (same seed, same terrain); ``None`` draws a fresh one.
        terrain_color: the floor's RGBA colour (4 numbers in [0, 1]) without the checker.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: an option's value is not allowed (see `CompoundWorld`), or ``seed`` is
            neither None nor an int >= 0.
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
        seed = check_seed(type(self).__name__, seed)
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
