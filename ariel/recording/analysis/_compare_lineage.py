"""The lineage measures of `ariel compare`, from each run's lineage in the ALife phylogeny
standard (`ariel.recording.lineage_statistics`), at the budget compared:

- ``surviving lineages``: the founders (bodies made from a random genotype: a GA's or
  MAP-Elites' generation 0; every body of random search) with a descendant in the population
  after the selection of the run's last generation wholly within the budget;
- ``best depth``: parent steps on the longest chain from that population's best body back to
  a founder: how many rounds of variation made it;
- ``distinct bodies``: how many different morphologies (robot graphs compared by structure,
  `graph_key`) the run has made by then, every body that could be built counted once: the
  diversity any body optimizer can be measured by, archive or not.

They get the fitness measures' treatment (`_compare_stats`: the design's tests, Holm over the
pairs, A12, the omnibus test; median, mean and sd per condition), but neither direction is
better: A12 is the chance that a run of A has the higher value, and ``better`` names the
higher condition as ``higher: A``. ``lineages.png`` draws both over evaluations per condition.
A brain-only run (one fixed body) has no lineage: its values are NaN, left out of the tests as
a missing value is; a comparison without a co-evolution run shows no lineage measure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.analysis._compare_design import whole_generations
from ariel.recording.analysis._compare_plots import lineages_figure
from ariel.recording.analysis._compare_stats import location, median_band
from ariel.recording.store import lineage, lineage_statistics, on_grid, stored_graph_key

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.analysis._compare_runs import RunCurve
    from ariel.recording.store import Run

__all__ = [
    "FIGURE",
    "LINEAGE_MEASURES",
    "at_budget",
    "figure",
    "measures",
    "relabel",
    "run_lineage",
    "series",
    "summary",
]

#: Measure name -> its column in `Comparison.runs` (and in `run_lineage`'s table).
LINEAGE_MEASURES = {
    "surviving lineages": "surviving_lineages",
    "best depth": "best_depth",
    "distinct bodies": "distinct_made",
}
#: The figure's file in ``compare/``.
FIGURE = "lineages.png"
GRID_POINTS = 200  # as best_so_far.png


def run_lineage(run: Run) -> pd.DataFrame | None:
    """Per finished generation of ``run``: ``generation``, ``evaluations`` (done by its end)
    and the `LINEAGE_MEASURES` columns (floats, NaN for no best); None for a brain-only run
    or one without a finished generation."""
    if not run.generations_done or run.brain_only:
        return None
    stats = lineage_statistics(lineage(run))
    counts = run.evaluations.groupby("generation").size()
    done = counts.reindex(range(run.generations_done), fill_value=0).cumsum()
    stats["evaluations"] = done.reindex(stats["generation"]).to_numpy()
    made = _distinct_made(run)
    stats["distinct_made"] = [made.get(int(g), 0) for g in stats["generation"]]
    for column in LINEAGE_MEASURES.values():
        stats[column] = stats[column].to_numpy(dtype=np.float64, na_value=np.nan)
    return stats.loc[:, ["generation", "evaluations", *LINEAGE_MEASURES.values()]]


def _distinct_made(run: Run) -> dict[int, int]:
    """Generation -> distinct morphologies among the bodies made up to it (its new bodies and
    every earlier generation's; a body that could not be built has no graph and is left out)."""
    bodies = run.bodies
    new = bodies.loc[bodies["is_new"], ["generation", "graph", "body_id"]]
    new = new.sort_values("generation")
    seen: set[str] = set()
    counts: dict[int, int] = {}
    for generation, graph, body_id in new.itertuples(index=False):
        if graph:
            seen.add(stored_graph_key(graph, body_id))
        counts[int(generation)] = len(seen)
    return counts


def at_budget(curve: RunCurve, budget: int) -> dict[str, float]:
    """A run's lineage measures after its last generation wholly within its first ``budget``
    evaluations (NaN where there is none); empty for a run without a lineage."""
    table = getattr(curve, "lineage", None)
    if table is None:
        return {}
    columns = [column for column in LINEAGE_MEASURES.values() if column in table]
    rows = table[table["generation"].isin(whole_generations(curve.evaluations, budget))]
    if not len(rows):
        return dict.fromkeys(columns, math.nan)
    last = rows.sort_values("generation").iloc[-1]
    return {column: float(last[column]) for column in columns}


def no_generation_note(curves: Sequence[RunCurve], budget: int) -> str | None:
    """A warning naming the runs with a lineage of which no generation lies wholly within the
    ``budget`` compared (their first generation alone is larger): their lineage measures are
    missing, which the tables otherwise showed as '-' without a word."""
    short = [
        c
        for c in curves
        if getattr(c, "lineage", None) is not None and not whole_generations(c.evaluations, budget)
    ]
    if not short:
        return None
    names = ", ".join(f"{c.condition} seed {c.seed}" for c in short[:5])
    return (
        f"{len(short)} run(s) finish no generation within the {budget:,} evaluations compared "
        f"({names}{', ...' if len(short) > 5 else ''}): their first generation alone is larger, "
        "so their lineage measures are missing"
    )


def measures(runs: pd.DataFrame) -> dict[str, str]:
    """The `LINEAGE_MEASURES` that ``runs`` (`Comparison.runs`) have: none where no run has
    a lineage (synthetic curves, brain-only runs)."""
    return {name: column for name, column in LINEAGE_MEASURES.items() if column in runs}


def summary(group: pd.DataFrame) -> dict[str, float]:
    """``<column>_median``, ``_mean`` and ``_sd`` of each lineage measure of one condition's
    runs (`location`), as the fitness measures have them."""
    return {
        f"{column}_{key}": value
        for column in measures(group).values()
        for key, value in location(group[column].to_numpy(dtype=np.float64)).items()
    }


def relabel(rows: Sequence[dict[str, Any]]) -> None:
    """``better`` of the lineage measures' pairs: ``higher: A`` (no direction is better)."""
    for row in rows:
        if row["measure"] in LINEAGE_MEASURES and row["better"] != "-":
            row["better"] = f"higher: {row['better']}"


def series(
    grouped: Mapping[str, Sequence[RunCurve]], budget: int
) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]]:
    """Column -> condition -> (evaluations 1..budget on a grid, median, 95 % band low, high)
    of the runs' lineage measures after each generation (a step curve: a generation's value
    from the evaluation that ended it on); conditions without a lineage are left out."""
    grid = np.unique(np.linspace(1, max(budget, 1), GRID_POINTS).round().astype(np.int64))
    found: dict[str, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = {}
    for name, runs in grouped.items():
        tables = [t for r in runs if (t := getattr(r, "lineage", None)) is not None]
        if not tables:
            continue
        for column in (c for c in LINEAGE_MEASURES.values() if c in tables[0]):
            values = np.array(
                [
                    on_grid(t["evaluations"].to_numpy(np.int64), t[column].to_numpy(float), grid)
                    for t in tables
                ]
            )
            found.setdefault(column, {})[name] = (grid, *median_band(values))
    return found


def figure(grouped: Mapping[str, Sequence[RunCurve]], budget: int, out: Path) -> dict[str, Path]:
    """``{"lineages": out / FIGURE}`` after drawing it (`_compare_plots.lineages_figure`);
    empty, with nothing drawn, where no run has a lineage."""
    drawn = series(grouped, budget)
    return {"lineages": lineages_figure(drawn, out / FIGURE)} if drawn else {}
