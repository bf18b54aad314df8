"""Fitness helpers for gait learning: how far and how fast the robot moved in the plane."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MAX_WINDOWS",
    "sustained_displacement",
    "window_count_error",
    "x_speed",
    "xy_displacement",
    "y_speed",
]

MAX_WINDOWS = 100_000
"""`sustained_displacement` cuts a path into at most this many windows, or one a sample where
the path has more samples: each window holds a few arrays' entries."""


def _planar(point: ArrayLike, name: str) -> np.ndarray:
    """First two coordinates of a position (``(x, y)`` or ``(x, y, z)``) as float64."""
    arr = np.asarray(point, dtype=np.float64).reshape(-1)
    if arr.size < 2:
        raise ValueError(f"{name} needs at least x and y; got {arr.size} value(s)")
    return arr[:2]


def xy_displacement(xy1: ArrayLike, xy2: ArrayLike) -> float:
    """Euclidean distance between two positions in the xy-plane (z is ignored).

    Args:
        xy1: the first position, ``(x, y)`` or ``(x, y, z)``, in metres.
        xy2: the second position, in the same form.

    Returns:
        The planar distance in metres (>= 0).

    Raises:
        ValueError: a position has fewer than two values.
    """
    return float(np.linalg.norm(_planar(xy2, "xy2") - _planar(xy1, "xy1")))


def x_speed(xy1: ArrayLike, xy2: ArrayLike, dt: float) -> float:
    """``|x2 - x1| / dt``; 0.0 when ``dt <= 0``.

    Args:
        xy1: the earlier position, ``(x, y)`` or ``(x, y, z)``, in metres.
        xy2: the later position, in the same form.
        dt: the time between the two positions, in seconds.

    Returns:
        The absolute speed along x in m/s.

    Raises:
        ValueError: a position has fewer than two values (checked only when ``dt > 0``).
    """
    if dt <= 0:
        return 0.0
    return float(abs(_planar(xy2, "xy2")[0] - _planar(xy1, "xy1")[0]) / dt)


def y_speed(xy1: ArrayLike, xy2: ArrayLike, dt: float) -> float:
    """``|y2 - y1| / dt``; 0.0 when ``dt <= 0``.

    Args:
        xy1: the earlier position, ``(x, y)`` or ``(x, y, z)``, in metres.
        xy2: the later position, in the same form.
        dt: the time between the two positions, in seconds.

    Returns:
        The absolute speed along y in m/s.

    Raises:
        ValueError: a position has fewer than two values (checked only when ``dt > 0``).
    """
    if dt <= 0:
        return 0.0
    return float(abs(_planar(xy2, "xy2")[1] - _planar(xy1, "xy1")[1]) / dt)


def window_count_error(span: float, samples: int, window: float) -> str | None:
    """Why `sustained_displacement` refuses ``window`` on a path, or None when it takes it.

    The windows (``span / window``) must number at most the larger of `MAX_WINDOWS` and
    ``samples``: more windows than samples measure nothing more, and a tiny window would take
    all memory.

    Args:
        span: the path's duration in seconds (last sample time minus first).
        samples: the path's number of samples.
        window: the window length in seconds (> 0).

    Returns:
        One line saying how many windows that is and the shortest window allowed, or None.
    """
    allowed = max(MAX_WINDOWS, int(samples))
    count = span / window  # a float, never an int: no overflow
    if not count > allowed * (1 + 1e-6):  # relative: a path's span is a sum of float steps
        return None
    shown = f"{count:,.0f}" if count < 1e12 else f"{count:.3g}"  # 1e+05 read as the limit
    return (
        f"window {window!r} s cuts the {span:.6g} s path into {shown} windows, more "
        f"than the {allowed:,} allowed (the larger of {MAX_WINDOWS:,} and the path's samples): "
        f"give a window of at least {_rounded_up(span / allowed):.3g} s"
    )


def _rounded_up(value: float) -> float:
    """``value`` rounded up to three significant digits: the shortest window named in the
    message must itself be taken when pasted (rounded to nearest, it could be refused)."""
    step = 10.0 ** (np.floor(np.log10(value)) - 2)
    return float(np.ceil(value / step - 1e-9) * step)  # 1e-5 / 1e-7 is 100.00000000000001


def sustained_displacement(times: ArrayLike, xy: ArrayLike, window: float = 1.0) -> float:
    """Planar displacement at the path's typical pace: robust to one late fall or lunge.

    The path is cut into consecutive windows of ``window`` seconds (positions at the window
    edges interpolated between samples); each window's progress is its displacement along the
    net direction (first to last position). The result is the median window's progress scaled
    to the whole span (times span / window): a steady gait scores its `xy_displacement`; a
    body that tips over once scores what it does in its other windows.

    Args:
        times: the ``T`` sample times in seconds, ascending.
        xy: the path, ``(T, 2+)`` positions in metres (columns past x and y are ignored).
        window: the window length in seconds (> 0): at most `MAX_WINDOWS` windows in the
            span, or as many as the path has samples (`window_count_error`).

    Returns:
        The displacement in metres. Never negative (a typical window going nowhere or
            backwards scores 0); a span shorter than one window scores its `xy_displacement`,
            and an empty path 0.0.

    Raises:
        ValueError: ``xy`` is not ``(T, 2+)`` with ``T = len(times)``, ``window <= 0``, or
            ``window`` so short that the span holds more windows than allowed.

    Example:
        ```python
        import numpy as np

        from ariel.simulation.tasks.gait_learning import sustained_displacement

        times = np.linspace(0.0, 10.0, 101)
        xy = np.stack([0.1 * times, np.zeros_like(times)], axis=1)  # steady 0.1 m/s along x
        xy[-10:, 0] += 0.5  # a lunge in the last second
        print(round(sustained_displacement(times, xy), 3))  # 1.0: the lunge is ignored
        ```
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    path = np.asarray(xy, dtype=np.float64)
    if path.ndim != 2 or path.shape[0] != t.size or path.shape[1] < 2:
        raise ValueError(f"xy must be (T, 2+) with T = len(times); got {path.shape}, T={t.size}")
    if not window > 0:
        raise ValueError(f"window must be > 0 seconds, not {window!r}")
    span = float(t[-1] - t[0]) if t.size else 0.0
    too_many = window_count_error(span, t.size, window)
    if too_many is not None:
        raise ValueError(too_many)
    count = int(np.floor(span / window + 1e-9))
    if count < 1:
        return xy_displacement(path[0], path[-1]) if t.size else 0.0
    net = path[-1, :2] - path[0, :2]
    length = float(np.linalg.norm(net))
    if length < 1e-12:
        return 0.0
    edges = t[0] + window * np.arange(count + 1)
    at_edges = np.stack([np.interp(edges, t, path[:, 0]), np.interp(edges, t, path[:, 1])], 1)
    progress = np.diff(at_edges, axis=0) @ (net / length)
    return float(max(0.0, np.median(progress)) * span / window)
