"""The report's MAP-Elites figure, ``archive.png``: the final archive as its description says
it is (`Run.archive_description`), a grid as a heatmap of fitness per cell (over the first two
measures; more are folded by their best), a CVT as its cells coloured by their elite's fitness
(`_cvt`), and the bodies of the best cells rendered in a grid of thumbnails (left out where
OpenGL is missing). Measure 0 runs across (x) and measure 1 up (y), as the Rerun viewer draws
the archive; with one measure, it runs across a single band."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import KDTree

from ariel.errors import DamagedRunError
from ariel.recording.rerun import CvtCells, archive_cells, archive_grid, three_quarter_view
from ariel.recording.store import (
    DESCRIPTORS,
    Run,
    archive_cell_count,
    descriptor_label,
    figure_label,
    fitness_label,
    integer_ticks,
    one_line,
)
from ariel.utils import mujoco_module

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes
    from matplotlib.collections import PathCollection
    from matplotlib.figure import Figure
    from matplotlib.image import AxesImage
    from PIL import Image

    from ariel.recording.analysis._report import Report
    from ariel.recording.store import JsonObject

__all__ = ["archive_figure"]

THUMBNAILS = 6  # the best cells whose bodies are drawn
_PIXELS = 400  # a CVT's cells are drawn as an image this many pixels a side


def _grid(archive: pd.DataFrame, maximise: bool) -> np.ndarray:
    """Fitness per cell as a 2D array, an image's rows by columns: a row per bin of measure 1
    (one row with one measure), a column per bin of measure 0; NaN: empty."""
    grid = archive_grid(archive.to_dict("records"))
    best = np.fmax if maximise else np.fmin
    while grid.ndim > 2:  # fold the measures beyond the second by their best cell
        grid = best.reduce(grid, axis=-1)
    return grid.reshape(grid.shape[0], -1).T


def _thumbnail(run: Run, body_id: str) -> Image.Image:
    """The rendered start pose of ``body_id``'s best evaluation."""
    mujoco = mujoco_module()

    from ariel.evaluation import build  # lazy: imports mujoco (as above)
    from ariel.recording.resim import replay_task  # lazy: slow (~0.6 s: the engine, networkx)
    from ariel.utils.renderers import single_frame_renderer  # lazy: imports mujoco (as above)

    body = run.bodies[run.bodies["body_id"] == body_id].iloc[-1]
    evals = run.evaluations
    row = evals[evals["eval_id"] == body["best_eval_id"]].iloc[0].to_dict()
    built = build(replay_task(run, row))
    size = max(float(body.get(k) or 0.0) for k in ("extent_x", "extent_y", "extent_z")) or 1.0
    data = mujoco.MjData(built.model)
    try:
        view = three_quarter_view(built, size)
        return single_frame_renderer(built.model, data, steps=0, width=240, height=180, **view)
    except ValueError:  # no orthographic camera: the free camera
        return single_frame_renderer(built.model, data, steps=0, width=240, height=180)


def _cvt(axes: Axes, archive: pd.DataFrame, description: JsonObject) -> AxesImage | PathCollection:
    """A CVT archive on ``axes`` (measure 0 across, measure 1 up): with one or two measures its
    cells, the regions nearest to each centroid in the measures scaled to [0, 1] (as the run
    placed bodies), coloured by their elite's fitness (blank: empty); with more, whose cells
    do not lie flat, only its centroids, coloured (hollow: empty). Centroids are dots."""
    cells = archive_cells(archive.to_dict("records"), description)
    assert isinstance(cells, CvtCells)  # description["kind"] == "cvt" (archive_figure checks)
    low, high = cells.ranges[:, 0], cells.ranges[:, 1]
    unit = (cells.centroids - low) / (high - low)
    count, flat = len(unit), unit.shape[1] <= 2
    across = cells.centroids[:, 0]
    up = cells.centroids[:, 1] if unit.shape[1] > 1 else np.full(count, 0.5)
    span = (low[1], high[1]) if unit.shape[1] > 1 else (0.0, 1.0)  # up
    filled = np.isfinite(cells.fitness)
    if flat:
        steps = (np.arange(_PIXELS) + 0.5) / _PIXELS
        rows, columns = np.meshgrid(steps, steps, indexing="ij")
        # a pixel's point: its column along measure 0, its row along measure 1
        pixels = np.column_stack([columns.ravel(), rows.ravel()])[:, : unit.shape[1]]
        _, nearest = KDTree(unit, leafsize=16).query(pixels)  # cKDTree's leaf size: its tree
        labels = nearest.reshape(_PIXELS, _PIXELS)
        edges = np.zeros(labels.shape, dtype=bool)  # where a pixel's cell is not its neighbour's
        edges[:, 1:] |= labels[:, 1:] != labels[:, :-1]
        edges[1:, :] |= labels[1:, :] != labels[:-1, :]
        extent = (low[0], high[0], span[0], span[1])
        image = cells.fitness[labels]
        shown = axes.imshow(image, origin="lower", aspect="auto", cmap="viridis", extent=extent)
        lines = np.where(edges, 1.0, np.nan)  # light grey
        axes.imshow(
            lines, origin="lower", aspect="auto", cmap="Greys", vmin=0, vmax=3, extent=extent
        )
        axes.scatter(across, up, s=5, c="black", alpha=0.6, linewidths=0)
        return shown
    axes.scatter(across[~filled], up[~filled], s=30, facecolors="none", edgecolors="grey")
    shown = axes.scatter(across[filled], up[filled], s=30, c=cells.fitness[filled], cmap="viridis")
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(*span)
    return shown


def _title(run: Run, archive: pd.DataFrame, description: JsonObject, last: int) -> str:
    """``archive after generation N: C cells (P%)``; a novelty run keeps two archives, and
    this one is its result archive, not the novelty archive selection uses."""
    coverage = len(archive) / archive_cell_count(description)
    kind = "CVT archive" if description["kind"] == "cvt" else "archive"
    title = f"after generation {last}: {len(archive)} cells ({coverage:.0%})"
    if run.body_optimizer == "novelty":
        return f"result {kind} {title}\nthe best body per cell (not the novelty archive)"
    return f"{kind} {title}"


def archive_figure(
    report: Report,
    maximise: bool,
    *,
    render: bool,
    figure: Callable[[float, float], Figure],
    save: Callable[[Figure, Path, Report], None],
) -> None:
    """Write ``archive.png`` for a MAP-Elites run (nothing for any other run)."""
    run = report.run
    if not len(run.archive):
        return
    last = int(run.archive["generation"].max())
    archive = run.archive[run.archive["generation"] == last]
    description = run.archive_description
    assert description is not None  # a run with an archive has its description
    measures = list(description["measures"])
    ranked = archive.sort_values("fitness", ascending=not maximise).head(THUMBNAILS)
    images, note = [], ""
    if render:
        try:
            images = [
                (row.body_id, row.fitness, _thumbnail(run, row.body_id))
                for row in ranked.itertuples()
            ]
        except (RuntimeError, DamagedRunError) as exc:  # no OpenGL here; a body's row crafted
            note = f"archive.png: body thumbnails left out ({one_line(exc)})"
    drawn = figure(11.0, 4.8 if images else 4.2)
    rows = 2 if images else 1
    columns = max(3, math.ceil(len(images) / 2)) if images else 1
    spec = drawn.add_gridspec(rows, 1 + columns, width_ratios=[2.2] + [1] * columns)
    axes = drawn.add_subplot(spec[:, 0])
    if description["kind"] == "cvt":
        shown = _cvt(axes, archive, description)
    else:
        grid = _grid(archive, maximise)
        ranges = description["ranges"]
        up = ranges[1] if len(ranges) > 1 else (0.0, 1.0)
        extent = (ranges[0][0], ranges[0][1], up[0], up[1])
        shown = axes.imshow(grid, origin="lower", aspect="auto", cmap="viridis", extent=extent)
    fitness_fn = str(run.config.get("task", {}).get("fitness", "fitness"))
    label = figure_label(fitness_label(fitness_fn, what="elite's fitness"))  # the config's name
    drawn.colorbar(shown, ax=axes, label=label)
    up_name = measures[1] if len(measures) > 1 else ""
    axes.set_xlabel(descriptor_label(measures[0]))
    axes.set_ylabel(descriptor_label(up_name) if up_name else "")
    for axis, measure in ((axes.xaxis, measures[0]), (axes.yaxis, up_name)):
        if DESCRIPTORS.get(measure, ("", False))[1]:  # a count: whole-number ticks
            integer_ticks(axis)
    axes.set_title(_title(run, archive, description, last))
    for k, (body_id, fitness, image) in enumerate(images):
        thumb = drawn.add_subplot(spec[k // columns, 1 + k % columns])
        thumb.imshow(np.asarray(image))
        thumb.set_axis_off()
        thumb.set_title(f"{body_id}: {fitness:.3g}", fontsize=8)
    if note:
        report.notes.append(note)
    save(drawn, report.folder / "archive.png", report)
