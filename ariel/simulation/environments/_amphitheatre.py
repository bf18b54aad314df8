"""AmphitheatreTerrainWorld: a flat arena ringed by a slope and a plateau."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ariel.simulation.environments._base import as_dims, as_vector
from ariel.simulation.environments._compound import TERRAIN_COLOR, CompoundWorld
from ariel.simulation.environments._rugged import DEFAULT_TERRAIN_SEED, check_seed
from ariel.simulation.environments.heightmaps import amphitheatre_heightmap

__all__ = ["AmphitheatreTerrainWorld"]


def _radii(
    inner_radius: float,
    outer_radius: float,
    ring_inner_radius: float | None,
    ring_outer_radius: float | None,
) -> tuple[float, float]:
    """The inner and outer radius, each given under our name or upstream's (``ring_``)."""
    for alias, value, ours, default in (
        ("ring_inner_radius", ring_inner_radius, inner_radius, 0.2),
        ("ring_outer_radius", ring_outer_radius, outer_radius, 0.45),
    ):
        if value is not None and ours != default:
            raise ValueError(f"give {alias} or {alias.removeprefix('ring_')}, not both")
    inner_radius = inner_radius if ring_inner_radius is None else ring_inner_radius
    outer_radius = outer_radius if ring_outer_radius is None else ring_outer_radius
    return inner_radius, outer_radius


class AmphitheatreTerrainWorld(CompoundWorld):
    """Flat for r <= `inner_radius`, rising linearly to a plateau at `outer_radius` (r in unit
    heightmap coordinates from the centre), plus `height_of_noise` x Perlin noise. The slope
    height is floor_size[2] before MuJoCo's rescaling; the surface tops out at floor_size[2] / 2.
    The map is `amphitheatre_heightmap`'s.

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"amphitheatre-world"``.
        floor_size: ``(width, length, depth)`` in metres: the terrain covers width x length
            and its surface spans z in [0, depth / 2] (default (10, 10, 2): 1 m of relief).
        floor_tilt: Euler angles in DEGREES (in ``floor_rot_sequence``) that tilt the whole
            terrain about the origin; the floor must stay below 90 degrees from level.
        floor_rot_sequence: the Euler sequence: 3 letters from ``xyzXYZ`` (MuJoCo's
            convention: lower case rotates about the tilted axes, upper case about fixed ones).
        checker_floor: a checkered floor instead of the plain ``terrain_color``.
        dims: the heightmap's ``(rows, cols)``, each >= 2 (rows run along y).
        inner_radius: the flat arena's radius, as a fraction of the terrain's size (>= 0).
        outer_radius: where the slope reaches the plateau (> ``inner_radius``).
        height_of_noise: the weight of the Perlin noise added to the shape (same units as the
            shape's height before MuJoCo rescales the map).
        scale_of_noise: the Perlin noise's feature size, in heightmap pixels per lattice cell
            (larger: broader hills).
        normalize: how the raw noise (about +-0.7) is scaled: ``"none"``, ``"linear"``
            (``v * 0.5 + 0.5``) or ``"clip"`` (clipped to [0, 1]).
        seed: the terrain's noise seed (same seed, same terrain); ``None`` draws a fresh one.
        terrain_color: the floor's RGBA colour (4 numbers in [0, 1]) without the checker.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.
        ring_inner_radius: upstream's name for ``inner_radius``.
        ring_outer_radius: upstream's name for ``outer_radius``.

    Raises:
        ValueError: a radius is given under both names, or an option's value is not allowed
            (see `amphitheatre_heightmap` and `CompoundWorld`).
    """

    name = "amphitheatre-world"

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 2.0),
        floor_tilt: Sequence[float] = (0.0, 0.0, 0.0),
        floor_rot_sequence: str = "XYZ",
        checker_floor: bool = False,
        dims: Sequence[int] = (100, 100),
        inner_radius: float = 0.2,
        outer_radius: float = 0.45,
        height_of_noise: float = 0.3,
        scale_of_noise: float = 5.0,
        normalize: str = "none",
        seed: int | None = DEFAULT_TERRAIN_SEED,
        terrain_color: Sequence[float] = TERRAIN_COLOR,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
        ring_inner_radius: float | None = None,
        ring_outer_radius: float | None = None,
    ) -> None:
        # Upstream's names for the two radii.
        inner_radius, outer_radius = _radii(
            inner_radius, outer_radius, ring_inner_radius, ring_outer_radius
        )
        self.seed = seed = check_seed(type(self).__name__, seed)
        self.inner_radius = inner_radius
        self.outer_radius = outer_radius
        self.height_of_noise = height_of_noise
        self.scale_of_noise = scale_of_noise
        self.normalize = normalize
        dims = as_dims(dims)
        cone_height = as_vector(floor_size, 3, "floor_size", positive=True)[2]
        heightmap = amphitheatre_heightmap(
            dims,
            inner_radius=inner_radius,
            outer_radius=outer_radius,
            cone_height=cone_height,
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
