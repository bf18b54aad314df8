"""The statistics of `ariel compare`, as evolutionary-computation papers report them.

- Median of the seeds with a 95 % percentile-bootstrap confidence band (`scipy.stats.bootstrap`).
- Per pair of conditions: the difference of the medians with its bootstrap CI, the two-sided
  Mann-Whitney U test (`scipy.stats.mannwhitneyu`), p-values Holm-corrected over all pairs
  (Holm 1979), and the Vargha-Delaney A12 effect size (Vargha & Delaney 2000): the chance
  that a run of the first condition beats one of the second, ties counting half, "beats"
  meaning better in the fitness's direction (so a minimised fitness compares correctly).

Random resampling uses a fixed seed: the same runs give the same table.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = [
    "ALPHA",
    "a12",
    "effect_label",
    "holm",
    "median_band",
    "median_difference_ci",
    "pairwise_table",
]

ALPHA = 0.05
CONFIDENCE = 0.95
RESAMPLES = 2000
_SEED = 20240514


def _rng() -> np.random.Generator:
    return np.random.default_rng(_SEED)


def median_band(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Median over the rows (seeds) of ``values`` (seeds x points) and its 95 % bootstrap
    band, per column; the band is NaN where fewer than 2 seeds have a value."""
    from scipy.stats import bootstrap

    values = np.asarray(values, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN, as meant
        median = np.nanmedian(values, axis=0) if values.size else np.full(values.shape[1:], np.nan)
    low = np.full(median.shape, np.nan)
    high = np.full(median.shape, np.nan)
    full = np.isfinite(values).all(axis=0)
    if values.shape[0] >= 2 and full.any():
        result = bootstrap(
            (values[:, full],),
            np.median,
            axis=0,
            vectorized=True,
            n_resamples=RESAMPLES,
            confidence_level=CONFIDENCE,
            method="percentile",
            rng=_rng(),
        )
        low[full], high[full] = result.confidence_interval
    return median, low, high


def _median_difference(x: np.ndarray, y: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.median(x, axis=axis) - np.median(y, axis=axis)


def median_difference_ci(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """95 % bootstrap CI of median(a) - median(b) (resampling each sample on its own); NaN
    when either has fewer than 2 values."""
    from scipy.stats import bootstrap

    if len(a) < 2 or len(b) < 2:
        return math.nan, math.nan
    result = bootstrap(
        (np.asarray(a, float), np.asarray(b, float)),
        _median_difference,
        vectorized=True,
        paired=False,
        n_resamples=RESAMPLES,
        confidence_level=CONFIDENCE,
        method="percentile",
        rng=_rng(),
    )
    return float(result.confidence_interval.low), float(result.confidence_interval.high)


def a12(a: np.ndarray, b: np.ndarray, *, maximise: bool) -> float:
    """Vargha-Delaney A12: P(a run of ``a`` is better than one of ``b``) + P(tie) / 2.

    From the Mann-Whitney U of ``a`` (pairs with a > b, ties half): U / (n_a n_b) when higher
    is better, 1 minus it when lower is.
    """
    from scipy.stats import mannwhitneyu

    if len(a) == 0 or len(b) == 0:
        return math.nan
    u = float(mannwhitneyu(a, b, alternative="two-sided").statistic)
    share = u / (len(a) * len(b))
    return share if maximise else 1.0 - share


def _p_value(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import mannwhitneyu

    if len(a) == 0 or len(b) == 0:
        return math.nan
    p = float(mannwhitneyu(a, b, alternative="two-sided").pvalue)
    return 1.0 if math.isnan(p) else p  # all values tied: no evidence of a difference


def holm(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down correction of ``p_values`` (NaN stays NaN, counted out of m)."""
    p = np.asarray(p_values, dtype=np.float64)
    adjusted = np.full(p.shape, np.nan)
    known = np.flatnonzero(np.isfinite(p))
    m = len(known)
    running = 0.0
    for rank, index in enumerate(known[np.argsort(p[known], kind="stable")]):
        running = max(running, min(1.0, (m - rank) * p[index]))
        adjusted[index] = running
    return adjusted


def effect_label(value: float) -> str:
    """Vargha and Delaney's magnitude of A12 (0.5: no effect; symmetric around it)."""
    if math.isnan(value):
        return "-"
    distance = abs(value - 0.5)
    for limit, label in ((0.06, "negligible"), (0.14, "small"), (0.21, "medium")):
        if distance < limit:
            return label
    return "large"


def pairwise_table(finals: Mapping[str, np.ndarray], *, maximise: bool) -> list[dict[str, Any]]:
    """One row per pair of conditions (in the given order): n, medians, difference of medians
    (a - b) with its CI, Mann-Whitney p (raw and Holm-corrected), A12 (a beats b), effect, and
    which condition is better at `ALPHA` (``-`` when the difference is not significant)."""
    names = list(finals)
    rows = []
    for i, first in enumerate(names):
        for second in names[i + 1 :]:
            a = np.asarray(finals[first], float)
            b = np.asarray(finals[second], float)
            low, high = median_difference_ci(a, b)
            effect = a12(a, b, maximise=maximise)
            rows.append(
                {
                    "a": first,
                    "b": second,
                    "n_a": len(a),
                    "n_b": len(b),
                    "median_a": float(np.median(a)) if len(a) else math.nan,
                    "median_b": float(np.median(b)) if len(b) else math.nan,
                    "difference": float(np.median(a) - np.median(b))
                    if len(a) and len(b)
                    else math.nan,
                    "ci_low": low,
                    "ci_high": high,
                    "p_value": _p_value(a, b),
                    "a12": effect,
                    "effect": effect_label(effect),
                }
            )
    adjusted = holm(np.array([row["p_value"] for row in rows]))
    for row, p in zip(rows, adjusted):
        row["p_holm"] = float(p)
        significant = math.isfinite(p) and p < ALPHA
        row["better"] = (row["a"] if row["a12"] > 0.5 else row["b"]) if significant else "-"
    return rows
