"""Fitness helper for turning on the spot. To be MAXIMISED (more turning, less drift)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["turning_in_place"]


def turning_in_place(xy_history: ArrayLike) -> float:
    """Total absolute change of heading of successive displacements, divided by
    ``1 + |end - start|`` (planar); 0.0 for fewer than two points.

    Headings are unwrapped, so a full circle counts 2π; zero-length displacements have heading
    0 (``atan2(0, 0)``).

    Args:
        xy_history: ``(T, 2)`` or ``(T, 3)`` positions in metres (z ignored).

    Returns:
        The turn in radians per (1 + metre of drift) (higher is better); 0.0 for an empty
            history.

    Raises:
        ValueError: ``xy_history`` is not empty and not two-dimensional with >= 2 columns.
    """
    points = np.asarray(xy_history, dtype=np.float64)
    if points.size == 0:
        return 0.0
    if points.ndim != 2 or points.shape[1] < 2:
        raise ValueError(f"xy_history must have shape (T, 2) or (T, 3); got {points.shape}")
    if points.shape[0] < 2:
        return 0.0
    xy = points[:, :2]
    steps = np.diff(xy, axis=0)
    headings = np.unwrap(np.arctan2(steps[:, 1], steps[:, 0]))
    total_turn = float(np.abs(np.diff(headings)).sum())
    drift = float(np.linalg.norm(xy[-1] - xy[0]))
    return total_turn / (1.0 + drift)
