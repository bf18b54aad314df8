"""The height of a MuJoCo heightfield surface at world (x, y), matching MuJoCo exactly.

MuJoCo normalises a heightfield's elevation data to [0, 1] when it compiles (so only the
shape of a heightmap matters) and the surface spans z in [0, size_z] above the geom origin.
Row i of the data lies at y = -size_y + 2 size_y i / (nrow - 1), column j at
x = -size_x + 2 size_x j / (ncol - 1). Each grid cell is two triangles split along the
diagonal from (i, j) to (i + 1, j + 1): interpolating on those triangles (not bilinearly)
reproduces what ``mujoco.mj_ray`` and the collision code see.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ariel.simulation.environments._base import quat_to_mat

# Bisection steps for tilted heightfields: the bracket is at most a few metres, so 48 halvings
# take it well below a micrometre.
_BISECTION_STEPS = 48


def normalise_heightmap(heightmap: np.ndarray) -> np.ndarray:
    """What MuJoCo stores: data rescaled to [0, 1] (a constant map becomes all zeros)."""
    data = np.asarray(heightmap, dtype=np.float64)
    low, high = float(data.min()), float(data.max())
    if high - low <= 0.0:
        return np.zeros_like(data)
    # MuJoCo stores float32; round the same way so heights agree to the last bit.
    return ((data - low) / (high - low)).astype(np.float32).astype(np.float64)


class HeightfieldSurface:
    """Ground height of one heightfield geom (any pose whose up axis points up)."""

    def __init__(
        self,
        heightmap: np.ndarray,
        size: Sequence[float],
        pos: Sequence[float] = (0.0, 0.0, 0.0),
        quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    ) -> None:
        self.data = normalise_heightmap(heightmap)
        self.size = tuple(float(s) for s in size)
        self.pos = np.asarray(pos, dtype=float)
        self.rot = quat_to_mat(quat)
        # The world z axis in the geom frame: how local coordinates move along a vertical line.
        self._up_local = self.rot.T @ np.array([0.0, 0.0, 1.0])
        if self._up_local[2] <= 1e-6:
            raise ValueError("a heightfield must face up (tilt strictly below 90 degrees)")
        self._tilted = bool(np.hypot(self._up_local[0], self._up_local[1]) > 1e-12)

    def local_height(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Surface height in the geom frame at geom-frame (u, v); clamped at the edges."""
        nrow, ncol = self.data.shape
        size_x, size_y, size_z = self.size[:3]
        col = np.clip((u + size_x) / (2.0 * size_x) * (ncol - 1), 0.0, ncol - 1)
        row = np.clip((v + size_y) / (2.0 * size_y) * (nrow - 1), 0.0, nrow - 1)
        c = np.minimum(np.floor(col).astype(np.intp), ncol - 2)
        r = np.minimum(np.floor(row).astype(np.intp), nrow - 2)
        fu, fv = col - c, row - r
        z00 = self.data[r, c]
        z01 = self.data[r, c + 1]
        z10 = self.data[r + 1, c]
        z11 = self.data[r + 1, c + 1]
        lower = z00 + fu * (z01 - z00) + fv * (z11 - z01)  # triangle (00, 01, 11): fu >= fv
        upper = z00 + fv * (z10 - z00) + fu * (z11 - z10)  # triangle (00, 10, 11): fu < fv
        return size_z * np.where(fu >= fv, lower, upper)

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """World z of the surface directly under world (x, y)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        # Geom-frame coordinates of the world point (x, y, 0): local = base + z * up_local.
        offset = np.stack([x - self.pos[0], y - self.pos[1], -np.full_like(x, self.pos[2])], -1)
        base = offset @ self.rot
        up = self._up_local
        if not self._tilted:
            return (self.local_height(base[..., 0], base[..., 1]) - base[..., 2]) / up[2]
        # Tilted: solve local_z(z) = surface(local_x(z), local_y(z)) for z by bisection. On the
        # surface local_z is in [0, size_z], which brackets the root.
        low = (0.0 - base[..., 2]) / up[2]
        high = (self.size[2] - base[..., 2]) / up[2]
        for _ in range(_BISECTION_STEPS):
            mid = 0.5 * (low + high)
            gap = base[..., 2] + mid * up[2]
            gap -= self.local_height(base[..., 0] + mid * up[0], base[..., 1] + mid * up[1])
            above = gap > 0.0
            high = np.where(above, mid, high)
            low = np.where(above, low, mid)
        return 0.5 * (low + high)
