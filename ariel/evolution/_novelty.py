"""Novelty search over morphologies (``body.optimizer = "novelty"``).

Lehman & Stanley, *Abandoning objectives: evolution through the search for novelty alone*
(Evolutionary Computation 19(2), 2011): bodies are selected for being unlike the bodies seen
so far, not for their fitness. A body's place is its vector of chosen morphology measures
(``measures``: any column of the bodies table, as in ``map_elites``), each mapped to [0, 1] by
its ``[low, high]`` of ``ranges`` (a value outside is clipped to the edge). Its *novelty* is
the mean Euclidean distance to its ``k`` nearest other bodies among the novelty archive and
the bodies being ranked (the generation's parents and children: Lehman & Stanley's "archive
plus current population"); with fewer than ``k`` of those, the mean over all of them (none:
0). Neighbours are ordered by distance, ties by body number.

The novelty archive is a pyribs ``ProximityArchive``. After each generation the new bodies
with a finite fitness are offered to it as one batch; a body enters when its novelty among
the archive's members (pyribs': the members before this batch, not the batch itself) is at
least ``novelty_threshold``, in the normalised units (0.05: a twentieth of a measure's range).
An empty archive takes every body, so all of generation 0 enters.

Selection (``selection``): ``"novelty"`` ranks bodies by novelty alone. ``"novelty+fitness"``
ranks them by Pareto front over two maximised objectives, as NSGA-II's non-dominated sorting
(Deb et al. 2002), the bodies of one front by novelty: novelty, and fitness (-fitness for a
minimised one), or, with ``local_competition``, the local competition score: how many of the
body's ``k`` nearest neighbours (the same ones) it beats in fitness. That is novelty search
with local competition, NSLC (Lehman & Stanley, *Evolving a diversity of virtual creatures
through novelty search and local competition*, GECCO 2011); the archive then also lets a body
that is not novel enough replace its nearest member when it is fitter (pyribs' NSLC archive).
Bodies that failed (no finite fitness, or a measure that is not finite) rank last, by number,
and never enter the archive.

Generation 0 is ``body.population`` random genotypes (those of the GA). The survivors are the
best ``body.population`` of parents and children (``body.survivors = "plus"``) or of the
children (``"generational"``), as ranked; each child's parents are drawn by tournament
(``body.tournament``) over that ranking, then crossover (``body.crossover_rate``) and mutation
as in the GA.

Result archive: novelty search keeps no best body per region, so, as pyribs advises for its
``ProximityArchive``, every body with a finite fitness is also put in a grid, a `MapElites`
archive over the same measures (``bins``, ``ranges`` and ``qd_offset`` as there). Its rows are
the run's ``archive`` table and its coverage and QD-score the progress line's, so a novelty run
is measured as a MAP-Elites run is (``ariel compare``); the line adds the novelty archive's
size and the population's mean novelty.

Determinism: child j of generation g draws its parents and variation from its own stream
(``variation``, g, j); bodies are offered to both archives in body order. The state holds the
novelty archive's members in pyribs' order and the grid's elites, as plain numbers; restoring
adds them to empty archives, which gives the same archives, so a resumed run asks exactly
what an uninterrupted one would.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from ribs.archives import ProximityArchive

from ariel.evolution._ga import tournament_children
from ariel.evolution._map_elites import MapElites
from ariel.evolution._optimizer import Proposal
from ariel.evolution._qd import DEFAULT_MEASURES, body_measures
from ariel.evolution._state import Body

__all__ = ["NoveltySearch", "neighbour_scores", "pareto_fronts"]

SELECTIONS = ("novelty", "novelty+fitness")
#: Every option (``body.optimizer_options``) novelty search takes.
OPTIONS = (
    "bins",
    "k",
    "local_competition",
    "measures",
    "novelty_threshold",
    "qd_offset",
    "ranges",
    "selection",
)


def neighbour_scores(
    points: np.ndarray,
    objectives: np.ndarray,
    reference: np.ndarray,
    reference_objectives: np.ndarray,
    k: int,
    own: Sequence[int | None],
) -> tuple[np.ndarray, np.ndarray]:
    """Novelty and local competition of each of ``points`` among the rows of ``reference``.

    Args:
        points: (n, measures) places to score.
        objectives: (n,) their objectives (higher is better).
        reference: (m, measures) the places they are compared with, in body order.
        reference_objectives: (m,) the objectives of those.
        k: The number of nearest neighbours.
        own: For each point, its own row of ``reference`` (left out), or None.

    Returns:
        ``(novelty, competition)``: per point, the mean distance to its ``k`` nearest rows
        (fewer when there are fewer; 0 with none; ties by row) and how many of those it
        beats (a strictly higher objective).
    """
    novelty = np.zeros(len(points), dtype=np.float64)
    competition = np.zeros(len(points), dtype=np.int64)
    for i, point in enumerate(points):
        distances = np.sqrt(np.sum((reference - point) ** 2, axis=1))
        order = np.argsort(distances, kind="stable")
        if own[i] is not None:
            order = order[order != own[i]]
        order = order[:k]
        if len(order):
            novelty[i] = float(np.mean(distances[order]))
            competition[i] = int(np.sum(objectives[i] > reference_objectives[order]))
    return novelty, competition


def pareto_fronts(objectives: np.ndarray) -> np.ndarray:
    """The Pareto front of each row of ``objectives`` (columns maximised).

    Args:
        objectives: (n, objectives) values, higher better in every column.

    Returns:
        (n,) front numbers: 0 for the rows no row dominates, 1 for those dominated only by
        rows of front 0, and so on (NSGA-II's non-dominated sorting, Deb et al. 2002).
    """
    values = np.asarray(objectives, dtype=np.float64)
    fronts = np.full(len(values), -1, dtype=np.int64)
    front = 0
    while (fronts < 0).any():
        left = np.flatnonzero(fronts < 0)
        others = values[left]
        for i in left:
            at_least = np.all(others >= values[i], axis=1)
            better = np.any(others > values[i], axis=1)
            if not np.any(at_least & better):
                fronts[i] = front
        front += 1
    return fronts


def _check_novelty_options(k: Any, threshold: Any, local: Any, selection: Any) -> None:
    if isinstance(k, bool) or not isinstance(k, int) or k < 1:
        raise ValueError(f"k must be an integer >= 1 (nearest neighbours), got {k!r}")
    number = isinstance(threshold, int | float) and not isinstance(threshold, bool)
    if not number or not math.isfinite(threshold) or threshold < 0:
        raise ValueError(
            "novelty_threshold must be a finite number >= 0 (a distance between measures "
            f"scaled to [0, 1]), got {threshold!r}"
        )
    if not isinstance(local, bool):
        raise ValueError(f"local_competition must be true or false, got {local!r}")
    if selection not in SELECTIONS:
        raise ValueError(f"selection must be one of {', '.join(SELECTIONS)}, got {selection!r}")
    if local and selection != "novelty+fitness":
        raise ValueError(
            "local_competition needs selection = 'novelty+fitness' (its score is the second "
            "objective)"
        )


class NoveltySearch:
    """Novelty search (or NSLC) over bodies, with a pyribs ``ProximityArchive``.

    Made by the plugin registry (``body_optimizers.make("novelty", ...)``) with the keywords
    every body optimizer takes; the others come from ``body.optimizer_options``. See the
    module docstring for the algorithm.

    Args:
        encoder: The run's body encoder plugin (its ``random_genotype``, ``crossover`` and
            ``mutate`` make the genotypes).
        seed: The run seed; every draw derives from it (`derive_rng`).
        maximise: Whether higher fitness is better.
        settings: The config's ``[body]`` section (a `BodyConfig`): its ``population``,
            ``tournament``, ``crossover_rate`` and ``survivors`` are used.
        measures: The measures novelty is measured in: morphology descriptor names (columns
            of the bodies table) or ``"n_joints"``; ``("num_limbs", "joints_ratio")`` by
            default, as ``map_elites``.
        ranges: ``[low, high]`` per measure, ``low < high``: what is mapped to [0, 1]; None:
            the defaults of ``map_elites`` (`DEFAULT_RANGES`), which must cover every measure.
        bins: Cells per measure of the result archive (integers >= 1); None: 8 each.
        qd_offset: The fitness that counts as nothing in the result archive's QD-score, as
            for ``map_elites``; None: 0 for a maximised fitness. It must be given for a
            minimised one.
        k: Nearest neighbours novelty is the mean distance to, >= 1.
        novelty_threshold: The novelty (in normalised units) a new body needs to enter the
            novelty archive, >= 0.
        local_competition: NSLC: rank by novelty and local competition score (needs
            ``selection = "novelty+fitness"``).
        selection: ``"novelty"`` (novelty alone) or ``"novelty+fitness"`` (Pareto fronts of
            novelty and fitness, or local competition).
        **unknown: No other option is taken.

    Raises:
        TypeError: For an option not in `OPTIONS`.
        ValueError: For a bad value of an option (as ``map_elites`` checks ``measures``,
            ``ranges``, ``bins`` and ``qd_offset``).
    """

    def __init__(
        self,
        *,
        encoder: Any,
        seed: int,
        maximise: bool,
        settings: Any,
        measures: Sequence[str] = DEFAULT_MEASURES,
        ranges: Sequence[Sequence[float]] | None = None,
        bins: Sequence[int] | None = None,
        qd_offset: float | None = None,
        k: int = 15,
        novelty_threshold: float = 0.05,
        local_competition: bool = False,
        selection: str = "novelty",
        **unknown: Any,
    ) -> None:
        if unknown:
            name = sorted(unknown)[0]
            raise TypeError(f"unknown option {name!r}; allowed: {', '.join(OPTIONS)}")
        self.result = MapElites(
            encoder=encoder,
            seed=seed,
            maximise=maximise,
            settings=settings,
            measures=measures,
            bins=bins,
            ranges=ranges,
            qd_offset=qd_offset,
        )
        _check_novelty_options(k, novelty_threshold, local_competition, selection)
        self.measures, self.ranges = self.result.measures, self.result.ranges
        self.qd_offset = self.result.qd_offset  # recorded in run.json, as map_elites'
        self.k, self.novelty_threshold = k, float(novelty_threshold)
        self.local_competition, self.selection = local_competition, selection
        self.encoder, self.seed, self.maximise, self.settings = encoder, seed, maximise, settings
        self.archive = ProximityArchive(
            solution_dim=1,  # the body number
            measure_dim=len(self.measures),
            k_neighbors=k,
            novelty_threshold=self.novelty_threshold,
            local_competition=local_competition,
            dtype=np.float64,
        )
        self.generation = 0  # the generation the next `ask` breeds
        self._population: list[Body] = []  # ranked, best first
        self._scored: dict[int, tuple[float, int]] | None = None  # its scores, once computed

    @property
    def population(self) -> list[Body]:
        """The survivors of the last `tell`, best first."""
        return list(self._population)

    # -- places and scores ---------------------------------------------------------------------

    def place(self, body: Body) -> np.ndarray | None:
        """``body``'s measures mapped to [0, 1]; None for a body that failed (see the module
        docstring)."""
        if body.status != "ok" or not math.isfinite(body.fitness):
            return None
        values = np.array(body_measures(body, self.measures), dtype=np.float64)
        if not np.isfinite(values).all():
            return None
        low, high = np.array(self.ranges, dtype=np.float64).T
        return np.clip((values - low) / (high - low), 0.0, 1.0)

    def _objective(self, body: Body) -> float:
        return float(body.fitness if self.maximise else -body.fitness)

    def members(self) -> tuple[list[int], np.ndarray, np.ndarray]:
        """The novelty archive: (body numbers, objectives, places), in pyribs' order."""
        data = self.archive.data()
        order = np.argsort(data["index"], kind="stable")
        numbers = [int(n) for n in data["solution"][order, 0].tolist()]
        return numbers, data["objective"][order], data["measures"][order]

    def scores(self, bodies: Sequence[Body]) -> dict[int, tuple[float, int]]:
        """(novelty, local competition score) by body number, of each of ``bodies`` that did
        not fail, among the novelty archive and ``bodies`` (see the module docstring)."""
        scored = [(b, p) for b in bodies if (p := self.place(b)) is not None]
        numbers, objectives, places = self.members()
        reference = dict(zip(numbers, zip(objectives.tolist(), places)))
        reference.update({b.number: (self._objective(b), p) for b, p in scored})
        order = sorted(reference)
        row = {number: i for i, number in enumerate(order)}
        width = len(self.measures)
        novelty, competition = neighbour_scores(
            np.array([p for _, p in scored]).reshape(-1, width),
            np.array([self._objective(b) for b, _ in scored]),
            np.array([reference[n][1] for n in order]).reshape(-1, width),
            np.array([reference[n][0] for n in order]),
            self.k,
            [row[b.number] for b, _ in scored],
        )
        return {
            b.number: (float(nov), int(lc)) for (b, _), nov, lc in zip(scored, novelty, competition)
        }

    def ranked(self, bodies: Sequence[Body]) -> list[Body]:
        """``bodies``, best first by ``selection`` (see the module docstring); those that
        failed last, by number."""
        return self._ranked(bodies, self.scores(bodies))

    def _ranked(
        self, bodies: Sequence[Body], scores: Mapping[int, tuple[float, int]]
    ) -> list[Body]:
        failed = sorted((b for b in bodies if b.number not in scores), key=lambda b: b.number)
        scored = sorted((b for b in bodies if b.number in scores), key=lambda b: b.number)
        if self.selection == "novelty":
            keys = [(-scores[b.number][0], b.number) for b in scored]
        else:
            second = [
                float(scores[b.number][1]) if self.local_competition else self._objective(b)
                for b in scored
            ]
            novelty = [scores[b.number][0] for b in scored]
            fronts = pareto_fronts(np.array([novelty, second]).T.reshape(-1, 2))
            keys = [(int(f), -n, b.number) for f, n, b in zip(fronts, novelty, scored)]
        order = sorted(range(len(scored)), key=lambda i: keys[i])
        return [scored[i] for i in order] + failed

    # -- ask / tell ----------------------------------------------------------------------------

    def tournament(self, rng: np.random.Generator) -> Body:
        """The best of ``body.tournament`` bodies drawn from the population (its ranking)."""
        population = self._population
        size = min(self.settings.tournament, len(population))
        picks = rng.choice(len(population), size=size, replace=False)
        return population[int(np.min(picks))]

    def ask(self, n: int) -> list[Proposal]:
        return tournament_children(self, n)

    def tell(self, bodies: Sequence[Body]) -> None:
        children = sorted(bodies, key=lambda b: b.number)
        offered = [(b, p) for b in children if (p := self.place(b)) is not None]
        if offered:
            self.archive.add(
                np.array([[float(b.number)] for b, _ in offered]),
                np.array([self._objective(b) for b, _ in offered]),
                np.array([p for _, p in offered]),
            )
        self.result.tell(children)
        generational = self.settings.survivors == "generational"
        pool = children if generational or not self._population else self._population + children
        scores = self.scores(pool)
        self._population = self._ranked(pool, scores)[: self.settings.population]
        # The survivors' scores as selection saw them (among the archive and the whole pool),
        # for the novelty table and the progress line: not remeasured among survivors alone.
        self._scored = {b.number: scores[b.number] for b in self._population if b.number in scores}
        self.generation += 1

    # -- records -------------------------------------------------------------------------------

    def archive_rows(self) -> list[dict[str, Any]]:
        """The result archive as rows of the ``archive`` table (`MapElites.archive_rows`)."""
        return self.result.archive_rows()

    def archive_description(self) -> dict[str, Any]:
        """The result archive's description (`MapElites.archive_description`: a grid)."""
        return self.result.archive_description()

    def novelty_rows(self) -> list[dict[str, Any]]:
        """Rows of the ``novelty`` table after a `tell` (`NoveltyRow`): each body of the
        population, ranked, with its novelty and local competition score as selection saw
        them (`_population_scores`), and each member of the novelty archive, by body number."""
        scores = self._population_scores()
        rank = {b.number: i for i, b in enumerate(self._population)}
        places = {b.number: self.place(b) for b in self._population}
        numbers, _, member_places = self.members()
        places.update(zip(numbers, member_places))
        members = set(numbers)
        rows = []
        for number in sorted(places):
            place = places[number]
            novelty, competition = scores.get(number, (math.nan, -1))
            rows.append(
                {
                    "body_id": Body(number, None, [], -1).body_id,
                    "place": [] if place is None else [float(v) for v in place],
                    "novelty": novelty,
                    "local_competition": competition,
                    "rank": rank.get(number, -1),
                    "in_archive": number in members,
                }
            )
        return rows

    def _population_scores(self) -> dict[int, tuple[float, int]]:
        """The population's scores as its selection saw them (`tell`, or the checkpoint);
        `scores` of the population alone only for a checkpoint written before they were kept."""
        if self._scored is None:
            self._scored = self.scores(self._population)
        return self._scored

    def stats(self) -> dict[str, float]:
        """The result archive's `MapElites.stats`, with ``novelty_archive`` (members of the
        novelty archive) and ``mean_novelty`` (of the population's bodies that did not fail,
        among the archive and the population; NaN for none)."""
        novelty = [nov for nov, _ in self._population_scores().values()]
        mean = math.fsum(novelty) / len(novelty) if novelty else math.nan
        return {**self.result.stats(), "novelty_archive": len(self.archive), "mean_novelty": mean}

    # -- state ---------------------------------------------------------------------------------

    def state(self) -> dict[str, Any]:
        numbers, objectives, places = self.members()
        return {
            "generation": self.generation,
            "ranking": [b.number for b in self._population],
            # [number, novelty, local competition] of the survivors, as selection scored them
            "scores": [
                [n, nov if math.isfinite(nov) else None, lc]
                for n, (nov, lc) in sorted(self._population_scores().items())
            ],
            # [number, objective, *place] per member, in pyribs' order
            "archive": [
                [n, float(o), *map(float, p)] for n, o, p in zip(numbers, objectives, places)
            ],
            # [number, fitness, *measures] per elite of the result archive
            "elites": [
                [b.number, float(b.fitness), *body_measures(b, self.measures)]
                for b in self.result.population
            ],
        }

    def restore(self, state: dict[str, Any], population: Sequence[Body]) -> None:
        self.generation = int(state["generation"])
        by_number = {b.number: b for b in population}
        self._population = [by_number[int(n)] for n in state["ranking"]]
        kept = state.get("scores")  # None: a checkpoint from before they were kept
        self._scored = (
            None
            if kept is None
            else {int(n): (math.nan if v is None else float(v), int(c)) for n, v, c in kept}
        )
        self.archive.clear()
        if state["archive"]:
            # An empty archive takes a whole batch, in order: the same members, same places.
            rows = np.array(state["archive"], dtype=np.float64)
            self.archive.add(rows[:, :1], rows[:, 1], rows[:, 2:])
        elites = [self._stand_in(entry) for entry in state["elites"]]
        self.result.restore({"generation": self.generation}, elites)

    def _stand_in(self, entry: Sequence[Any]) -> Body:
        """A result-archive elite from its state entry: what the archive reads of a body (its
        number, fitness and measures), not its genotype."""
        number, fitness, *values = entry
        measured = dict(zip(self.measures, (float(v) for v in values)))
        body = Body(int(number), None, [], -1)
        body.n_joints = int(measured.pop("n_joints", 0))
        body.descriptors, body.fitness = measured, float(fitness)
        return body
