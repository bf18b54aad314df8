"""CVT-MAP-Elites (``map_elites`` with ``archive = "cvt"``): centroids from the seed, kept by
state and restore, recorded in run.json's archive description, and read back by the report,
the viewer and run.rrd as a CVT, not a grid; bad options are one line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from _helpers import interrupt_then_resume, table_digests

from ariel.evolution import BodyConfig, ConfigError, MapElites
from ariel.evolution._optimizer_checks import check_body_optimizer
from ariel.evolution._state import Body
from ariel.recording import load_run, make_report
from ariel.recording.store import describe_archive
from ariel.runs import run_experiment

MEASURES = ["num_limbs", "joints_ratio"]
RANGES = [[0.0, 4.0], [0.0, 1.0]]
CELLS = 12
CVT = {
    "name": "cvt",
    "seed": 5,
    "generations": 2,
    "body": {
        "options": {"number_of_modules": 6},
        "population": 4,
        "offspring": 3,
        "optimizer": "map_elites",
        "optimizer_options": {
            "archive": "cvt",
            "cells": CELLS,
            "measures": MEASURES,
            "ranges": RANGES,
        },
    },
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.3},
    "executor": {"kind": "serial"},
    "record": {"rerun": True},
}


def _cvt(seed: int, **options) -> MapElites:
    settings = BodyConfig(population=4, offspring=4)
    options = {"archive": "cvt", "cells": CELLS, "ranges": RANGES, **options}
    return MapElites(encoder=None, seed=seed, maximise=True, settings=settings, **options)


def _bodies(count: int, rng: np.random.Generator) -> list[Body]:
    bodies = []
    for number in range(count):
        body = Body(number, [float(number)], [], 0)
        body.descriptors = {"num_limbs": float(rng.integers(0, 5)), "joints_ratio": rng.random()}
        body.fitness = float(rng.random())
        bodies.append(body)
    return bodies


def _nearest(centroids: np.ndarray, measures: list[float]) -> int:
    """The cell of measure values: the nearest centroid, in the measures scaled by RANGES."""
    low, high = np.array(RANGES).T
    point = np.clip((np.array(measures) - low) / (high - low), 0.0, 1.0)
    scaled = (centroids - low) / (high - low)
    return int(np.argmin(np.sum((scaled - point) ** 2, axis=1)))


def test_centroids_come_from_the_seed_and_survive_state_and_restore() -> None:
    first, again, other = _cvt(3), _cvt(3), _cvt(4)
    assert first.centroids.shape == (CELLS, 2)
    assert np.array_equal(first.centroids, again.centroids)  # bit for bit
    assert not np.allclose(first.centroids, other.centroids)
    first.tell(_bodies(20, np.random.default_rng(0)))
    state = json.loads(json.dumps(first.state(), allow_nan=False))
    # Restored into an optimizer whose seed would make other centroids: the run's own come back.
    other.restore(state, first.population)
    assert np.array_equal(other.centroids, first.centroids)
    assert other.archive_rows() == first.archive_rows()
    described = first.archive_description()
    assert described["kind"] == "cvt" and described["cells"] == CELLS
    assert np.allclose(np.array(described["centroids"])[:, 0], first.centroids[:, 0] * 4.0)
    for row in first.archive_rows():
        assert row["grid"] == [CELLS]
        assert row["cell"] == _nearest(np.array(described["centroids"]), row["measures"])


def test_the_optimizer_check_passes_for_a_cvt_and_a_grid() -> None:
    check_body_optimizer("map_elites", archive="cvt", cells=8)
    check_body_optimizer("map_elites")


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"archive": "hex"}, "archive must be one of grid, cvt, got 'hex'"),
        ({"archive": "cvt", "cells": 0}, r"cells must be an integer >= 1 .*got 0"),
        ({"archive": "cvt", "bins": [2, 2]}, "bins is an option of archive = 'grid'"),
        ({"cells": 9}, "cells is an option of archive = 'cvt'"),
        # Too many cells: a 298 GiB allocation (a traceback), or minutes of k-means unsaid.
        ({"archive": "cvt", "cells": 10**9}, "cells must be at most 10,000, got 1,000,000,000"),
        ({"bins": [10**5, 10**5]}, r"bins \[100000, 100000\] make 10,000,000,000 cells; at most"),
        # Read letter by letter ("unknown measure 'n'"), or a grid only its diagonal fills.
        ({"measures": "num_limbs"}, "measures must be a non-empty list of: num_modules"),
        ({"measures": ["depth", "depth"]}, "measure 'depth' is listed twice; each measure once"),
    ],
)
def test_bad_options_are_one_config_error(options: dict, message: str, tmp_path: Path) -> None:
    config = {**CVT, "body": {**CVT["body"], "optimizer_options": options}}
    with pytest.raises(ConfigError, match="body.optimizer_options: 'map_elites': " + message):
        run_experiment(config, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


@pytest.fixture(scope="module")
def cvt_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cvt") / "run"
    run_experiment(CVT, out=out)
    return out


def test_a_cvt_run_records_its_archive_and_its_centroids(cvt_run: Path) -> None:
    run = load_run(cvt_run)
    described = run.archive_description
    assert described == json.loads((cvt_run / "run.json").read_text())["archive"]
    assert described["kind"] == "cvt" and described["measures"] == MEASURES
    centroids = np.array(described["centroids"])
    assert centroids.shape == (CELLS, 2)
    state = json.loads((cvt_run / "checkpoints" / "state.json").read_text())["state"]
    unit = np.array(state["optimizer"]["centroids"])  # exact, for resume
    assert np.allclose(centroids, unit * np.array(RANGES)[:, 1])
    archive = run.archive
    assert len(archive) and set(archive["generation"]) == {0, 1}
    for row in archive.itertuples():
        assert list(row.grid) == [CELLS]
        assert row.cell == _nearest(centroids, list(row.measures))
    for row in run.generations.itertuples():
        filled = (archive["generation"] == row.generation).sum()
        assert row.coverage == pytest.approx(filled / CELLS)


def test_the_report_view_and_run_rrd_draw_a_cvt(cvt_run: Path) -> None:
    import rerun as rr

    from ariel.recording.rerun import ARCHIVE_ENTITY, CvtCells, write_blueprint
    from ariel.recording.viewer._view import _archive_beside

    report = make_report(cvt_run, render=False)
    assert cvt_run / "report" / "archive.png" in report.written
    axes = report.figures["archive.png"].axes[0]
    assert axes.get_title().startswith("CVT archive after generation 1")
    assert axes.get_xlabel().startswith("num_limbs") and axes.get_ylabel().startswith("joints")
    run = load_run(cvt_run)
    cells, names = _archive_beside(run)
    assert isinstance(cells, CvtCells) and names == ["num_limbs (0 to 4)", "joints_ratio (0 to 1)"]
    last = run.archive[run.archive["generation"] == 1]
    assert np.isfinite(cells.fitness).sum() == len(last)
    assert np.allclose(cells.fitness[last["cell"]], last["fitness"])
    points = {}  # run.rrd: the archive per generation, points at the centroids
    for chunk in rr.chunk.RrdReader(cvt_run / "run.rrd").stream().to_chunks():
        if chunk.entity_path == "/archive":
            batch = chunk.to_record_batch()
            for g, p in zip(
                batch["generation"].to_pylist(), batch["Points2D:positions"].to_pylist()
            ):
                points[g] = p
    assert sorted(points) == [0, 1] and len(points[1]) == CELLS
    assert np.allclose(np.array(points[1]), cells.positions(), atol=1e-6)
    layout = cvt_run / "cvt.rbl"
    write_blueprint(layout, archive="cvt")
    (store,) = rr.chunk.RrdReader(layout).blueprints()
    kinds = {}  # the layout's views: origin -> kind
    for chunk in rr.chunk.RrdReader(layout).stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            (origin,) = batch["ViewBlueprint:space_origin"].to_pylist()[0]
            kinds[origin] = batch["ViewBlueprint:class_identifier"].to_pylist()[0][0]
    assert kinds[ARCHIVE_ENTITY] == "2D"  # a 2D view of points, not a tensor view


def test_an_interrupted_cvt_run_resumes_to_the_same_records(
    cvt_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "run"  # the folder name is the run id, as the reference's
    interrupt_then_resume(CVT, out, monkeypatch, after=0)
    assert table_digests(out) == table_digests(cvt_run)
    resumed, reference = load_run(out), load_run(cvt_run)
    pd.testing.assert_frame_equal(resumed.archive, reference.archive)
    assert resumed.archive_description == reference.archive_description


def test_an_old_run_without_a_description_is_its_grid() -> None:
    rows = pd.DataFrame({"generation": [0], "cell": [3], "fitness": [0.5], "grid": [[2, 3]]})
    options = {"measures": ["depth", "symmetry"], "ranges": [[0, 5], [0, 1]]}
    info = {"config": {"body": {"optimizer_options": options}}}
    assert describe_archive(info, rows) == {
        "kind": "grid",
        "measures": ["depth", "symmetry"],
        "ranges": [[0.0, 5.0], [0.0, 1.0]],
        "bins": [2, 3],
    }
    defaults = describe_archive({"config": {}}, rows)
    assert defaults["measures"] == MEASURES and defaults["ranges"] == [[0.0, 8.0], [0.0, 1.0]]
    assert describe_archive({"config": {}}, rows.iloc[:0]) is None


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda a: a.update(centroids="x"), "has no centroids of one number per measure"),
        (lambda a: a.update(centroids=a["centroids"][:3]), "another count of cells than of"),
        (lambda a: a.update(kind="grid", bins=[0, 8]), r"no count of bins \(>= 1\) per measure"),
        (lambda a: a.update(kind="grid", bins=[4, 4]), "the archive table has a grid other"),
        (lambda a: a.update(ranges=[[8, 0], [0, 1]]), r"no \[low, high\] range"),
        (lambda a: a.update(kind="hex"), r"describes no grid or CVT \('hex'\)"),
    ],
)
def test_a_damaged_archive_description_is_one_line_not_a_wrong_number(
    cvt_run: Path, tmp_path: Path, change: Any, message: str
) -> None:
    """run.json's archive, edited: readers indexed past the archive (IndexError), divided by
    no cells (ZeroDivisionError) or drew 400 % coverage from 3 centroids where 32 were."""
    import shutil

    from ariel.errors import DamagedRunError

    copy = shutil.copytree(cvt_run, tmp_path / "run")
    info = json.loads((copy / "run.json").read_text())
    change(info["archive"])
    (copy / "run.json").write_text(json.dumps(info))
    run = load_run(copy)
    with pytest.raises(DamagedRunError, match=f"is damaged: .*{message}"):
        run.generations  # noqa: B018  # coverage and the QD-score read the description
    with pytest.raises(DamagedRunError, match=message):
        run.archive_description  # noqa: B018
    # ... and for the viewer's archive beside a robot, and the gallery's atlas (which fell
    # back to the config's grid: a damaged run.json read as one that describes no archive)
    from ariel.recording.analysis._gallery_select import _described
    from ariel.recording.viewer._archive_panel import archive_beside

    for reader in (archive_beside, _described):
        with pytest.raises(DamagedRunError, match=message):
            reader(load_run(copy))


def test_archive_rows_outside_the_described_archive_are_damage() -> None:
    from ariel.recording.store import archive_damage

    grid = {"kind": "grid", "measures": ["depth"], "ranges": [[0, 4]], "bins": [4]}
    rows = pd.DataFrame({"cell": [0, 3], "grid": [[4], [4]]})
    assert archive_damage(grid, rows) is None
    assert archive_damage(grid, rows.assign(cell=[0, 4])) == (
        "the archive table",
        "has a cell outside the archive's 4",
    )
    assert archive_damage(grid, rows.assign(cell=[-1, 0]))[1].startswith("has a cell outside")
