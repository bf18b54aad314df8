"""A quality-diversity archive as Rerun draws it, by its description (run.json's ``archive``,
`ariel.recording.store.describe_archive`): a grid as a tensor of fitness per cell (NaN:
empty), a CVT as points at its centroids coloured by their elite's fitness (grey: empty).

A CVT's points lie in its first two measures, each scaled to [0, 1] by its range (measure 0
across, measure 1 up; one measure: across), where its cells are the regions nearest to each
centroid; the colours run viridis from the worst elite (dark) to the best (yellow), as the
grid's tensor view draws them. Hovering a point names its cell, centroid and fitness.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.rerun._chunks import rerun_module

if TYPE_CHECKING:
    from rerun import Points2D, Tensor
    from rerun.blueprint import View

__all__ = [
    "ARCHIVE_ENTITY",
    "CvtCells",
    "archive_cells",
    "archive_grid",
    "archive_image",
    "archive_kind",
    "archive_shown",
    "archive_view",
]

#: A MAP-Elites run's archive beside an evaluation (static, the last generation's).
ARCHIVE_ENTITY = "/run/archive"
#: Where empty archive cells are drawn: this share of the elites' fitness span below the
#: worst elite, so they take the darkest colour and no elite looks empty.
_EMPTY_BELOW = 0.5
# viridis at 0, 1/4, 1/2, 3/4, 1 (dark: low fitness, bright yellow: high)
_VIRIDIS = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]])
_EMPTY_COLOUR = (90, 90, 90, 255)
_MARGIN = 0.05  # of the unit square, around a CVT's points


@dataclass(frozen=True)
class CvtCells:
    """A CVT archive to draw: its ``centroids`` (cells x measures, in the measures' units),
    the measures' ``ranges`` (measures x 2), their names (``measures``) and the elite's
    ``fitness`` per cell (NaN: empty)."""

    centroids: np.ndarray
    ranges: np.ndarray
    measures: list[str]
    fitness: np.ndarray

    def positions(self) -> np.ndarray:
        """(cells, 2) points: measure 0 across, measure 1 up, scaled to [0, 1] by ``ranges``."""
        low, high = self.ranges[:, 0], self.ranges[:, 1]
        unit = (self.centroids - low) / (high - low)
        up = unit[:, 1] if unit.shape[1] > 1 else np.full(len(unit), 0.5)
        return np.column_stack([unit[:, 0], 1.0 - up])  # Rerun's 2D y points down


def archive_grid(rows: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """A MAP-Elites archive's rows as its grid of fitness (NaN in empty cells)."""
    grid = [int(n) for n in rows[0]["grid"]] if rows else [0]
    values = np.full(int(np.prod(grid)), np.nan)
    for row in rows:
        values[int(row["cell"])] = float(row["fitness"])
    return values.reshape(grid)


def archive_cells(
    rows: Sequence[Mapping[str, Any]], description: Mapping[str, Any] | None = None
) -> np.ndarray | CvtCells:
    """An archive's rows (one generation's) as drawn: `archive_grid` for a grid (and a run
    without a ``description``), `CvtCells` for a CVT."""
    if not description or description.get("kind") != "cvt":
        return archive_grid(rows)
    centroids = np.asarray(description["centroids"], dtype=np.float64)
    centroids = centroids.reshape(len(centroids), -1)
    fitness = np.full(len(centroids), np.nan)
    for row in rows:
        fitness[int(row["cell"])] = float(row["fitness"])
    ranges = np.asarray(description["ranges"], dtype=np.float64).reshape(-1, 2)
    return CvtCells(centroids, ranges, [str(m) for m in description["measures"]], fitness)


def archive_kind(archive: np.ndarray | CvtCells | None) -> str | bool:
    """``"cvt"`` for `CvtCells`, ``"grid"`` for a grid, False for None (no archive)."""
    if archive is None:
        return False
    return "cvt" if isinstance(archive, CvtCells) else "grid"


def _colours(fitness: np.ndarray) -> np.ndarray:
    """RGBA per cell: viridis from the lowest elite fitness to the highest; grey: empty."""
    colours = np.tile(np.array(_EMPTY_COLOUR, dtype=np.uint8), (len(fitness), 1))
    filled = np.isfinite(fitness)
    if filled.any():
        low, high = float(fitness[filled].min()), float(fitness[filled].max())
        share = (fitness[filled] - low) / (high - low) if high > low else np.ones(filled.sum())
        anchors = np.linspace(0.0, 1.0, len(_VIRIDIS))
        for c in range(3):
            colours[filled, c] = np.round(np.interp(share, anchors, _VIRIDIS[:, c]))
    return colours


def _points(cells: CvtCells) -> Points2D:
    rr = rerun_module()

    count = len(cells.fitness)
    radius = 0.4 / (math.sqrt(count) if cells.centroids.shape[1] > 1 else count)
    labels = [
        f"cell {i} at ({', '.join(f'{v:.3g}' for v in centroid)}): "
        + (f"{fitness:.4g}" if math.isfinite(fitness) else "empty")
        for i, (centroid, fitness) in enumerate(zip(cells.centroids, cells.fitness))
    ]
    return rr.Points2D(
        cells.positions(),
        radii=np.full(count, radius, dtype=np.float32),
        colors=_colours(cells.fitness),
        labels=labels,
        show_labels=False,
    )


def archive_image(archive: np.ndarray | CvtCells) -> Points2D | Tensor:
    """An archive of one generation as ``run.rrd`` logs it at ``/archive``: a grid's tensor
    (NaN: empty), a CVT's points."""
    rr = rerun_module()

    return _points(archive) if isinstance(archive, CvtCells) else rr.Tensor(archive)


def archive_shown(
    archive: np.ndarray | CvtCells, dimensions: Sequence[str] | None = None
) -> Points2D | Tensor | None:
    """An archive as drawn beside an evaluation (`ARCHIVE_ENTITY`); None without elites.

    A grid is a tensor, its dimensions named (``dimensions``: the measures, e.g. "num_limbs
    (0 to 8)"). The viewer draws NaN in the brightest colour, so empty cells get a value below
    every elite's (`_EMPTY_BELOW`) and the colour scale spans them to the best elite. A CVT
    is its points (see the module docstring).
    """
    rr = rerun_module()

    if isinstance(archive, CvtCells):
        return _points(archive) if np.isfinite(archive.fitness).any() else None
    values = np.asarray(archive, dtype=np.float64)
    filled = values[np.isfinite(values)]
    if not filled.size:
        return None
    low, high = float(filled.min()), float(filled.max())
    empty = low - max(_EMPTY_BELOW * (high - low), 1e-9 + 1e-3 * abs(low))
    shown = np.where(np.isfinite(values), values, empty)
    names = list(dimensions or [])[: values.ndim]
    names += [f"measure {d}" for d in range(len(names), values.ndim)]
    return rr.Tensor(shown, dim_names=names, value_range=[empty, high])


def archive_view(
    kind: str | bool,
    unit: str = "",
    origin: str = ARCHIVE_ENTITY,
    *,
    name: str | None = None,
    sliced: bool = False,
) -> View:
    """The blueprint view of an archive of ``kind`` (``"grid"``, or True; ``"cvt"``) at
    ``origin``: a tensor view (``sliced``: measure 0 across, measure 1 up, cells sharp, in
    viridis) or a 2D view of a CVT's points over the unit square. ``name``: its title; None:
    "archive: fitness (UNIT), dark: empty" (``unit``: " (m)", or "")."""
    rr = rerun_module()
    rrb = rr.blueprint

    empty = "grey" if kind == "cvt" else "dark"
    name = f"archive: fitness{unit}, {empty}: empty" if name is None else name
    if kind == "cvt":
        span = [-_MARGIN, 1.0 + _MARGIN]
        bounds = rrb.VisualBounds2D(x_range=span, y_range=span)
        return rrb.Spatial2DView(name=name, origin=origin, visual_bounds=bounds)
    if not sliced:
        return rrb.TensorView(name=name, origin=origin)
    return rrb.TensorView(
        name=name,
        origin=origin,
        slice_selection=rrb.TensorSliceSelection(
            width=rr.TensorDimensionSelection(dimension=0),
            height=rr.TensorDimensionSelection(dimension=1, invert=True),
        ),
        scalar_mapping=rrb.TensorScalarMapping(mag_filter="nearest", colormap="viridis"),
        view_fit="FillKeepAspectRatio",
    )
