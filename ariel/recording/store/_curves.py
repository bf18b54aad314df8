"""Best-so-far fitness of a run against its evaluations, and on a grid shared by many runs.

The x axis is evaluations, not generations: conditions may differ in evaluations per
generation. Evaluations are counted in generation order, and within a generation in eval-id
order (body, iteration, candidate), so the curve is the same however results arrived. Only
finished evaluations (status ``ok``, finite fitness) count.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["best_so_far", "on_grid"]


def best_so_far(evaluations: pd.DataFrame, maximise: bool) -> tuple[np.ndarray, np.ndarray]:
    """(evaluations 1..n, best fitness so far; NaN before the first finished evaluation)."""
    ordered = evaluations.sort_values(["generation", "eval_id"], kind="stable")
    fitness = ordered["fitness"].to_numpy(dtype=np.float64)
    ok = (ordered["status"] == "ok").to_numpy() & np.isfinite(fitness)
    sign = 1.0 if maximise else -1.0  # the running maximum of the oriented fitness
    oriented = np.where(ok, sign * fitness, -np.inf)
    best = np.maximum.accumulate(oriented) if len(oriented) else oriented
    best = np.where(np.isfinite(best), sign * best, np.nan)
    return np.arange(1, len(best) + 1, dtype=np.int64), best


def on_grid(x: np.ndarray, best: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """The step curve (``x``, ``best``) at ``grid``; NaN before its first point and after its
    last (a run that stopped early has no value where it never got)."""
    index = np.searchsorted(x, grid, side="right") - 1
    values = np.where(index >= 0, best[np.clip(index, 0, None)] if len(best) else np.nan, np.nan)
    if len(x):
        values = np.where(grid > x[-1], np.nan, values)
    return values.astype(np.float64)
