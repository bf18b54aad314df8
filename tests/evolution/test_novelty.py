"""Novelty search over morphologies: novelty and local competition as defined, its ranking,
its archive, its check, an exact resume (of the optimizer, and of a tiny run after Ctrl-C) and
one-line option errors."""

from __future__ import annotations

import inspect
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _helpers import interrupt_then_resume, table_digests

from ariel.evolution import BodyConfig, ConfigError, MapElites, NoveltySearch
from ariel.evolution._ga import random_proposals
from ariel.evolution._novelty import OPTIONS, neighbour_scores, pareto_fronts
from ariel.evolution._optimizer_checks import _body, _VectorEncoder
from ariel.evolution._progress import fmt_value, population_text
from ariel.evolution._state import Body
from ariel.plugins import body_optimizers, check_body_optimizer
from ariel.recording import load_run
from ariel.runs import run_experiment

MEASURES = ["joints_ratio", "symmetry"]  # both in [0, 1]: places are the values themselves
SETTINGS = BodyConfig(population=3, offspring=4, tournament=2)


def _novelty(maximise: bool = True, settings: BodyConfig = SETTINGS, **options) -> NoveltySearch:
    options = {"measures": MEASURES, **options}
    if not maximise:
        options.setdefault("qd_offset", 10.0)
    return NoveltySearch(
        encoder=_VectorEncoder(), seed=3, maximise=maximise, settings=settings, **options
    )


def _made(number: int, place: tuple[float, float], fitness: float) -> Body:
    body = Body(number, [float(number)], [], 0)
    body.descriptors = dict(zip(MEASURES, place))
    body.fitness = fitness
    return body


def _random_bodies(rng: np.random.Generator, first: int, n: int) -> list[Body]:
    return [_made(first + i, tuple(rng.random(2)), float(rng.normal())) for i in range(n)]


def _brute_force(point, objective, others, k):
    """Mean distance to the k nearest of ``others`` ((place, objective) pairs) and how many of
    them ``objective`` beats; ties by position in ``others``."""
    nearest = sorted((math.dist(point, place), i, obj) for i, (place, obj) in enumerate(others))
    nearest = nearest[:k]
    if not nearest:
        return 0.0, 0
    novelty = sum(d for d, _, _ in nearest) / len(nearest)
    return novelty, sum(objective > obj for _, _, obj in nearest)


# -- the definitions ---------------------------------------------------------------------------


@pytest.mark.parametrize("k", [1, 3, 15])
def test_novelty_and_local_competition_are_the_brute_force_k_nearest(k: int) -> None:
    rng = np.random.default_rng(k)
    reference = rng.random((12, 3))
    objectives = rng.integers(0, 4, 12).astype(float)  # ties in fitness: not beaten
    points = np.vstack([reference[[2, 7]], rng.random((3, 3))])
    own = [2, 7, None, None, None]
    point_objectives = np.concatenate([objectives[[2, 7]], rng.integers(0, 4, 3)])
    novelty, competition = neighbour_scores(points, point_objectives, reference, objectives, k, own)
    for i, point in enumerate(points):
        others = [(reference[j], objectives[j]) for j in range(12) if j != own[i]]
        expected = _brute_force(point, point_objectives[i], others, k)
        assert novelty[i] == pytest.approx(expected[0], rel=1e-12)
        assert competition[i] == expected[1]


def test_a_body_s_novelty_is_among_the_archive_and_the_bodies_ranked() -> None:
    rng = np.random.default_rng(5)
    search = _novelty(k=4, novelty_threshold=0.3)
    told = []
    for generation in range(4):
        bodies = _random_bodies(rng, len(told), 6)
        members = set(search.members()[0])
        archive = {n: (p, o) for n, o, p in zip(*search.members())}
        search.tell(bodies)
        # a new body entered the archive iff its novelty among the members before was enough
        # (an empty archive takes them all)
        for body in bodies:
            others = list(archive.values())
            novelty = _brute_force(search.place(body), 0.0, others, 4)[0]
            entered = body.number in set(search.members()[0]) - members
            assert entered == (not others or novelty >= 0.3), (generation, body.number)
        told += bodies
    pool = search.population + _random_bodies(rng, len(told), 4)
    archive = {n: (p, o) for n, o, p in zip(*search.members())}
    reference = {**archive, **{b.number: (search.place(b), b.fitness) for b in pool}}
    scores = search.scores(pool)
    assert sorted(scores) == sorted(b.number for b in pool)
    for body in pool:
        others = [reference[n] for n in sorted(reference) if n != body.number]
        novelty, beaten = _brute_force(search.place(body), body.fitness, others, 4)
        assert scores[body.number] == (pytest.approx(novelty, rel=1e-12), beaten)


def test_the_recorded_novelty_is_the_one_selection_ranked_by_and_survives_a_checkpoint() -> None:
    """The novelty table and the progress line measured the survivors again among themselves,
    not what selection saw (the archive and parents and children): under pure novelty
    selection the recorded values did not fall with the rank."""
    rng = np.random.default_rng(11)
    search = _novelty(k=3, novelty_threshold=0.2)
    for generation in range(4):
        search.tell(_random_bodies(rng, 6 * generation, 6))
        rows = sorted((r for r in search.novelty_rows() if r["rank"] >= 0), key=lambda r: r["rank"])
        values = [r["novelty"] for r in rows]
        assert values == sorted(values, reverse=True), generation
    pool = search.population  # the last tell's pool held these and the bodies it dropped
    assert [r["novelty"] for r in rows] != [search.scores(pool)[b.number][0] for b in pool]
    again = _novelty(k=3, novelty_threshold=0.2)
    again.restore(json.loads(json.dumps(search.state())), pool)
    assert again.novelty_rows() == search.novelty_rows()
    assert again.stats() == search.stats()


# Five bodies on a line (exact binary places), k = 2: novelty / local competition
#   A 0     fitness 1: neighbours B, C -> 0.1875 / 0
#   B 0.125 fitness 5: neighbours A, C -> 0.125  / 2
#   C 0.25  fitness 3: neighbours B, A -> 0.1875 / 1
#   D 0.625 fitness 2: neighbours C, E -> 0.375  / 1
#   E 1     fitness 0: neighbours D, C -> 0.5625 / 0
LINE = {"A": (0.0, 1.0), "B": (0.125, 5.0), "C": (0.25, 3.0), "D": (0.625, 2.0), "E": (1.0, 0.0)}


def _line(maximise: bool = True) -> list[Body]:
    sign = 1.0 if maximise else -1.0
    return [_made(n, (x, 0.0), sign * f) for n, (x, f) in enumerate(LINE.values())]


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        # novelty alone: E, D, then A and C tied (by number), then B
        ({}, "EDACB"),
        # NSLC: fronts of (novelty, local competition): {E, D, B}, {C}, {A}; by novelty
        ({"selection": "novelty+fitness", "local_competition": True}, "EDBCA"),
        # novelty and fitness: fronts {E, D, C, B}, {A}
        ({"selection": "novelty+fitness"}, "EDCBA"),
    ],
)
@pytest.mark.parametrize("maximise", [True, False])
def test_the_ranking_matches_its_definition_on_a_hand_made_line(
    options: dict, expected: str, maximise: bool
) -> None:
    search = _novelty(maximise, k=2, **options)
    bodies = _line(maximise)
    scores = search.scores(bodies)
    assert [scores[b.number] for b in bodies] == [
        (0.1875, 0),
        (0.125, 2),
        (0.1875, 1),
        (0.375, 1),
        (0.5625, 0),
    ]
    names = "ABCDE"
    assert "".join(names[b.number] for b in search.ranked(bodies)) == expected
    search.tell(bodies)  # generation 0: the best `population` (3) survive, ranked
    assert "".join(names[b.number] for b in search.population) == expected[:3]


def test_pareto_fronts_peel_the_non_dominated() -> None:
    values = np.array([[0.5, 0], [0.4, 1], [0.1, 2], [0.2, 1], [0.2, 0], [0.5, 0]])
    assert pareto_fronts(values).tolist() == [0, 0, 0, 1, 2, 0]  # equal rows: one front


def test_failed_bodies_rank_last_and_never_enter_the_archive() -> None:
    search = _novelty(settings=BodyConfig(population=5, offspring=4))
    bodies = _line()
    bodies[1].fitness = math.nan
    bodies[3].status, bodies[3].fitness = "error", -math.inf
    bodies[4].descriptors = {"joints_ratio": math.nan, "symmetry": 0.0}
    search.tell(bodies)
    assert search.members()[0] == [0, 2]
    assert [b.number for b in search.population[-3:]] == [1, 3, 4]
    assert sorted(search.scores(bodies)) == [0, 2]
    assert {row["body_id"] for row in search.archive_rows()} == {"b000000", "b000002"}


# -- the optimizer -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"selection": "novelty+fitness"},
        {"selection": "novelty+fitness", "k": 2, "local_competition": True},
    ],
)
def test_novelty_passes_the_body_optimizer_check(options: dict) -> None:
    assert body_optimizers.provenance("novelty")["object"] == (
        "ariel.evolution._novelty:NoveltySearch"
    )
    check_body_optimizer("novelty", **options)


def test_defaults_are_map_elites_and_generation_0_is_the_ga_s() -> None:
    default = inspect.signature(NoveltySearch).parameters["measures"].default
    assert default == inspect.signature(MapElites).parameters["measures"].default
    search = NoveltySearch(encoder=_VectorEncoder(), seed=3, maximise=True, settings=SETTINGS)
    assert (search.k, search.novelty_threshold, search.selection) == (15, 0.05, "novelty")
    assert search.ranges == [(0.0, 8.0), (0.0, 1.0)]  # map_elites' DEFAULT_RANGES
    expected = random_proposals(_VectorEncoder(), 3, 3)
    assert [p.genotype for p in search.ask(3)] == [p.genotype for p in expected]


def _generations(search: NoveltySearch, first: int, count: int, told: int) -> list[str]:
    """``count`` ask/tell rounds on the checker's made-up bodies; the asks as JSON."""
    asked = []
    for generation in range(first, first + count):
        proposals = search.ask(3 if generation == 0 else 4)
        asked.append(json.dumps([(p.genotype, p.parent_ids) for p in proposals]))
        bodies = [_body(told + i, p, generation) for i, p in enumerate(proposals)]
        told += len(bodies)
        search.tell(bodies)
    return asked


@pytest.mark.parametrize(
    "options",
    [
        {"novelty_threshold": 0.4, "k": 3},
        {
            "selection": "novelty+fitness",
            "local_competition": True,
            "k": 3,
            "novelty_threshold": 0.4,
        },
    ],
)
@pytest.mark.parametrize("maximise", [True, False])
def test_a_restored_search_asks_and_keeps_exactly_what_the_first_does(
    options: dict, maximise: bool
) -> None:
    measures = ["num_limbs", "joints_ratio", "n_joints"]
    search = _novelty(maximise, **options, measures=measures)
    _generations(search, 0, 4, 0)
    members = search.members()[0]
    assert len(members) < 3 + 3 * 4  # some were not novel enough
    if search.local_competition:  # and some replaced a member: a later body at an earlier place
        assert members != sorted(members)
    state = json.loads(json.dumps(search.state(), allow_nan=False))
    restored = _novelty(maximise, **options, measures=measures)
    restored.restore(state, list(reversed(search.population)))  # order comes from the state
    assert restored.state() == state
    assert restored.population == search.population
    assert restored.archive_rows() == search.archive_rows()
    assert restored.stats() == search.stats()
    for name in ("index", "solution", "objective", "measures"):
        assert np.array_equal(restored.archive.data(name), search.archive.data(name))
    told = 3 + 3 * 4
    assert _generations(restored, 4, 3, told) == _generations(search, 4, 3, told)
    assert restored.state() == search.state()


def test_stats_add_the_novelty_archive_to_the_qd_metrics() -> None:
    search = _novelty(k=2, bins=[4, 4])
    search.tell(_line())
    stats = search.stats()
    assert stats["novelty_archive"] == 5
    assert stats["filled"] == 4 and stats["cells"] == 16  # A and B share a cell: B kept
    assert stats["coverage"] == 4 / 16 and stats["qd_score"] == 5 + 3 + 2 + 0
    assert [b.number for b in search.population] == [4, 3, 0]  # E, D, A
    assert stats["mean_novelty"] == pytest.approx((0.5625 + 0.375 + 0.1875) / 3)
    assert {row["body_id"] for row in search.archive_rows()} == {
        "b000001",
        "b000002",
        "b000003",
        "b000004",
    }
    assert population_text(None, stats).endswith(
        f", novelty archive 5, mean novelty {fmt_value(stats['mean_novelty'])}"
    )
    rows = search.novelty_rows()  # the novelty table's rows: population and archive
    assert [row["body_id"] for row in rows] == [f"b{n:06d}" for n in range(5)]
    assert sum(row["in_archive"] for row in rows) == stats["novelty_archive"]
    ranked = sorted((row for row in rows if row["rank"] >= 0), key=lambda row: row["rank"])
    assert [row["body_id"] for row in ranked] == ["b000004", "b000003", "b000000"]
    assert np.mean([row["novelty"] for row in ranked]) == pytest.approx(stats["mean_novelty"])
    outside = [row for row in rows if row["rank"] < 0]
    assert len(outside) == 2  # B and C, in the archive only
    assert all(math.isnan(row["novelty"]) and row["local_competition"] == -1 for row in outside)
    assert all(len(row["place"]) == 2 and min(row["place"]) >= 0 for row in rows)


# -- options -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"colour": "red"}, TypeError, "unknown option 'colour'; allowed: " + ", ".join(OPTIONS)),
        ({"k": 0}, ValueError, "k must be an integer >= 1"),
        ({"k": 2.5}, ValueError, "k must be an integer >= 1"),
        ({"novelty_threshold": -0.1}, ValueError, "novelty_threshold must be a finite number"),
        ({"novelty_threshold": "far"}, ValueError, "novelty_threshold must be a finite number"),
        ({"local_competition": "yes"}, ValueError, "local_competition must be true or false"),
        ({"selection": "fitness"}, ValueError, "selection must be one of novelty, novelty"),
        ({"local_competition": True}, ValueError, "local_competition needs selection"),
        ({"measures": ["legs"]}, ValueError, "unknown measure 'legs'"),
        ({"ranges": [[1, 0], [0, 1]]}, ValueError, "low < high"),
        ({"bins": [4]}, ValueError, "one count per measure"),
    ],
)
def test_bad_options_are_one_line_naming_the_option(
    options: dict, error: type, message: str
) -> None:
    with pytest.raises(error) as caught:
        _novelty(**options)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_a_minimised_fitness_needs_a_qd_offset_as_for_map_elites() -> None:
    with pytest.raises(ValueError, match="qd_offset must be given for a minimised fitness"):
        NoveltySearch(encoder=None, seed=0, maximise=False, settings=SETTINGS)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"colour": "red"}, "unknown option 'colour'; allowed: bins, k, "),
        ({"local_competition": True}, "local_competition needs selection = 'novelty\\+fitness'"),
    ],
)
def test_a_run_with_bad_options_is_one_config_error_and_writes_nothing(
    options: dict, message: str, tmp_path: Path
) -> None:
    config = {
        "name": "novelty",
        "body": {"optimizer": "novelty", "optimizer_options": options},
        "record": {"rerun": False},
        "executor": {"kind": "serial"},
    }
    with pytest.raises(ConfigError, match="^body.optimizer_options: 'novelty': " + message):
        run_experiment(config, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


# -- a run -------------------------------------------------------------------------------------

# experiments/novelty_flat.toml's NSLC, made tiny: a few bodies, one brain iteration, 0.3 s.
NSLC = {
    "name": "nslc",
    "seed": 2,
    "generations": 3,
    "body": {
        "options": {"number_of_modules": 6},
        "optimizer": "novelty",
        "optimizer_options": {
            "measures": ["num_limbs", "joints_ratio"],
            "ranges": [[0, 8], [0, 1]],
            "bins": [4, 4],
            "k": 3,
            "novelty_threshold": 0.05,
            "local_competition": True,
            "selection": "novelty+fitness",
        },
        "population": 3,
        "offspring": 3,
    },
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.3},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


def test_an_interrupted_novelty_run_resumes_to_the_same_records(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference = tmp_path / "whole" / "run"  # the folder name is the run id, in every row
    run_experiment(NSLC, out=reference)
    out = tmp_path / "killed" / "run"
    interrupt_then_resume(NSLC, out, monkeypatch, after=0)
    assert table_digests(out) == table_digests(reference)
    resumed, whole = load_run(out), load_run(reference)
    assert len(whole.archive) and set(whole.archive["generation"]) == {0, 1, 2}
    pd.testing.assert_frame_equal(resumed.archive, whole.archive)
    assert set(whole.novelty["generation"]) == {0, 1, 2}  # the novelty table, every generation
    pd.testing.assert_frame_equal(resumed.novelty, whole.novelty)
    last = whole.novelty[whole.novelty["generation"] == 2]
    assert (last["rank"] >= 0).sum() == NSLC["body"]["population"]
    state = [
        json.loads((run / "checkpoints" / "state.json").read_text()) for run in (out, reference)
    ]
    assert state[0]["state"]["optimizer"] == state[1]["state"]["optimizer"]  # the novelty archive
