"""Heightmaps for heightfield worlds: arrays of shape ``dims = (rows, cols)``.

Grid convention: column j sits at x = j / (cols - 1) and row i at y = i / (rows - 1), both in
[0, 1] (rows run along the world y axis, columns along x, as in MuJoCo heightfields). The grid
is symmetric, so the centre of a crater or amphitheatre is the centre of the heightfield (the
world origin). Non-square dims stretch the same shapes (upstream resizes a square map).

MuJoCo rescales heightfield data to [0, 1] when compiling, so only a map's shape matters; the
world's ``floor_size`` sets the real height.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from ariel.simulation.environments._base import as_dims
from ariel.simulation.environments.perlin import PerlinNoise

__all__ = [
    "amphitheater_heightmap",
    "amphitheatre_heightmap",
    "crater_heightmap",
    "flat_heightmap",
    "rugged_heightmap",
    "smooth_edges_heightmap",
]


def _unit_grid(dims: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """x (along columns) and y (along rows) in [0, 1], each of shape dims."""
    rows, cols = dims
    x = np.linspace(0.0, 1.0, cols)[np.newaxis, :]
    y = np.linspace(0.0, 1.0, rows)[:, np.newaxis]
    return np.broadcast_to(x, dims), np.broadcast_to(y, dims)


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return number


def _non_negative(value: Any, what: str) -> float:
    number = _number(value, what)
    if number < 0:
        raise ValueError(f"{what} must be a finite number >= 0, got {value!r}")
    return number


def _noise(
    dims: tuple[int, int],
    scale_of_noise: float,
    normalize: str | None,
    seed: int | None,
) -> np.ndarray:
    rows, cols = dims
    if normalize is None:  # upstream's scripts pass None for raw values
        normalize = "none"
    return PerlinNoise(seed).as_grid(cols, rows, scale=scale_of_noise, normalize=normalize)


def flat_heightmap(dims: tuple[int, int]) -> np.ndarray:
    """All zeros.

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).

    Returns:
        A float64 array of shape ``dims``.

    Raises:
        ValueError: ``dims`` is not two integers >= 2.
    """
    return np.zeros(as_dims(dims), dtype=np.float64)


def rugged_heightmap(
    dims: tuple[int, int],
    scale_of_noise: float = 4.0,
    normalize: str | None = "none",
    *,
    seed: int | None = None,
) -> np.ndarray:
    """Perlin noise; pixel (col, row) samples the noise at (col, row) / scale_of_noise.

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).
        scale_of_noise: the noise's feature size, in pixels per lattice cell (> 0).
        normalize: ``"none"`` (or ``None``) for raw values (about +-0.7), ``"linear"``
            (``v * 0.5 + 0.5``) or ``"clip"`` (clipped to [0, 1]).
        seed: the noise seed (same seed, same map); ``None`` draws a fresh one.

    Returns:
        A float64 array of shape ``dims``.

    Raises:
        ValueError: ``dims``, ``scale_of_noise`` or ``normalize`` is not allowed.

    Example:
        ```python
        from ariel.simulation.environments.heightmaps import (
            rugged_heightmap,
            smooth_edges_heightmap,
        )

        dims = (50, 80)
        hills = rugged_heightmap(dims, 4.0, seed=42) * smooth_edges_heightmap(dims, 0.2)
        print(hills.shape, hills[0].max())  # (50, 80) 0.0: flat along the border
        ```
    """
    return _noise(as_dims(dims), scale_of_noise, normalize, seed)


def smooth_edges_heightmap(dims: tuple[int, int], edge_width: float = 0.2) -> np.ndarray:
    """A mask that is 0 on the border, rises smoothly (3t^2 - 2t^3) and is 1 further in.

    t = d / edge_width with d the distance to the nearest border in unit coordinates.

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).
        edge_width: the width of the rising band, as a fraction of the map's size (unit
            coordinates); <= 0 gives a hard step, 0 on the border and 1 inside.

    Returns:
        A float64 array of shape ``dims`` with values in [0, 1], to multiply a heightmap by.

    Raises:
        ValueError: ``dims`` is not two integers >= 2, or ``edge_width`` is not a finite
            number.
    """
    dims = as_dims(dims)
    width = _number(edge_width, "edge_width")
    x, y = _unit_grid(dims)
    distance = np.minimum(np.minimum(x, 1.0 - x), np.minimum(y, 1.0 - y))
    t = np.clip(distance / width, 0.0, 1.0) if width > 0 else (distance > 0).astype(float)
    return t * t * (3.0 - 2.0 * t)


def crater_heightmap(
    dims: tuple[int, int],
    crater_depth: float = 1.0,
    crater_radius: float = 0.3,
    height_of_noise: float = 0.3,
    scale_of_noise: float = 5.0,
    normalize: str = "none",
    *,
    seed: int | None = None,
) -> np.ndarray:
    """An inverted cone (lowest at the centre, rising linearly outwards) plus Perlin noise.

    height = crater_depth * r + height_of_noise * noise, r = distance from the centre in units
    of crater_radius (unit coordinates).

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).
        crater_depth: the cone's height per ``crater_radius`` of distance (>= 0).
        crater_radius: the radius unit, as a fraction of the map's size (> 0).
        height_of_noise: the weight of the Perlin noise added to the shape (>= 0).
        scale_of_noise: the noise's feature size, in pixels per lattice cell (> 0).
        normalize: ``"none"`` (raw noise, about +-0.7), ``"linear"`` (``v * 0.5 + 0.5``) or
            ``"clip"`` (clipped to [0, 1]).
        seed: the noise seed (same seed, same map); ``None`` draws a fresh one.

    Returns:
        A float64 array of shape ``dims``.

    Raises:
        ValueError: a number is negative (``crater_radius``: not positive) or not finite, or
            ``dims``, ``scale_of_noise`` or ``normalize`` is not allowed.
    """
    dims = as_dims(dims)
    depth = _non_negative(crater_depth, "crater_depth")
    radius = _number(crater_radius, "crater_radius")
    if radius <= 0:
        raise ValueError(f"crater_radius must be a positive number, got {crater_radius!r}")
    noise_height = _non_negative(height_of_noise, "height_of_noise")
    x, y = _unit_grid(dims)
    r = np.hypot((x - 0.5) / radius, (y - 0.5) / radius)
    return depth * r + noise_height * _noise(dims, scale_of_noise, normalize, seed)


def amphitheatre_heightmap(
    dims: tuple[int, int],
    inner_radius: float = 0.2,
    outer_radius: float = 0.45,
    cone_height: float = 1.0,
    height_of_noise: float = 0.3,
    scale_of_noise: float = 5.0,
    normalize: str = "none",
    *,
    seed: int | None = None,
) -> np.ndarray:
    """A flat arena (r <= inner_radius), a linear slope up to cone_height at outer_radius and a
    plateau beyond (r from the centre in unit coordinates), plus height_of_noise * Perlin noise.

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).
        inner_radius: the flat arena's radius, as a fraction of the map's size (>= 0).
        outer_radius: where the slope reaches the plateau (> ``inner_radius``).
        cone_height: the plateau's height above the arena (>= 0).
        height_of_noise: the weight of the Perlin noise added to the shape (>= 0).
        scale_of_noise: the noise's feature size, in pixels per lattice cell (> 0).
        normalize: ``"none"`` (raw noise, about +-0.7), ``"linear"`` (``v * 0.5 + 0.5``) or
            ``"clip"`` (clipped to [0, 1]).
        seed: the noise seed (same seed, same map); ``None`` draws a fresh one.

    Returns:
        A float64 array of shape ``dims``.

    Raises:
        ValueError: the radii are not ``0 <= inner_radius < outer_radius``, a height is
            negative or not finite, or ``dims``, ``scale_of_noise`` or ``normalize`` is not
            allowed.
    """
    dims = as_dims(dims)
    inner = _number(inner_radius, "inner_radius")
    outer = _number(outer_radius, "outer_radius")
    if not 0 <= inner < outer:
        raise ValueError(
            f"need 0 <= inner_radius < outer_radius, got {inner_radius!r}, {outer_radius!r}",
        )
    height = _non_negative(cone_height, "cone_height")
    noise_height = _non_negative(height_of_noise, "height_of_noise")
    x, y = _unit_grid(dims)
    r = np.hypot(x - 0.5, y - 0.5)
    profile = height * np.clip((r - inner) / (outer - inner), 0.0, 1.0)
    return profile + noise_height * _noise(dims, scale_of_noise, normalize, seed)


def amphitheater_heightmap(
    dims: tuple[int, int],
    ring_inner_radius: float = 0.2,
    ring_outer_radius: float = 0.45,
    cone_height: float = 1.0,
    height_of_noise: float = 0.3,
    scale_of_noise: float = 5.0,
    normalize: str = "none",
    *,
    seed: int | None = None,
) -> np.ndarray:
    """Upstream's name and keywords (``ring_inner_radius``, ``ring_outer_radius``) for
    `amphitheatre_heightmap`: the same map.

    Args:
        dims: ``(rows, cols)``, each an integer >= 2 (rows run along y).
        ring_inner_radius: the flat arena's radius, as a fraction of the map's size (>= 0).
        ring_outer_radius: where the slope reaches the plateau (> ``ring_inner_radius``).
        cone_height: the plateau's height above the arena (>= 0).
        height_of_noise: the weight of the Perlin noise added to the shape (>= 0).
        scale_of_noise: the noise's feature size, in pixels per lattice cell (> 0).
        normalize: ``"none"`` (raw noise, about +-0.7), ``"linear"`` (``v * 0.5 + 0.5``) or
            ``"clip"`` (clipped to [0, 1]).
        seed: the noise seed (same seed, same map); ``None`` draws a fresh one.

    Returns:
        A float64 array of shape ``dims``.

    Raises:
        ValueError: as `amphitheatre_heightmap`.
    """
    return amphitheatre_heightmap(
        dims,
        ring_inner_radius,
        ring_outer_radius,
        cone_height,
        height_of_noise,
        scale_of_noise,
        normalize,
        seed=seed,
    )
