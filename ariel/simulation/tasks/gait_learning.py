"""Fitness helpers for gait learning: how far and how fast the robot moved in the plane."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["x_speed", "xy_displacement", "y_speed"]


def _planar(point: ArrayLike, name: str) -> np.ndarray:
    """First two coordinates of a position (``(x, y)`` or ``(x, y, z)``) as float64."""
    arr = np.asarray(point, dtype=np.float64).reshape(-1)
    if arr.size < 2:
        raise ValueError(f"{name} needs at least x and y; got {arr.size} value(s)")
    return arr[:2]


def xy_displacement(xy1: ArrayLike, xy2: ArrayLike) -> float:
    """Euclidean distance between two positions in the xy-plane (z is ignored)."""
    return float(np.linalg.norm(_planar(xy2, "xy2") - _planar(xy1, "xy1")))


def x_speed(xy1: ArrayLike, xy2: ArrayLike, dt: float) -> float:
    """``|x2 - x1| / dt``; 0.0 when ``dt <= 0``."""
    if dt <= 0:
        return 0.0
    return float(abs(_planar(xy2, "xy2")[0] - _planar(xy1, "xy1")[0]) / dt)


def y_speed(xy1: ArrayLike, xy2: ArrayLike, dt: float) -> float:
    """``|y2 - y1| / dt``; 0.0 when ``dt <= 0``."""
    if dt <= 0:
        return 0.0
    return float(abs(_planar(xy2, "xy2")[1] - _planar(xy1, "xy1")[1]) / dt)
