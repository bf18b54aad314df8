"""2-D Perlin gradient noise (Perlin 2002, "Improving Noise"), vectorised with numpy.

As upstream ARIEL: a permutation of 0..255 (doubled to 512) drawn from the noise's own
``np.random.default_rng(seed)``, 8 unit gradients at multiples of 45 degrees, the quintic fade
6t^5 - 15t^4 + 10t^3 and bilinear blending of the four corner contributions. Raw values lie
roughly within +-0.7 and are 0 at integer lattice points.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ariel.utils import global_generator

__all__ = ["NORMALIZE_METHODS", "PerlinNoise"]

#: Accepted values of `normalize`: raw values, v * 0.5 + 0.5, or clipped to [0, 1].
NORMALIZE_METHODS = ("none", "linear", "clip")


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


class PerlinNoise:
    """Seeded 2-D Perlin noise; same seed, same noise (``seed=None``: NumPy's global RNG).

    Args:
        seed: seeds the noise's own ``np.random.default_rng`` (the global RNGs are left alone);
            ``None`` draws the seed from NumPy's global RNG, so ``np.random.seed(n)`` before
            makes an unseeded terrain repeat, as every other stochastic component does.
    """

    def __init__(self, seed: int | None = None) -> None:
        self.seed = seed
        rng = global_generator() if seed is None else np.random.default_rng(seed)
        permutation = rng.permutation(256)
        self.permutation = np.concatenate([permutation, permutation]).astype(np.intp)
        angles = np.arange(8) * (np.pi / 4.0)
        self.gradients = np.stack([np.cos(angles), np.sin(angles)], axis=1)

    def __repr__(self) -> str:
        return f"PerlinNoise(seed={self.seed!r})"

    def _corner(self, xi: np.ndarray, yi: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """Dot product of the lattice corner's gradient with the offset (dx, dy) to it."""
        perm = self.permutation
        hashed = perm[(perm[xi & 255] + (yi & 255)) & 255]
        gradient = self.gradients[hashed % 8]
        return gradient[..., 0] * dx + gradient[..., 1] * dy

    def noise(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Noise at points (x, y) in lattice units (arrays broadcast)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        x0 = np.floor(x)
        y0 = np.floor(y)
        xf, yf = x - x0, y - y0
        xi, yi = x0.astype(np.intp), y0.astype(np.intp)
        n00 = self._corner(xi, yi, xf, yf)
        n10 = self._corner(xi + 1, yi, xf - 1.0, yf)
        n01 = self._corner(xi, yi + 1, xf, yf - 1.0)
        n11 = self._corner(xi + 1, yi + 1, xf - 1.0, yf - 1.0)
        u, v = _fade(xf), _fade(yf)
        bottom = n00 + u * (n10 - n00)
        top = n01 + u * (n11 - n01)
        return bottom + v * (top - bottom)

    def as_grid(
        self,
        width: int,
        height: int,
        scale: float = 64.0,
        normalize: str = "none",
    ) -> np.ndarray:
        """Noise on a (height, width) pixel grid; pixel (px, py) samples (px/scale, py/scale)."""
        for what, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value <= 0:
                raise ValueError(f"{what} must be a positive integer, got {value!r}")
        if (
            isinstance(scale, bool)
            or not isinstance(scale, numbers.Real)
            or not math.isfinite(scale)
            or scale <= 0
        ):
            raise ValueError(f"scale must be a positive number, got {scale!r}")
        if normalize not in NORMALIZE_METHODS:
            raise ValueError(
                f"unknown normalize {normalize!r}; allowed: {', '.join(NORMALIZE_METHODS)}",
            )
        px = np.arange(width, dtype=float) / float(scale)
        py = np.arange(height, dtype=float) / float(scale)
        values = self.noise(px[np.newaxis, :], py[:, np.newaxis])
        if normalize == "linear":
            return values * 0.5 + 0.5
        if normalize == "clip":
            return np.clip(values, 0.0, 1.0)
        return values
