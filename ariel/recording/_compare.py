"""`ariel compare`: conditions of a campaign (or plain run folders grouped by how their configs
differ) compared with statistics; writes ``compare/`` and returns a `Comparison`.

``compare/`` holds ``best_so_far.png``, ``final_best.png``, ``morphology.png`` (co-evolution
runs), ``stats.csv`` / ``stats.md`` (one row per pair of conditions, see `_compare_stats`),
``runs.csv`` (each run's final best) and ``compare.html``, one self-contained page with the
figures embedded. The fitness direction comes from the runs' records.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ariel.recording._campaign import fitness_maximise, is_campaign, load_campaign
from ariel.recording._compare_stats import median_band, pairwise_table
from ariel.recording._curves import best_so_far, on_grid
from ariel.recording._load import Run, load_run

__all__ = ["CompareError", "Comparison", "RunCurve", "compare", "compare_runs"]

GRID_POINTS = 200
MORPHOLOGY_BINS = 20


class CompareError(ValueError):
    """Runs that cannot be compared (none, different fitness functions, ...): one line."""


@dataclass
class RunCurve:
    """One run's part of a comparison: its condition, seed, and evaluations table (``fitness``,
    ``status``, ``generation``, ``eval_id``, descriptor columns)."""

    condition: str
    seed: int
    evaluations: Any
    path: str = ""


@dataclass
class Comparison:
    """What `compare` found and wrote (``stats`` and ``runs``: pandas DataFrames)."""

    out: Path
    title: str
    maximise: bool
    fitness_fn: str
    conditions: list[str]
    runs: Any
    stats: Any
    figures: dict[str, Path] = field(default_factory=dict)
    html: Path | None = None


# --------------------------------------------------------------------------------------------
# Finding the runs and their conditions
# --------------------------------------------------------------------------------------------


def _campaign_runs(path: Path) -> tuple[str, list[tuple[RunCurve, Run]]]:
    campaign = load_campaign(path)
    found = [
        (RunCurve(condition, seed, run.evaluations, str(run.path)), run)
        for (condition, seed), run in campaign.runs.items()
    ]
    return str(campaign.info.get("campaign_id", path.name)), found


def _flat(config: dict[str, Any], prefix: str = "") -> dict[str, str]:
    flat: dict[str, str] = {}
    for key, value in config.items():
        if isinstance(value, dict) and not key.endswith("options"):
            flat.update(_flat(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = json.dumps(value, sort_keys=True)
    return flat


_NOT_A_CONDITION = ("seed", "name", "description")


def _folder_runs(paths: Sequence[Path]) -> tuple[str, list[tuple[RunCurve, Run]]]:
    """Plain run folders, each condition named by the config values that tell it apart."""
    runs = [load_run(p) for p in paths]
    flats = []
    for run in runs:
        flat = _flat(run.config)
        flats.append(
            {
                k: v
                for k, v in flat.items()
                if k not in _NOT_A_CONDITION and not k.startswith("executor.")
            }
        )
    keys = sorted({k for f in flats for k in f})
    differing = [k for k in keys if len({f.get(k) for f in flats}) > 1]
    found = []
    for run, flat in zip(runs, flats):
        name = ",".join(f"{k}={flat.get(k, '-')}" for k in differing) or str(
            run.config.get("name", "runs")
        )
        seed = int(run.info.get("seed", run.config.get("seed", 0)))
        found.append((RunCurve(name, seed, run.evaluations, str(run.path)), run))
    return f"{len(runs)} runs", found


def _direction(runs: Sequence[Run]) -> tuple[bool, str]:
    names = {str(r.config.get("task", {}).get("fitness", "?")) for r in runs}
    if len(names) > 1:
        raise CompareError(
            f"the runs use different fitness functions ({', '.join(sorted(names))}); "
            "compare runs of one fitness function"
        )
    directions = {fitness_maximise(r.info) for r in runs}
    if len(directions) > 1:
        raise CompareError("the runs disagree on the fitness direction (maximise in run.json)")
    return directions.pop(), names.pop()


# --------------------------------------------------------------------------------------------
# Computing
# --------------------------------------------------------------------------------------------


def _by_condition(curves: Sequence[RunCurve]) -> dict[str, list[RunCurve]]:
    grouped: dict[str, list[RunCurve]] = {}
    for curve in curves:
        grouped.setdefault(curve.condition, []).append(curve)
    return grouped


def _best_curves(grouped: dict[str, list[RunCurve]], maximise: bool) -> tuple[dict, dict]:
    """Per condition: (grid, median, low, high) of best so far, and each run's final best."""
    curves, finals = {}, {}
    for name, runs in grouped.items():
        steps = [best_so_far(r.evaluations, maximise) for r in runs]
        longest = max((len(x) for x, _ in steps), default=0)
        grid = np.unique(np.linspace(1, max(longest, 1), GRID_POINTS).round().astype(np.int64))
        values = np.array([_held(on_grid(x, best, grid)) for x, best in steps])
        curves[name] = (grid, *median_band(values))
        finals[name] = np.array([best[-1] for _, best in steps if len(best)], dtype=np.float64)
        finals[name] = finals[name][np.isfinite(finals[name])]
    return curves, finals


def _held(values: np.ndarray) -> np.ndarray:
    """A run's last value held to the end of the grid (its condition's longest run)."""
    finite = np.flatnonzero(np.isfinite(values))
    if len(finite):
        values[finite[-1] + 1 :] = values[finite[-1]]
    return values


def _morphology(grouped: dict[str, list[RunCurve]]) -> dict[str, dict[str, tuple]]:
    """descriptor -> condition -> (bin centres, median, 25 %, 75 %) of per-run bin means."""
    from ariel.recording._compare_plots import MORPHOLOGY

    series: dict[str, dict[str, tuple]] = {}
    for descriptor in MORPHOLOGY:
        per_condition = {}
        for name, runs in grouped.items():
            if not all(descriptor in r.evaluations.columns for r in runs):
                continue
            longest = max(len(r.evaluations) for r in runs)
            edges = np.linspace(0, longest, max(1, min(MORPHOLOGY_BINS, longest)) + 1)
            means = np.array([_bin_means(r.evaluations, descriptor, edges) for r in runs])
            if not np.isfinite(means).any():
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN bin: NaN
                low, median, high = np.nanpercentile(means, [25, 50, 75], axis=0)
            per_condition[name] = ((edges[:-1] + edges[1:]) / 2, median, low, high)
        if per_condition:
            series[descriptor] = per_condition
    return series


def _bin_means(evaluations: Any, descriptor: str, edges: np.ndarray) -> np.ndarray:
    ordered = evaluations.sort_values(["generation", "eval_id"], kind="stable")
    values = ordered[descriptor].to_numpy(dtype=np.float64, na_value=np.nan)
    position = np.arange(len(values))
    bins = np.digitize(position, edges[1:-1])
    means = np.full(len(edges) - 1, np.nan)
    for b in range(len(means)):
        inside = values[bins == b]
        if np.isfinite(inside).any():
            means[b] = np.nanmean(inside)
    return means


# --------------------------------------------------------------------------------------------
# The comparison
# --------------------------------------------------------------------------------------------


def compare_runs(
    curves: Sequence[RunCurve],
    out: str | Path,
    *,
    maximise: bool,
    fitness_fn: str = "fitness",
    title: str = "comparison",
) -> Comparison:
    """Compare ``curves`` (runs with their conditions) and write ``out`` (see the module
    docstring); the core of `compare`, usable on any evaluations tables."""
    import pandas as pd

    from ariel.recording import _compare_plots as plots
    from ariel.recording._axes import fitness_label
    from ariel.recording._compare_html import write_html, write_markdown

    grouped = _by_condition(curves)
    if not grouped:
        raise CompareError("no run with a finished generation to compare")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ylabel = fitness_label(fitness_fn, maximise, what="best fitness")
    best, finals = _best_curves(grouped, maximise)
    stats = pd.DataFrame(pairwise_table(finals, maximise=maximise))
    runs = pd.DataFrame(
        [
            {
                "condition": c.condition,
                "seed": c.seed,
                "evaluations": len(c.evaluations),
                "final_best": best_so_far(c.evaluations, maximise)[1][-1]
                if len(c.evaluations)
                else math.nan,
                "path": c.path,
            }
            for c in curves
        ]
    )
    figures = {
        "best_so_far": plots.best_so_far_figure(best, out / "best_so_far.png", ylabel=ylabel),
        "final_best": plots.final_best_figure(finals, out / "final_best.png", ylabel=ylabel),
    }
    morphology = _morphology(grouped)
    if morphology:
        figures["morphology"] = plots.morphology_figure(morphology, out / "morphology.png")
    stats.to_csv(out / "stats.csv", index=False)
    runs.to_csv(out / "runs.csv", index=False)
    comparison = Comparison(
        out, title, maximise, fitness_fn, list(grouped), runs, stats, figures, None
    )
    write_markdown(comparison, out / "stats.md")
    comparison.html = write_html(comparison, out / "compare.html")
    return comparison


def compare(paths: Sequence[str | Path], *, out: str | Path | None = None) -> Comparison:
    """Compare a campaign's conditions (one campaign folder) or plain run folders (grouped by
    their config difference). ``out``: default ``CAMPAIGN_DIR/compare``, or ``compare`` in
    the run folders' common parent."""
    import os

    paths = [Path(p) for p in paths]
    if not paths:
        raise CompareError("give a campaign folder or run folders to compare")
    if len(paths) == 1 and is_campaign(paths[0]):
        title, found = _campaign_runs(paths[0])
        default = paths[0] / "compare"
    else:
        campaigns = [p for p in paths if is_campaign(p)]
        if campaigns:
            raise CompareError(
                f"{str(campaigns[0])!r} is a campaign: compare one campaign alone, or run folders"
            )
        title, found = _folder_runs(paths)
        default = Path(os.path.commonpath([p.resolve() for p in paths])) / "compare"
    found = [(c, r) for c, r in found if r.generations_done > 0]
    if not found:
        raise CompareError("no run with a finished generation to compare")
    maximise, fitness_fn = _direction([r for _, r in found])
    return compare_runs(
        [c for c, _ in found],
        out if out is not None else default,
        maximise=maximise,
        fitness_fn=fitness_fn,
        title=title,
    )
