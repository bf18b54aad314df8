"""`ariel export RUN EVAL_ID|best DIR`: MJCF that MuJoCo loads, genotype and controller JSON,
and a replay script on the tutorial API that runs and follows the recorded path; a run folder
is data: its ids never become code (issue 27)."""

from __future__ import annotations

import ast
import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _helpers import (
    exit_code,
    one_error_line,
    run_replay_script,
    tiny_finished_run,
)

from ariel.recording import load_run


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_finished_run(tmp_path_factory, "export", 7)


def test_export_writes_mjcf_json_and_a_replay_script_that_follows_the_run(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "best"
    assert exit_code(["export", str(run_dir), "best", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == [
        "body.xml",
        "controller.json",
        "genotype.json",
        "replay.py",
    ]
    run = load_run(run_dir)
    brain = json.loads((out / "controller.json").read_text())
    row = run.evaluations.set_index("eval_id").loc[brain["eval_id"]]
    ok = run.evaluations[np.isfinite(run.evaluations["fitness"])]
    assert row["fitness"] == ok["fitness"].max()  # the best one
    assert brain["params"] == list(row["controller_params"])  # exact
    genotype = json.loads((out / "genotype.json").read_text())
    assert genotype["genotype"] == json.loads(row["body_genotype"])
    assert genotype["body_encoder"] == row["body_encoder"]

    model = mujoco.MjModel.from_xml_path(str(out / "body.xml"))  # what MuJoCo's viewer loads
    assert model.nu == row["n_joints"]

    done = run_replay_script(out, tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    final = json.loads(lines[0].removeprefix("core at "))
    frames = run.trajectories[run.trajectories["eval_id"] == brain["eval_id"]].sort_values("t")
    start = frames[["core_x", "core_y", "core_z"]].to_numpy()[0]
    end = frames[["core_x", "core_y", "core_z"]].to_numpy()[-1]
    np.testing.assert_array_equal(final, end)  # the tutorial path is the engine's
    assert np.linalg.norm(end - start) > 1e-3  # it moved
    # ... printed beside what the run recorded: the core's end and the fitness
    assert json.loads(lines[1].removeprefix("recorded core at ")) == final
    # the replay's own fitness (the run's function on the frames it kept), beside the record's
    from ariel.plugins import fitness_functions

    unit = fitness_functions.get(brain["fitness_fn"]).unit
    unit = f" {unit}" if unit else ""
    recorded = float(row["fitness"])
    assert lines[2] == (
        f"replayed fitness {recorded!r}{unit} (recorded {recorded!r}{unit}; {brain['fitness_fn']})"
    )
    assert lines[3] == f"evaluation {brain['eval_id']} of run {brain['run_id']}"
    assert brain["backend"] == "mujoco"
    # A MuJoCo Warp evaluation (executor gpu) replays a little differently: it says why; a
    # run without trajectories has no core to show ("recorded core at None" before)
    (out / "controller.json").write_text(
        json.dumps({**brain, "backend": "mujoco-warp:cuda", "core_end": None})
    )
    again = run_replay_script(out, tmp_path).stdout.splitlines()
    assert again[1] == "recorded core at (not recorded: no trajectories)"
    assert (
        again[3]
        == "the run simulated it with mujoco-warp:cuda (float32): this MuJoCo replay differs"
    )


def test_the_mujoco_viewer_is_offered_only_where_a_window_can_open(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    """Headless, the offered `python -m mujoco.viewer` failed with GLFW errors and left a
    MUJOCO_LOG.TXT where it ran."""
    from ariel.cli import _export

    for display, shown in ((False, False), (True, True)):
        monkeypatch.setattr(_export, "has_display", lambda display=display: display)
        assert exit_code(["export", str(run_dir), "best", str(tmp_path / str(display))]) == 0
        said = capsys.readouterr().out
        assert ("-m mujoco.viewer" in said) is shown and "replay.py (" in said


def test_export_of_an_unknown_evaluation_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(["export", str(run_dir), "b999999-i000-c000", str(tmp_path / "x")]) == 2
    assert "no evaluation 'b999999-i000-c000'" in one_error_line(capsys)
    assert not (tmp_path / "x").exists()


def test_lineage_may_come_before_the_evaluation_and_its_folder(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """argparse bound EVAL_ID too early: options first was "unrecognized arguments"."""
    lineage, out = tmp_path / "lineage.csv", tmp_path / "best"
    assert exit_code(["export", str(run_dir), "--lineage", str(lineage), "best", str(out)]) == 0
    assert (out / "replay.py").is_file() and lineage.read_text().startswith("id,")
    assert "wrote" in capsys.readouterr().out


def test_export_into_a_folder_that_is_not_empty_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    assert exit_code(["export", str(run_dir), "best", str(tmp_path)]) == 2
    assert "is not an empty folder" in one_error_line(capsys)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux's /proc")
def test_an_export_that_cannot_be_made_names_the_folder_asked_for(
    run_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It named its hidden folder beside it, half cut: "cannot write '/proc/x.2b671b2e...'"."""
    assert exit_code(["export", str(run_dir), "best", "/proc/ariel-export"]) == 2
    assert one_error_line(capsys).startswith("ariel: error: cannot write '/proc/ariel-export': ")


def test_nothing_is_exported_into_a_run_folder(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An export or a lineage CSV inside a run folder was written there, among its records
    (a folder named like a generation's table, a CSV in manifests/): the run then failed
    `ariel verify`. Refused in one line, as --rrd and --video are."""
    from ariel.recording import lineage, write_lineage_csv

    before = sorted(p.relative_to(run_dir) for p in run_dir.rglob("*"))
    table = next((run_dir / "evaluations").glob("*.parquet")).with_name("gen-000099.parquet")
    for command in (
        ["export", str(run_dir), "best", str(table)],
        ["export", str(run_dir), "best", str(run_dir / "new" / "deeper")],
        ["export", str(run_dir), "--lineage", str(run_dir / "manifests" / "lineage.csv")],
    ):
        assert exit_code(command) == 2, command
        assert "is inside the run or campaign folder" in one_error_line(capsys)
    with pytest.raises(ValueError, match="inside the run or campaign folder"):
        write_lineage_csv(lineage(load_run(run_dir)), run_dir / "lineage.csv")
    assert sorted(p.relative_to(run_dir) for p in run_dir.rglob("*")) == before


# --- a run folder is data: its ids never become code ------------------------------------------

CRAFTED = '"""\nimport pathlib; pathlib.Path("code-ran").touch()\n"""'


def test_replay_script_holds_no_data_of_the_run(run_dir: Path, tmp_path: Path) -> None:
    """replay.py is the same text for every export: the ids are read from controller.json
    when it runs, so no id can close a string and become code."""
    import string

    from ariel.recording.resim._export import _SCRIPT, export

    fields = {name for _, name, _, _ in string.Formatter().parse(_SCRIPT) if name}
    assert fields == {"core"}  # our constant, the core geom's name: nothing of the run
    evaluations = load_run(run_dir).evaluations
    ok = evaluations[np.isfinite(evaluations["fitness"])]
    scripts = []
    for eval_id in ("best", ok.sort_values("fitness")["eval_id"].iloc[0]):  # best, worst
        out = export(run_dir, eval_id, tmp_path / eval_id)
        scripts.append((out / "replay.py").read_text())
        assert json.loads((out / "controller.json").read_text())["eval_id"] not in scripts[-1]
    assert scripts[0] == scripts[1]
    ast.parse(scripts[0])


def test_a_crafted_run_id_is_refused_in_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    info = json.loads((copy / "run.json").read_text())
    info["run_id"] = CRAFTED
    (copy / "run.json").write_text(json.dumps(info))
    assert exit_code(["export", str(copy), "best", str(tmp_path / "x")]) == 2
    line = one_error_line(capsys)
    assert "holds a run id that is not one: " in line and "code-ran" in line
    assert not (tmp_path / "x").exists()


def test_a_crafted_eval_id_is_refused_in_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The table changed and its manifest written again, as a crafter would."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ariel.recording.store._manifest import write_manifest

    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    best = load_run(copy).evaluations.sort_values("fitness").iloc[-1]
    generation = int(best["generation"])
    path = copy / "evaluations" / f"gen-{generation:06d}.parquet"
    table = pq.read_table(path)
    ids = [CRAFTED if i == best["eval_id"] else i for i in table.column("eval_id").to_pylist()]
    column = table.schema.get_field_index("eval_id")
    table = table.set_column(column, table.schema.field(column), pa.array(ids, pa.string()))
    pq.write_table(table, path)
    write_manifest(copy, generation)
    assert exit_code(["export", str(copy), "best", str(tmp_path / "x")]) == 2
    line = one_error_line(capsys)
    assert "has eval_id " in line and "code-ran" in line and "not an id" in line
    assert not (tmp_path / "x").exists()


def test_a_crafted_id_in_an_exported_folder_runs_nothing(run_dir: Path, tmp_path: Path) -> None:
    """An exported folder mailed on with its controller.json edited: replay.py reads the id
    as data, refuses it, and runs none of it."""
    from ariel.recording.resim._export import export

    out = export(run_dir, "best", tmp_path / "x")
    brain = json.loads((out / "controller.json").read_text())
    brain["run_id"] = CRAFTED
    (out / "controller.json").write_text(json.dumps(brain))
    done = run_replay_script(out, tmp_path)
    assert done.returncode != 0 and not (tmp_path / "code-ran").exists()
    assert "holds a run id that is not one" in done.stderr.splitlines()[-1]


def test_replayed_fitness_needs_the_whole_simulation_and_the_exported_frame_rate(
    run_dir: Path, tmp_path: Path
) -> None:
    import math

    from ariel.recording import load_exported
    from ariel.recording.resim._export import export

    out = export(run_dir, "best", tmp_path / "x")
    robot = load_exported(out)
    with pytest.raises(ValueError, match="simulate the robot for its"):
        robot.replayed_fitness()  # not simulated yet
    brain = json.loads((out / "controller.json").read_text())
    del brain["record_every"]  # an export made before the key
    (out / "controller.json").write_text(json.dumps(brain))
    assert math.isnan(load_exported(out).replayed_fitness())
