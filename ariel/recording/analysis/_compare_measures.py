"""The numbers of `compare`: each run's measures at the budget (``final best``, ``AUC``, the QD
columns and the lineage measures, `_run_rows`), the per-condition summary (`_summary`), the
pairwise and omnibus tests of every measure with the notes they need (`_statistics`), and the
best-so-far curves per condition that ``best_so_far.png`` draws (`_best_curves`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ariel.recording.analysis import _compare_lineage as lineages
from ariel.recording.analysis._compare_design import MEASURES, QD_COLUMNS, whole_generations
from ariel.recording.analysis._compare_runs import RunCurve
from ariel.recording.analysis._compare_stats import (
    Design,
    Sample,
    location,
    median_band,
    omnibus_test,
    pairing_notes,
    pairwise_table,
    small_n_warning,
    tied_pairs_note,
)
from ariel.recording.store import best_so_far, on_grid

__all__ = ["GRID_POINTS"]

#: Points of the evaluations grid the best-so-far curves are drawn on (`_best_curves`).
GRID_POINTS = 200


def _by_condition(curves: Sequence[RunCurve]) -> dict[str, list[RunCurve]]:
    grouped: dict[str, list[RunCurve]] = {}
    for curve in curves:
        grouped.setdefault(curve.condition, []).append(curve)
    return grouped


def _best_curves(
    grouped: dict[str, list[RunCurve]], maximise: bool, budget: int
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per condition: (grid, median, low, high) of best so far over evaluations 1..budget.
    As for the AUC (`_measures`), a run's curve stands at the worst fitness any compared run
    finished with before its own first finished evaluation, and a run without one is left
    out (a condition lost its whole band to one such run, and its median its own floor)."""
    grid = np.unique(np.linspace(1, max(budget, 1), GRID_POINTS).round().astype(np.int64))
    worst = _worst([run for runs in grouped.values() for run in runs], maximise, budget)
    curves = {}
    for name, runs in grouped.items():
        rows = []
        for run in runs:
            row = on_grid(*best_so_far(run.evaluations, maximise), grid)
            finite = np.flatnonzero(np.isfinite(row))
            if len(finite):
                row[: finite[0]] = worst
                rows.append(row)
        values = np.array(rows) if rows else np.full((0, len(grid)), np.nan)
        curves[name] = (grid, *median_band(values))
    return curves


def _finished(curve: RunCurve, budget: int) -> np.ndarray:
    """The fitness of the run's finished evaluations among its first ``budget`` (in the order
    `best_so_far` counts them)."""
    ordered = curve.evaluations.sort_values(["generation", "eval_id"], kind="stable")
    ordered = ordered.iloc[:budget]
    fitness = ordered["fitness"].to_numpy(dtype=np.float64)
    return fitness[(ordered["status"] == "ok").to_numpy() & np.isfinite(fitness)]


def _worst(curves: Sequence[RunCurve], maximise: bool, budget: int) -> float:
    """The worst fitness any of ``curves``' finished evaluations had within ``budget`` (NaN
    without one): what `_measures` counts before a run's first finished evaluation."""
    found = [_finished(c, budget) for c in curves]
    values = np.concatenate(found) if found else np.array([])
    if not len(values):
        return math.nan
    return float(values.min() if maximise else values.max())


def _measures(
    curve: RunCurve, maximise: bool, budget: int, worst: float | None = None
) -> dict[str, float]:
    """A run's best so far after ``budget`` evaluations, and its AUC: the area under its
    best-so-far curve over evaluations 1..budget divided by their number, where the curve
    stands at ``worst`` before the run's first finished evaluation (default: the run's own
    worst finished fitness; `compare` gives the worst of all runs compared). NaN without a
    finished evaluation."""
    _, best = best_so_far(curve.evaluations, maximise)
    best = best[:budget]
    final = float(best[-1]) if len(best) == budget else math.nan
    finite = np.isfinite(best)
    if not finite.any():
        return {"final_best": final, "auc": math.nan}
    floor = _worst([curve], maximise, budget) if worst is None or math.isnan(worst) else worst
    return {"final_best": final, "auc": float(np.where(finite, best, floor).mean())}


def _qd_at_budget(curve: RunCurve, budget: int) -> dict[str, float]:
    """The run's QD columns at its last generation wholly within its first ``budget``
    evaluations (empty without QD columns or such a generation)."""
    if curve.generations is None or not len(curve.generations):
        return {}
    whole = whole_generations(curve.evaluations, budget)
    rows = curve.generations.loc[curve.generations["generation"].isin(whole)]
    if not len(rows):
        return {}
    last = rows.sort_values("generation").iloc[-1]
    return {c: float(last[c]) for c in QD_COLUMNS if c in rows.columns}


def _run_rows(
    curves: Sequence[RunCurve], truncated: Sequence[RunCurve], maximise: bool, budget: int
) -> list[dict[str, Any]]:
    worst = _worst(truncated, maximise, budget)
    return [
        {
            "condition": whole.condition,
            "seed": whole.seed,
            "evaluations": len(whole.evaluations),
            "compared_at": budget,
            **_measures(cut, maximise, budget, worst),
            **_qd_at_budget(whole, budget),
            **lineages.at_budget(whole, budget),
            "path": whole.path,
        }
        for whole, cut in zip(curves, truncated)
    ]


def _samples(runs: pd.DataFrame, column: str) -> dict[str, Sample]:
    return {
        str(name): Sample.of(group[column].to_numpy(dtype=np.float64), group["seed"].tolist())
        for name, group in runs.groupby("condition", sort=False)
    }


def _summary(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per condition: runs, then median / mean / sd of each measure, QD medians."""
    rows = []
    for name, group in runs.groupby("condition", sort=False):
        row: dict[str, object] = {"condition": name, "runs": len(group)}
        for column in MEASURES.values():
            for key, value in location(group[column].to_numpy(dtype=np.float64)).items():
                row[f"{column}_{key}"] = value
        for column in QD_COLUMNS:
            if column in group:
                # pandas has no type stubs: pyright reads a column as Series | DataFrame
                row[f"{column}_median"] = float(group[column].median())  # pyright: ignore[reportArgumentType]
        row.update(lineages.summary(group))
        rows.append(row)
    return pd.DataFrame(rows)


def _statistics(
    runs: pd.DataFrame, maximise: bool, choice: Design
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[str]]:
    """(pairwise rows of every measure, omnibus rows, notes on small n and missing pairs)."""
    rows, omnibus = [], []
    for measure, column in {**MEASURES, **lineages.measures(runs)}.items():
        samples = _samples(runs, column)
        higher = maximise if measure in MEASURES else True  # a lineage measure: A12 = P(higher)
        rows += pairwise_table(samples, maximise=higher, paired=choice.paired, measure=measure)
        found = omnibus_test(samples, paired=choice.paired, measure=measure)
        if found is not None:
            omnibus.append(found)
    lineages.relabel(rows)
    first = [r for r in rows if r["measure"] == "final best"]
    # Runs with a value of the first measure (a run without a finished evaluation has none):
    # the n its tests have, not the runs the folders hold.
    final = runs[MEASURES["final best"]].to_numpy(dtype=np.float64)
    sizes: dict[str, int] = {}
    for condition, valued in zip(runs["condition"], np.isfinite(final), strict=True):
        sizes[str(condition)] = sizes.get(str(condition), 0) + int(valued)
    notes = [
        small_n_warning(rows, sizes, choice, omnibus),  # rows: "final best" first
        tied_pairs_note(rows),
        *pairing_notes(first),
    ]
    return rows, omnibus, [n for n in notes if n]
