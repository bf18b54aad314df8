"""The figures of `ariel compare`: best so far against evaluations (median and 95 % bootstrap
band per condition, one legend entry each: the line over its band; beyond `LEGEND_INSIDE` conditions
the legends stand beside the figures; the y axis spans the data, not from 0), final
best per condition (box plot with every seed's point), and the bodies' morphology descriptors
over evaluations per condition (`morphology_series`: the runs' mean per bin of evaluations),
and the lineages (surviving lineages and the best body's ancestry depth over evaluations,
`_compare_lineage`). Matplotlib (Agg), PNG files, each written whole and never
through a link (`_files.atomic_write`); condition names are drawn as text (`figure_label`:
one line, no mathtext).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ariel.recording.store import (
    DESCRIPTORS,
    atomic_write,
    condition_colours,
    figure_label,
    integer_ticks,
)

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from ariel.recording.analysis._compare_runs import RunCurve

__all__ = [
    "MORPHOLOGY",
    "best_so_far_figure",
    "data_limits",
    "final_best_figure",
    "lineages_figure",
    "morphology_figure",
    "morphology_series",
]

#: Descriptors drawn over evaluations (those a reader of a co-evolution paper looks for).
MORPHOLOGY = ("num_modules", "num_limbs", "joints_ratio", "symmetry")
MORPHOLOGY_BINS = 20
_DPI = 110
_BAND_ALPHA = 0.2


def _pyplot() -> Any:
    import matplotlib  # lazy: heavy optional library (only where a figure is drawn)

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt  # lazy: heavy optional library, after the Agg backend

    return plt


#: Conditions whose legend still fits inside a panel; more go beside the figure.
LEGEND_INSIDE = 6
_LEGEND_ROWS = 24  # entries per legend column beside the figure


def _legend(
    axes: Axes,
    handles: Sequence[Artist | tuple[Artist, ...]] | None = None,
    labels: Sequence[str] | None = None,
) -> None:
    """The legend of ``axes`` (its labelled artists, or ``handles`` with ``labels``): inside
    it where it fits, else beside the figure (in columns of `_LEGEND_ROWS`), where it covers
    no curve and runs off no edge. A tuple handle is drawn as its parts overlaid."""
    if handles is None or labels is None:
        handles, labels = axes.get_legend_handles_labels()
    if len(handles) <= LEGEND_INSIDE:
        axes.legend(handles, labels, loc="best", fontsize="small")
        return
    axes.figure.legend(
        cast("list[Artist]", handles),  # a tuple handle draws as its parts (HandlerTuple)
        labels,
        loc="upper left",
        bbox_to_anchor=(1.0, 0.95),
        fontsize="small",
        ncols=-(-len(handles) // _LEGEND_ROWS),
    )


def _save(figure: Figure, path: Path) -> Path:
    with warnings.catch_warnings():  # many conditions: the legend takes the room; drawn anyway
        warnings.filterwarnings("ignore", "Tight layout not applied", UserWarning)
        figure.tight_layout()

    def write(temporary: Path) -> None:  # "tight": the legend beside, the labels, all in
        figure.savefig(temporary, dpi=_DPI, format="png", bbox_inches="tight")

    try:  # never through a link planted in the output folder (``compare/final_best.png -> ~/x``)
        atomic_write(path, write)
    finally:
        _pyplot().close(figure)
    return path


def best_so_far_figure(
    curves: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    path: Path,
    *,
    ylabel: str,
) -> Path:
    """``curves``: condition -> (evaluations grid, median, band low, band high)."""
    from matplotlib.patches import Patch  # lazy: heavy optional library

    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    colours = condition_colours(list(curves))
    handles: list[tuple[Patch, Line2D]] = []
    labels: list[str] = []
    for name, (grid, median, low, high) in curves.items():
        label = figure_label(name)
        (line,) = axes.plot(grid, median, color=colours[name], label=label, linewidth=1.8)
        axes.fill_between(grid, low, high, color=colours[name], alpha=_BAND_ALPHA, linewidth=0)
        band = Patch(facecolor=colours[name], alpha=_BAND_ALPHA)
        handles.append((band, line))  # one entry a condition: its median over its band
        labels.append(label)
    limits = data_limits([v for _, *lines in curves.values() for v in lines])
    if limits is not None:
        axes.set_ylim(*limits)
    axes.set_xlabel("evaluations")
    integer_ticks(axes.xaxis)
    axes.set_ylabel(ylabel)
    axes.set_title("best so far: median of the seeds, 95 % bootstrap band")
    axes.grid(alpha=0.3)
    _legend(axes, handles, labels)
    return _save(figure, path)


def data_limits(series: Sequence[np.ndarray], margin: float = 0.05) -> tuple[float, float] | None:
    """The y range of the finite values of ``series``, widened by ``margin`` of it on each
    side (an axis that starts where the data starts, not at 0); None without a value."""
    values = np.concatenate([np.asarray(s, dtype=np.float64).ravel() for s in series] or [[]])
    values = values[np.isfinite(values)]
    if not len(values):
        return None
    low, high = float(values.min()), float(values.max())
    pad = margin * (high - low) or margin * max(abs(high), 1e-9)
    return low - pad, high + pad


def final_best_figure(finals: Mapping[str, np.ndarray], path: Path, *, ylabel: str) -> Path:
    """``finals``: condition -> every seed's final best fitness."""
    plt = _pyplot()
    names = list(finals)
    figure, axes = plt.subplots(figsize=(max(4.5, 1.4 * len(names) + 2), 4.5))
    colours = condition_colours(names)
    data = [np.asarray(finals[n], float) for n in names]
    axes.boxplot(data, showfliers=False, widths=0.5)
    jitter = np.random.default_rng(0)  # fixed: the same runs draw the same figure
    for position, (name, values) in enumerate(zip(names, data), start=1):
        x = position + jitter.uniform(-0.12, 0.12, size=len(values))
        axes.scatter(x, values, color=colours[name], zorder=3, s=22, edgecolor="black")
    labels = [figure_label(n) for n in names]
    slanted = len(names) > 3 or max(map(len, labels)) > 15  # long names overlapped level
    axes.set_xticks(
        range(1, len(names) + 1),
        labels,
        rotation=30 if slanted else 0,
        ha="right" if slanted else "center",
        rotation_mode="anchor",
    )
    axes.set_ylabel(ylabel)
    axes.set_title("final best per run (one point per seed)")
    axes.grid(alpha=0.3, axis="y")
    return _save(figure, path)


def morphology_figure(
    series: Mapping[str, Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]],
    path: Path,
) -> Path:
    """``series``: descriptor -> condition -> (evaluations, median, 25th, 75th percentile) of
    the runs' mean descriptor per bin of evaluations."""
    plt = _pyplot()
    names = list(series)
    columns = min(2, len(names))
    rows = int(np.ceil(len(names) / columns))
    figure, grid = plt.subplots(rows, columns, figsize=(5.2 * columns, 3.2 * rows), squeeze=False)
    conditions = list(next(iter(series.values()), {}))
    colours = condition_colours(conditions)
    for axes, descriptor in zip(grid.flat, names):
        for condition, (x, median, low, high) in series[descriptor].items():
            axes.plot(x, median, color=colours[condition], label=figure_label(condition))
            axes.fill_between(x, low, high, color=colours[condition], alpha=0.15, linewidth=0)
        axes.set_title(descriptor)
        axes.set_xlabel("evaluations")
        axes.set_ylabel(DESCRIPTORS.get(descriptor, ("", False))[0])
        integer_ticks(axes.xaxis)
        axes.grid(alpha=0.3)
    for axes in list(grid.flat)[len(names) :]:
        axes.set_visible(False)
    _legend(grid.flat[0])
    figure.suptitle("morphology of the evaluated bodies: median of the seeds (band: 25-75 %)")
    return _save(figure, path)


def morphology_series(
    grouped: Mapping[str, Sequence[RunCurve]],
) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]]:
    """``grouped``: condition -> its runs (`_compare_runs.RunCurve`, evaluations up to the budget).

    Returns:
        descriptor -> condition -> (bin centres, median, 25 %, 75 %) of per-run bin means.
    """
    series: dict[str, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = {}
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


def _bin_means(evaluations: pd.DataFrame, descriptor: str, edges: np.ndarray) -> np.ndarray:
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


#: Each condition's line in ``lineages.png``, in order: told apart where their medians are equal.
_DASHES = ("-", "--", ":", "-.")

#: The panels of ``lineages.png``: `Comparison.runs` column -> (title, y label).
LINEAGE_PANELS = {
    "surviving_lineages": ("surviving lineages", "lineages (founders with a living descendant)"),
    "best_depth": ("depth of the best body's ancestry", "parent steps back to a founder"),
    "distinct_made": ("distinct bodies made", "morphologies (robot graphs)"),
}


def lineages_figure(
    series: Mapping[str, Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]],
    path: Path,
) -> Path:
    """``series``: column (`LINEAGE_PANELS`) -> condition -> (evaluations grid, median, band
    low, band high) of the runs' values after each generation, up to the budget; drawn as
    steps (a value holds from the evaluation that ended its generation)."""
    plt = _pyplot()
    names = [column for column in LINEAGE_PANELS if column in series]
    figure, grid = plt.subplots(1, len(names), figsize=(5.6 * len(names), 4.6), squeeze=False)
    conditions = list(dict.fromkeys(c for s in series.values() for c in s))
    colours = condition_colours(conditions)
    # Equal medians drew one condition's line over the other's: each its own dash; and a dot
    # at the final value (the last generation's, at the budget: a step of no width).
    dashes = {c: _DASHES[i % len(_DASHES)] for i, c in enumerate(conditions)}
    for axes, column in zip(grid.flat, names):
        for condition, (x, median, low, high) in series[column].items():
            colour, label = colours[condition], figure_label(condition)
            axes.plot(
                x,
                median,
                color=colour,
                label=label,
                linewidth=1.8,
                drawstyle="steps-post",
                linestyle=dashes[condition],
            )
            axes.plot(x[-1:], median[-1:], "o", color=colour, markersize=5)  # the final value
            axes.fill_between(x, low, high, color=colour, alpha=_BAND_ALPHA, lw=0, step="post")
        title, ylabel = LINEAGE_PANELS[column]
        axes.set_title(title)
        axes.set_xlabel("evaluations")
        axes.set_ylabel(ylabel)
        axes.set_ylim(bottom=0)
        integer_ticks(axes.xaxis)
        integer_ticks(axes.yaxis)
        axes.grid(alpha=0.3)
    _legend(grid.flat[0])
    figure.suptitle(
        "lineages and diversity after each generation: median of the seeds "
        "(band: 95 % bootstrap CI)"
    )
    return _save(figure, path)
