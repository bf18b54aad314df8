"""MAP-Elites over morphologies (``body.optimizer = "map_elites"``).

Mouret & Clune, *Illuminating search spaces by mapping elites* (2015). A grid over chosen
morphology measures (any column of the bodies table: the morphology descriptors and
``n_joints``), a pyribs ``GridArchive``, keeps in each cell the best body seen there. Generation
0 is ``body.population`` random genotypes; every later generation breeds ``body.offspring``
children from elites drawn uniformly from the archive, with the encoder's own crossover (with
probability ``body.crossover_rate``) and mutation. Every new body learns its brain with
CMA-ES as in the GA, and its fitness is its best brain's.

Options (``body.optimizer_options``): ``measures`` (default ``["num_limbs", "joints_ratio"]``),
``bins`` (cells per measure, default 8 each), ``ranges`` (``[low, high]`` per measure; a
value outside is put in the edge cell; defaults for the descriptors below) and ``qd_offset``
(see below). Bodies that failed (no finite fitness) never enter the archive.

``archive = "cvt"`` (default ``"grid"``) makes it CVT-MAP-Elites (Vassiliades et al. 2018): a
pyribs ``CVTArchive`` of ``cells`` cells (default 64; ``bins`` is then an error), each the
region nearest to a centroid, made from the run seed (`ariel.evolution._cvt`). A cell's index
is its centroid's; the ``archive`` table's ``grid`` column is then ``[cells]``.

The archive describes itself (`MapElites.archive_description`: its kind, measures, ranges, and
a grid's bins or a CVT's centroids); the driver records that in run.json (``archive``), and
readers draw the archive from it.

QD metrics (`archive_quality`, in `ariel.evolution._qd` with what readers of runs need,
without pyribs), as pyribs' archive statistics: ``coverage`` (filled cells /
cells), ``qd_score`` (the sum over elites of how much better than ``qd_offset`` each is,
pyribs' ``qd_score_offset``) and ``norm_qd_score`` (``qd_score`` / cells). ``qd_offset`` is a
fitness (in the fitness's unit) that counts as nothing: 0 by default for a maximised fitness
(pyribs' default, right for a fitness never below 0 such as a displacement or a speed; give a
lower one for a fitness that can be negative), and it must be given for a minimised one,
which has no natural worst value (for a distance to a target: e.g. the distance at the
start). An elite worse than the offset counts 0, as an empty cell does, so ``qd_score`` is
never negative and never falls: a new elite fills a cell (adds >= 0) or replaces a worse one
(whose share is no larger). With every elite at least as good as the offset it
is exactly pyribs' number (the QD-score: Pugh et al. 2016, *Quality diversity: a new frontier
for evolutionary computation*; the offset: Tjanaka et al. 2023, *pyribs*).

Determinism: bodies enter the archive one at a time in body order, so a tie keeps the older
body; child j of generation g draws its parents and variation from its own stream
(``variation``, g, j); the archive's state is its elites (body, cell), rebuilt on resume by
adding them again.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NotRequired, TypedDict

import numpy as np
from ribs.archives import CVTArchive, GridArchive

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.evolution._cvt import check_archive, in_measure_units, scaled, unit_centroids
from ariel.evolution._ga import breed, random_proposals
from ariel.evolution._optimizer import Proposal
from ariel.evolution._qd import (
    DEFAULT_MEASURES,
    DEFAULT_RANGES,
    archive_quality,
    body_measures,
    resolve_qd_offset,
)
from ariel.evolution._seeds import derive_rng
from ariel.evolution._state import Body

if TYPE_CHECKING:
    from ariel.evolution._config import BodyConfig
    from ariel.plugins import BodyEncoder

__all__ = ["MAX_CELLS", "OPTIONS", "MapElites", "MapElitesState"]

#: Every option (``body.optimizer_options``) MAP-Elites takes.
OPTIONS = ("archive", "bins", "cells", "measures", "qd_offset", "ranges")
#: The most cells a grid archive may have (its bins multiplied): 316 x 316, or 46 cubed.
MAX_CELLS = 100_000


def _check_options(
    measures: object, bins: object, ranges: object
) -> tuple[list[str], list[int], list[tuple[float, float]]]:

    known = [*DESCRIPTOR_NAMES, "n_joints"]
    if not isinstance(measures, list | tuple) or not measures:  # a string too: a list of one
        raise ValueError(f"measures must be a non-empty list of: {', '.join(known)}")
    for i, name in enumerate(measures):
        if not isinstance(name, str) or name not in known:
            raise ValueError(f"unknown measure {name!r}; known: {', '.join(known)}")
        if name in measures[:i]:  # the grid's other cells along it could never fill
            raise ValueError(f"measure {name!r} is listed twice; each measure once")
    bins = [8] * len(measures) if bins is None else bins
    if not isinstance(bins, list | tuple) or len(bins) != len(measures):
        raise ValueError(f"bins must list one count per measure ({len(measures)}), got {bins!r}")
    if any(not isinstance(b, int) or isinstance(b, bool) or b < 1 for b in bins):
        raise ValueError(f"bins must be integers >= 1, got {bins!r}")
    if math.prod(bins) > MAX_CELLS:
        raise ValueError(
            f"bins {list(bins)} make {math.prod(bins):,} cells; at most {MAX_CELLS:,} (the "
            "archive is held, drawn and stored whole every generation)"
        )
    if ranges is None:
        missing = [m for m in measures if m not in DEFAULT_RANGES]
        if missing:
            raise ValueError(f"ranges must be given for {', '.join(missing)} ([low, high] each)")
        ranges = [DEFAULT_RANGES[m] for m in measures]
    if not isinstance(ranges, list | tuple) or len(ranges) != len(measures):
        raise ValueError(f"ranges must list one [low, high] per measure, got {ranges!r}")
    checked = []
    for pair in ranges:
        low, high = (float(v) for v in pair) if len(pair) == 2 else (math.nan, math.nan)
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ValueError(f"each range must be [low, high] with low < high, got {pair!r}")
        checked.append((low, high))
    return list(measures), [int(b) for b in bins], checked


class MapElitesState(TypedDict):
    """MAP-Elites' state (`MapElites.state`): the generation its next `ask` breeds and a CVT's
    centroids (in the unit cube; none for a grid). Its elites are the population, stored
    apart."""

    generation: int
    centroids: NotRequired[list[list[float]]]


class MapElites:
    """A pyribs ``GridArchive`` of bodies, bred from uniformly drawn elites.

    Made by the plugin registry (``body_optimizers.make("map_elites", ...)``) with the keywords
    every body optimizer takes; ``measures``, ``bins``, ``ranges`` and ``qd_offset`` come from
    ``body.optimizer_options``.

    Args:
        encoder: The run's body encoder plugin (its ``random_genotype``, ``crossover`` and
            ``mutate`` make the genotypes).
        seed: The run seed; every draw derives from it (`derive_rng`).
        maximise: Whether higher fitness is better.
        settings: The config's ``[body]`` section (a `BodyConfig`): its ``crossover_rate`` is
            used.
        measures: The archive's axes: morphology descriptor names (columns of the bodies
            table) or ``"n_joints"``; ``("num_limbs", "joints_ratio")`` by default.
        bins: Cells per measure, integers >= 1; None: 8 each.
        ranges: ``[low, high]`` per measure, ``low < high`` (a value outside is put in the edge
            cell); None: the defaults of `DEFAULT_RANGES`, which must then cover every measure.
        qd_offset: The fitness that counts as nothing in the QD-score (pyribs'
            ``qd_score_offset``, in the fitness's unit); None: 0 for a maximised fitness. It
            must be given for a minimised one.
        archive: ``"grid"`` (a ``GridArchive`` of ``bins``) or ``"cvt"`` (a ``CVTArchive``
            of ``cells`` centroids made from ``seed``, `ariel.evolution._cvt`).
        cells: A CVT's number of cells, an integer >= 1; None: 64. Only with ``"cvt"``.
        unknown: Any other option: a `TypeError` that names the allowed ones (`OPTIONS`).

    Raises:
        ValueError: For an unknown or empty list of measures, ``bins`` or ``ranges`` that do
            not give one valid entry per measure, a measure without a default range when
            ``ranges`` is None, or a ``qd_offset`` that is not a finite number (or is missing
            for a minimised fitness); an ``archive`` other than ``"grid"`` or ``"cvt"``,
            ``cells`` that is not an integer >= 1, or ``bins`` with a CVT (``cells`` with a
            grid).
    """

    def __init__(
        self,
        *,
        encoder: BodyEncoder,
        seed: int,
        maximise: bool,
        settings: BodyConfig,
        measures: Sequence[str] = DEFAULT_MEASURES,
        bins: Sequence[int] | None = None,
        ranges: Sequence[Sequence[float]] | None = None,
        qd_offset: float | None = None,
        archive: str = "grid",
        cells: int | None = None,
        **unknown: object,
    ) -> None:
        if unknown:
            raise TypeError(f"unknown option {sorted(unknown)[0]!r}; allowed: {', '.join(OPTIONS)}")
        cvt_cells = check_archive(archive, bins, cells)
        self.measures, self.bins, self.ranges = _check_options(measures, bins, ranges)
        self.qd_offset = resolve_qd_offset(qd_offset, maximise)
        self.encoder, self.seed, self.maximise, self.settings = encoder, seed, maximise, settings
        self.kind = archive
        # cells per measure of a grid, [cells] of a CVT: the archive table's grid column
        self.shape = self.bins if cvt_cells is None else [cvt_cells]
        self.centroids: np.ndarray | None = None  # a CVT's, in the unit cube
        self.archive: GridArchive | CVTArchive
        if cvt_cells is None:
            self.archive = GridArchive(
                solution_dim=1,
                dims=self.bins,
                ranges=self.ranges,
                qd_score_offset=self._score_offset,
                dtype=np.float64,
            )
        else:
            self._make_cvt(unit_centroids(seed, cvt_cells, len(self.measures)))
        self.generation = 0  # the generation the next `ask` breeds
        self._bodies: dict[int, Body] = {}  # the elites, by body number

    @property
    def _score_offset(self) -> float:
        """pyribs' ``qd_score_offset``: `qd_offset` in objective units."""
        return self.qd_offset if self.maximise else -self.qd_offset

    def _make_cvt(self, centroids: np.ndarray) -> None:
        """A CVT archive of ``centroids`` (in the unit cube), empty."""
        self.centroids = np.array(centroids, dtype=np.float64)
        self.archive = CVTArchive(
            solution_dim=1,
            centroids=self.centroids,
            ranges=[(0.0, 1.0)] * len(self.measures),
            qd_score_offset=self._score_offset,
            dtype=np.float64,
        )

    @property
    def population(self) -> list[Body]:
        """The elites, in body order."""
        return [self._bodies[n] for n in sorted(self._bodies)]

    def cells(self) -> list[tuple[int, Body]]:
        """(cell index, elite) for every filled cell, in cell order."""
        data = self.archive.data()
        pairs = zip(data["index"].tolist(), data["solution"][:, 0].tolist())
        return sorted((int(index), self._bodies[int(number)]) for index, number in pairs)

    def ask(self, n: int) -> list[Proposal]:
        elites = self.population
        if not elites:
            return random_proposals(self.encoder, self.seed, n)

        def pick(rng: np.random.Generator) -> Body:
            return elites[int(rng.integers(len(elites)))]

        return [
            breed(
                self.encoder,
                derive_rng(self.seed, "variation", self.generation, j),
                pick,
                self.settings.crossover_rate,
                len(elites) > 1,
            )
            for j in range(n)
        ]

    def tell(self, bodies: Sequence[Body]) -> None:
        for body in sorted(bodies, key=lambda b: b.number):
            self._add(body)
        self.generation += 1

    def _add(self, body: Body) -> None:
        if body.status != "ok" or not math.isfinite(body.fitness):
            return
        objective = body.fitness if self.maximise else -body.fitness
        measures = np.array([body_measures(body, self.measures)])
        if not np.isfinite(measures).all():
            return
        if self.centroids is not None:  # a CVT's cells are in the scaled measures
            measures = scaled(measures, self.ranges)
        info = self.archive.add(np.array([[float(body.number)]]), np.array([objective]), measures)
        if int(info["status"][0]) > 0:  # new cell or improved: the body is an elite now
            self._bodies[body.number] = body
            kept = {int(n) for n in self.archive.data()["solution"][:, 0].tolist()}
            self._bodies = {n: b for n, b in self._bodies.items() if n in kept}

    def archive_rows(self) -> list[dict[str, Any]]:
        """The archive as rows of the ``archive`` table (one per filled cell, in cell order)."""
        return [
            {
                "cell": index,
                "body_id": body.body_id,
                "fitness": float(body.fitness),
                "objective": float(body.fitness if self.maximise else -body.fitness),
                "measures": body_measures(body, self.measures),
                "grid": list(self.shape),
            }
            for index, body in self.cells()
        ]

    def stats(self) -> dict[str, float]:
        """``coverage``, ``qd_score``, ``norm_qd_score`` (`archive_quality`), ``cells`` and
        ``filled``."""
        fitness = [body.fitness for _, body in self.cells()]
        cells = int(np.prod(self.shape))
        quality = archive_quality(fitness, cells, self.qd_offset, self.maximise)
        return {**quality, "cells": cells, "filled": len(fitness)}

    def archive_description(self) -> dict[str, Any]:
        """The archive as readers draw it (plain JSON): ``kind`` (``"grid"`` or ``"cvt"``),
        ``measures``, ``ranges`` and a grid's ``bins`` or a CVT's ``cells`` and ``centroids``
        (one list of measure values per cell, in cell order, in the measures' units; a
        body's cell is the nearest centroid in the measures scaled to [0, 1] by ``ranges``)."""
        described: dict[str, Any] = {
            "kind": self.kind,
            "measures": list(self.measures),
            "ranges": [[low, high] for low, high in self.ranges],
        }
        if self.centroids is None:
            return {**described, "bins": list(self.bins)}
        centroids = in_measure_units(self.centroids, self.ranges)
        return {**described, "cells": len(centroids), "centroids": centroids}

    def state(self) -> MapElitesState:
        if self.centroids is None:
            return {"generation": self.generation}
        return {"generation": self.generation, "centroids": self.centroids.tolist()}

    def restore(self, state: MapElitesState, population: Sequence[Body]) -> None:
        self.generation = int(state["generation"])
        if self.centroids is not None and "centroids" in state:  # the run's own, exactly
            self._make_cvt(np.array(state["centroids"], dtype=np.float64))
        self.archive.clear()
        self._bodies = {}
        for body in sorted(population, key=lambda b: b.number):
            self._add(body)
