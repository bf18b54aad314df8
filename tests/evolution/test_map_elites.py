"""MAP-Elites over morphologies: the archive's invariants, its records, resume, bad options."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _helpers import table_digests

from ariel.evolution import BodyConfig, ConfigError, MapElites
from ariel.evolution._progress import Progress
from ariel.evolution._state import Body
from ariel.recording import load_run
from ariel.recording.store._load import Run, archive_quality_table
from ariel.runs import resume_experiment, run_experiment

MEASURES = ["num_limbs", "joints_ratio"]
BINS = [4, 5]
RANGES = [[0.0, 8.0], [0.0, 1.0]]

QD = {
    "name": "qd",
    "seed": 4,
    "generations": 4,
    "body": {
        "optimizer": "map_elites",
        "optimizer_options": {"measures": MEASURES, "bins": BINS, "ranges": RANGES},
        "options": {"number_of_modules": 10},
        "population": 6,
        "offspring": 5,
    },
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.4},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


def _cell(values: list[float]) -> int:
    """The grid cell of measure values (edges clipped into the edge cells, as pyribs does)."""
    index = []
    for value, bins, (low, high) in zip(values, BINS, RANGES):
        position = int(np.floor((value - low) / (high - low) * bins))
        index.append(min(max(position, 0), bins - 1))
    return int(np.ravel_multi_index(index, BINS))


@pytest.fixture(scope="module")
def qd_run(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("qd") / "run"
    run_experiment(QD, out=out)
    return out, load_run(out)


def test_every_elite_is_the_best_body_seen_in_its_cell(qd_run) -> None:
    _, run = qd_run
    bodies = run.bodies.drop_duplicates("body_id")
    bodies = bodies[(bodies["status"] == "ok") & bodies["fitness"].map(math.isfinite)]
    last = run.generations_done - 1
    archive = run.archive[run.archive["generation"] == last]
    assert len(archive) > 1
    seen: dict[int, list[tuple[float, str]]] = {}
    for row in bodies.itertuples():
        cell = _cell([getattr(row, name) for name in MEASURES])
        seen.setdefault(cell, []).append((row.fitness, row.body_id))
    assert set(archive["cell"]) == set(seen)  # every cell a body reached is filled
    for row in archive.itertuples():
        best = max(fitness for fitness, _ in seen[row.cell])
        assert row.fitness == best
        # ties keep the older body
        assert row.body_id == min(b for f, b in seen[row.cell] if f == best)
        assert _cell(list(row.measures)) == row.cell


def test_the_elites_are_the_selected_bodies_and_breed_the_next_generation(qd_run) -> None:
    _, run = qd_run
    for generation, group in run.bodies.groupby("generation"):
        archive = run.archive[run.archive["generation"] == generation]
        assert set(group[group["selected"]]["body_id"]) == set(archive["body_id"])
    children = run.bodies[run.bodies["is_new"] & (run.bodies["generation"] > 0)]
    for row in children.itertuples():
        before = run.archive[run.archive["generation"] == row.generation - 1]
        assert set(row.parent_ids) <= set(before["body_id"]), row.body_id


def test_coverage_and_qd_score_per_generation(qd_run) -> None:
    _, run = qd_run
    generations = run.generations
    cells = int(np.prod(BINS))
    assert run.info["qd_offset"] == 0.0  # the default for a maximised fitness, recorded
    for row in generations.itertuples():
        archive = run.archive[run.archive["generation"] == row.generation]
        assert row.coverage == pytest.approx(len(archive) / cells)
        assert row.qd_score == pytest.approx(archive["fitness"].sum())  # displacements >= 0
        assert row.norm_qd_score == pytest.approx(row.qd_score / cells)
    # an elite is only ever replaced by a better one: the QD-score never falls
    assert np.all(np.diff(generations["qd_score"]) >= 0)


def test_an_interrupted_map_elites_run_resumes_to_the_same_records(
    qd_run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference, _ = qd_run
    original = Progress.end_generation

    def stop_after_generation_one(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        if generation == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "end_generation", stop_after_generation_one)
    out = tmp_path / "run"  # the folder name is the run id, in every row
    with pytest.raises(KeyboardInterrupt):
        run_experiment(QD, out=out)
    monkeypatch.setattr(Progress, "end_generation", original)
    assert resume_experiment(out).status == "finished"
    assert table_digests(out) == table_digests(reference)
    assert sorted(p.name for p in (out / "archive").iterdir()) == sorted(
        p.name for p in (reference / "archive").iterdir()
    )


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"measures": ["legs"]}, "unknown measure 'legs'"),
        ({"measures": MEASURES, "bins": [4]}, "one count per measure"),
        ({"measures": MEASURES, "ranges": [[1, 0], [0, 1]]}, "low < high"),
        ({"measures": ["extent_x"]}, "ranges must be given for extent_x"),
        ({"colour": "red"}, "unknown option 'colour'; allowed: archive, bins, cells, measures, "),
    ],
)
def test_bad_options_are_one_config_error_and_write_nothing(
    options: dict, message: str, tmp_path: Path
) -> None:
    config = {**QD, "body": {**QD["body"], "optimizer_options": options}}
    with pytest.raises(ConfigError, match="body.optimizer_options: 'map_elites': .*" + message):
        run_experiment(config, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_an_unknown_optimizer_names_the_known_ones(tmp_path: Path) -> None:
    config = {**QD, "body": {**QD["body"], "optimizer": "annealing"}}
    with pytest.raises(ConfigError, match=r"body.optimizer: .*'annealing'.*ga.*map_elites"):
        run_experiment(config, out=tmp_path / "run")


def test_the_report_draws_the_archive_and_run_rrd_plays_it(tmp_path: Path) -> None:
    import rerun as rr

    from ariel.recording import make_report

    config = {**QD, "generations": 2, "record": {"rerun": True, "bodies": "elites"}}
    out = tmp_path / "run"
    run_experiment(config, out=out)
    report = make_report(out, render=False)
    assert out / "report" / "archive.png" in report.written
    heatmap = report.figures["archive.png"].axes[0]  # measures with their units, counts whole
    assert heatmap.get_xlabel() == "num_limbs (leaf modules)"  # as in the viewer: 0 across
    assert heatmap.get_ylabel() == "joints_ratio (hinges / modules)"
    assert all(float(t).is_integer() for t in heatmap.get_xticks())
    store = rr.chunk.RrdReader(out / "run.rrd").stream().collect()
    archive = [c for c in store.stream().to_chunks() if c.entity_path == "/archive"]
    grids = {}
    for chunk in archive:
        batch = chunk.to_record_batch()
        for generation, tensor in zip(
            batch.column("generation").to_pylist(),
            batch.column("Tensor:data").to_pylist(),
        ):
            grids[generation] = tensor
    assert sorted(grids) == [0, 1]  # one archive per generation, on the generation timeline
    run = load_run(out)
    filled = [len(run.archive[run.archive["generation"] == g]) for g in (0, 1)]
    shape = grids[1][0]["shape"]
    assert list(shape) == BINS
    cells = np.asarray(grids[1][0]["buffer"], dtype=np.float64)  # NaN: an empty cell
    assert int(np.isfinite(cells).sum()) == filled[1]


def test_a_ga_run_has_no_archive(tmp_path: Path) -> None:
    from ariel.recording import make_report

    body = {**QD["body"], "optimizer": "ga", "optimizer_options": {}}
    config = {**QD, "generations": 1, "body": body}
    out = tmp_path / "run"
    run_experiment(config, out=out)
    assert not (out / "archive").exists()
    assert "coverage" not in load_run(out).generations.columns
    assert out / "report" / "archive.png" not in make_report(out, render=False).written


# -- QD metrics, archive level (no physics) ----------------------------------------------------


def _archive_body(number: int, rng: np.random.Generator, fitness: float) -> Body:
    body = Body(number, [float(number)], [], 0)
    body.descriptors = {"num_limbs": float(rng.integers(0, 8)), "joints_ratio": rng.random()}
    body.fitness = fitness
    return body


def _map_elites(maximise: bool, **options) -> MapElites:
    settings = BodyConfig(population=4, offspring=4)
    return MapElites(
        encoder=None,
        seed=0,
        maximise=maximise,
        settings=settings,
        bins=BINS,
        ranges=RANGES,
        **options,
    )


@pytest.mark.parametrize(
    ("maximise", "options", "fitness_range", "failed"),
    [
        (True, {}, (-0.3, 1.0), -math.inf),  # some elites below the default offset 0
        (False, {"qd_offset": 2.0}, (0.0, 5.0), math.inf),  # some worse than the offset
    ],
)
def test_the_qd_score_is_never_negative_and_never_falls(
    maximise: bool, options: dict, fitness_range: tuple, failed: float
) -> None:
    rng = np.random.default_rng(7)
    archive = _map_elites(maximise, **options)
    cells = int(np.prod(BINS))
    scores, number = [], 0
    for _ in range(12):
        bodies = []
        for _ in range(5):
            bodies.append(_archive_body(number, rng, float(rng.uniform(*fitness_range))))
            number += 1
        bodies.append(_archive_body(number, rng, failed))  # a failed evaluation
        bodies.append(_archive_body(number + 1, rng, math.nan))
        number += 2
        archive.tell(bodies)
        stats = archive.stats()
        scores.append(stats["qd_score"])
        assert stats["qd_score"] >= 0
        assert stats["norm_qd_score"] == pytest.approx(stats["qd_score"] / cells)
        assert stats["coverage"] == len(archive.population) / cells
        assert all(math.isfinite(body.fitness) for body in archive.population)
    assert np.all(np.diff(scores) >= 0) and scores[-1] > scores[0]
    # and the same number from the archive table, as load_run computes it
    rows = pd.DataFrame([{"generation": 11, **row} for row in archive.archive_rows()])
    quality = archive_quality_table(rows, archive.qd_offset, maximise).loc[11]
    assert quality["qd_score"] == pytest.approx(scores[-1])
    assert quality["norm_qd_score"] == pytest.approx(scores[-1] / cells)
    assert quality["coverage"] == stats["coverage"]


def test_with_every_elite_beyond_the_offset_the_qd_score_is_pyribs() -> None:
    rng = np.random.default_rng(3)
    archive = _map_elites(False, qd_offset=5.0)  # minimised: fitness 0..3 all better than 5
    archive.tell([_archive_body(n, rng, float(rng.uniform(0.0, 3.0))) for n in range(30)])
    stats, pyribs = archive.stats(), archive.archive.stats
    assert stats["qd_score"] == pytest.approx(float(pyribs.qd_score))
    assert stats["norm_qd_score"] == pytest.approx(float(pyribs.norm_qd_score))
    assert stats["coverage"] == pytest.approx(float(pyribs.coverage))
    expected = sum(5.0 - body.fitness for body in archive.population)
    assert stats["qd_score"] == pytest.approx(expected)


def test_a_minimised_fitness_needs_a_qd_offset(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="qd_offset must be given for a minimised fitness"):
        _map_elites(False)
    config = {**QD, "task": {**QD["task"], "fitness": "distance_to_target"}}
    with pytest.raises(ConfigError, match="'map_elites': qd_offset must be given"):
        run_experiment(config, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_an_old_run_without_a_recorded_offset_still_reads(tmp_path: Path) -> None:
    rows = pd.DataFrame(
        [{"generation": 0, "cell": 0, "fitness": 0.5, "grid": [2, 2]}]  # before qd_offset
    )
    maximised = Run(tmp_path, {"maximise": True})
    assert maximised.qd_offset == 0.0  # what its QD-score summed then
    assert archive_quality_table(rows, 0.0, True).loc[0, "qd_score"] == 0.5
    minimised = Run(tmp_path, {"maximise": False})
    assert minimised.qd_offset is None
    quality = archive_quality_table(rows, None, False).loc[0]
    assert quality["coverage"] == 0.25 and math.isnan(quality["qd_score"])
    assert Run(tmp_path, {"maximise": False, "qd_offset": 3}).qd_offset == 3.0
