"""Replay: one evaluation re-simulated from the run folder alone reproduces its stored fitness
bit for bit, from the very task the loop built."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from ariel.evolution import run_experiment
from ariel.recording import UnknownEvaluationError, load_run, replay
from ariel.recording.resim._replay import replay_task

CONFIG = {
    "name": "replaytiny",
    "seed": 11,
    "generations": 3,
    "body": {"options": {"number_of_modules": 6}, "population": 2, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 0.5},
    "executor": {"kind": "serial"},
}
BRAIN_ONLY = {
    **CONFIG,
    "name": "replaybrain",
    "generations": 2,
    "body": {"encoder": "prebuilt", "genotype": "gecko"},
}


def _bits(value: float) -> bytes:
    return np.float64(value).tobytes()


def _make_run(config: dict, out: Path) -> tuple[Path, list]:
    """Run ``config`` into ``out``; also return every task the loop handed to the engine."""
    import ariel.evaluation

    original = ariel.evaluation.evaluate_batch
    tasks: list = []

    def capture(batch, **kwargs):
        tasks.extend(batch)
        return original(batch, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ariel.evaluation, "evaluate_batch", capture)
        run_experiment(config, out=out)
    return out, tasks


@pytest.fixture(scope="module")
def coevolution(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    return _make_run(CONFIG, tmp_path_factory.mktemp("runs") / "coevolution")


@pytest.fixture(scope="module")
def brain_only(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    return _make_run(BRAIN_ONLY, tmp_path_factory.mktemp("runs") / "brain")


def _pick(run_dir: Path) -> dict[str, str]:
    evals = load_run(run_dir).evaluations
    last = evals[evals["generation"] == evals["generation"].max()]
    return {
        "best": "best",
        "arbitrary": evals["eval_id"].iloc[len(evals) // 3],
        "later generation": last["eval_id"].iloc[-1],
        "worst": evals.loc[evals["fitness"].idxmin(), "eval_id"],
    }


def test_replay_rebuilds_the_very_task_the_loop_evaluated(coevolution, brain_only) -> None:
    for run_dir, tasks in (coevolution, brain_only):
        run = load_run(run_dir)
        assert len(tasks) == len(run.evaluations) > 0
        built = {task.eval_id: task for task in tasks}
        for row in run.evaluations.to_dict("records"):
            assert replay_task(run, row) == built[row["eval_id"]], row["eval_id"]


@pytest.mark.parametrize("which", ["best", "arbitrary", "later generation", "worst"])
def test_replayed_fitness_is_the_stored_one_bit_for_bit(coevolution, which: str) -> None:
    run_dir, _ = coevolution
    eval_id = _pick(run_dir)[which]
    replayed = replay(run_dir, eval_id)
    stored = load_run(run_dir).evaluations.set_index("eval_id").loc[replayed.eval_id]
    assert replayed.stored_fitness == stored["fitness"]
    assert _bits(replayed.fitness) == _bits(stored["fitness"])
    assert replayed.identical and replayed.status == stored["status"] == "ok"
    # (the git commit may turn "-dirty" while others edit this checkout: not a package version)
    assert set(replayed.version_differences) <= {"git_commit"}
    if which == "later generation":
        assert replayed.row["generation"] == 2


def test_best_is_the_best_stored_evaluation(coevolution) -> None:
    run_dir, _ = coevolution
    evals = load_run(run_dir).evaluations
    replayed = replay(run_dir, "best")
    assert replayed.eval_id == evals.loc[evals["fitness"].idxmax(), "eval_id"]
    assert replayed.fitness == evals["fitness"].max()


def test_a_brain_only_run_replays_bit_for_bit(brain_only) -> None:
    run_dir, _ = brain_only
    for eval_id in _pick(run_dir).values():
        replayed = replay(run_dir, eval_id)
        assert replayed.row["body_encoder"] == "prebuilt"
        assert _bits(replayed.fitness) == _bits(replayed.stored_fitness)
        assert replayed.identical


def test_a_one_ulp_difference_is_not_identical(coevolution) -> None:
    run_dir, _ = coevolution
    replayed = replay(run_dir, "best")
    replayed.row["fitness"] = np.nextafter(replayed.stored_fitness, np.inf)
    assert not replayed.identical
    replayed.row["fitness"] = replayed.fitness
    replayed.row["status"] = "unstable"
    assert not replayed.identical


def test_unknown_ids_and_unfinished_generations_are_refused(coevolution, tmp_path: Path) -> None:
    run_dir, _ = coevolution
    with pytest.raises(UnknownEvaluationError) as info:
        replay(run_dir, "b999999-i000-c000")
    message = str(info.value)
    assert "\n" not in message and "b999999-i000-c000" in message
    assert "'best'" in message and "load_run" in message
    # A run killed after writing generation 2's tables but before counting it in run.json:
    # generation 2 is not part of the run yet, so its evaluations cannot be replayed.
    killed = tmp_path / "killed"
    shutil.copytree(run_dir, killed)
    info_path = killed / "run.json"
    data = json.loads(info_path.read_text())
    data.update(status="running", generations_done=2)
    info_path.write_text(json.dumps(data))
    later = _pick(run_dir)["later generation"]
    with pytest.raises(UnknownEvaluationError, match="finished generations"):
        replay(killed, later)
    assert replay(killed, "best").row["generation"] < 2


def test_a_copied_run_folder_replays_without_its_original(coevolution, tmp_path: Path) -> None:
    run_dir, _ = coevolution
    copy = tmp_path / "elsewhere" / "copy"
    shutil.copytree(run_dir, copy)
    away = run_dir.with_name(run_dir.name + "-away")
    run_dir.rename(away)  # nothing may still point at the original folder
    try:
        assert str(run_dir) not in (copy / "run.json").read_text()
        replayed = replay(copy, _pick(copy)["arbitrary"])
        assert replayed.identical
    finally:
        away.rename(run_dir)


@pytest.mark.parametrize(
    ("registered", "said"),
    [
        (None, "is not installed here"),
        ("ariel.no_such_module:Controller", "is installed here but does not load"),
    ],
)
def test_a_missing_or_broken_plugin_is_one_line_naming_it(
    coevolution, tmp_path: Path, registered: str | None, said: str
) -> None:
    from ariel.errors import MissingPluginError, PluginLoadError
    from ariel.plugins import controllers

    run_dir, _ = coevolution
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["brain"]["controller"] = "plugin_under_test"
    (copy / "run.json").write_text(json.dumps(info))
    if registered is not None:
        controllers.register("plugin_under_test", registered)
    try:
        with pytest.raises(
            MissingPluginError, match=rf"'plugin_under_test' \(brain.controller\) {said}"
        ) as caught:
            replay(copy, "best")
        assert "\n" not in str(caught.value)
    finally:
        if registered is not None:
            with pytest.raises(PluginLoadError):  # removed, then imported to be returned
                controllers.unregister("plugin_under_test")


def test_full_rate_frames_pass_through_the_recorded_ones(coevolution) -> None:
    run_dir, _ = coevolution
    replayed = replay(run_dir, "best")
    dense, sparse = replayed.full_rate(), replayed.result
    model = replayed.model
    nstep = round(replayed.task.duration / model.opt.timestep)
    assert replayed.task.record_every > 1 and len(dense.time) == nstep + 1
    index = np.round(sparse.time / model.opt.timestep).astype(int)
    np.testing.assert_array_equal(dense.core_pos[index], sparse.core_pos)
    np.testing.assert_array_equal(dense.joint_angle[index], sparse.joint_angle)
    assert dense.body_pos.shape == (nstep + 1, len(dense.body_names), 3)
    # xy_displacement looks at the first and last frame only: the same at any rate.
    assert _bits(dense.fitness) == _bits(replayed.stored_fitness)
    assert replayed.controls().shape == (nstep, model.nu)


def test_fitness_of_all_frames_is_reproduced_at_the_runs_own_rate(tmp_path: Path) -> None:
    config = {
        **CONFIG,
        "generations": 1,
        "body": {**CONFIG["body"], "population": 1},
        "task": {"duration": 0.5, "fitness": "turning_in_place"},
    }
    run_dir, _ = _make_run(config, tmp_path / "turning")
    replayed = replay(run_dir, "best")
    assert replayed.identical
    # This fitness sums over every frame: at full rate it is another number, which is why the
    # stored fitness is reproduced from the run's own record rate.
    assert replayed.full_rate().fitness != replayed.stored_fitness


def test_the_replay_controls_drive_a_plain_simulation_to_the_same_state(coevolution) -> None:
    """What the video renderer steps (mj_step + the control callback) is the replay itself."""
    run_dir, _ = coevolution
    replayed = replay(run_dir, _pick(run_dir)["arbitrary"])
    model, dense = replayed.model, replayed.full_rate()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    with replayed.driven(model):
        assert mujoco.get_mjcb_control() is not None
        mujoco.mj_step(model, data, nstep=replayed.controls().shape[0])
    assert mujoco.get_mjcb_control() is None
    angles = data.qpos[model.jnt_qposadr[model.actuator_trnid[:, 0]]]
    np.testing.assert_array_equal(angles, dense.joint_angle[-1])


def test_a_replay_writes_a_rerun_recording(coevolution, tmp_path: Path) -> None:
    pytest.importorskip("ariel.recording.rerun._rerun", reason="Rerun recordings not in this tree")
    run_dir, _ = coevolution
    replayed = replay(run_dir, "best")
    path = replayed.write_rrd(tmp_path / "sub" / "best.rrd")
    assert path == tmp_path / "sub" / "best.rrd"
    assert path.read_bytes()[:4] == b"RRF2"  # Rerun's file magic
    assert path.stat().st_size > 10_000
    props = replayed.properties()
    assert props["fitness"] == props["replayed_fitness"] and props["identical"] is True


def test_the_viewer_needs_a_display(coevolution, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    run_dir, _ = coevolution
    with pytest.raises(RuntimeError, match="no display"):
        replay(run_dir, "best").view()


@pytest.fixture
def gl_available() -> None:
    from ariel.utils._gl import create_renderer

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    try:
        create_renderer(model, 16, 16).close()
    except RuntimeError as exc:
        pytest.skip(str(exc))


@pytest.mark.usefixtures("gl_available")
def test_a_replay_writes_a_video_of_the_evaluation(coevolution, tmp_path: Path) -> None:
    import imageio_ffmpeg

    run_dir, _ = coevolution
    replayed = replay(run_dir, "best")
    path = replayed.write_video(tmp_path / "best.mp4", width=160, height=120, fps=20)
    assert path == tmp_path / "best.mp4" and path.is_file()
    assert [p.name for p in tmp_path.iterdir()] == ["best.mp4"]  # no stamped leftovers
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    frames = [np.frombuffer(b, np.uint8).reshape(120, 160, 3) for b in reader]
    assert meta["size"] == (160, 120)
    assert len(frames) == round(replayed.task.duration * 20)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.5  # it moves


def test_an_error_row_has_no_body_to_show(coevolution, tmp_path: Path) -> None:
    """A body the genotype cannot build: replay gives the same error and worst fitness."""
    run_dir, _ = coevolution
    copy = tmp_path / "broken"
    shutil.copytree(run_dir, copy)
    path = copy / "evaluations" / "gen-000000.parquet"
    table = pq.read_table(path)
    genotypes = table.column("body_genotype").to_pylist()
    genotypes[0] = json.dumps([[1.0]])  # not an NDE genotype: decoding fails
    fitness = table.column("fitness").to_pylist()
    fitness[0] = -np.inf
    status = table.column("status").to_pylist()
    status[0] = "error"
    for name, values in (("body_genotype", genotypes), ("fitness", fitness), ("status", status)):
        index = table.schema.get_field_index(name)
        table = table.set_column(index, name, pa.array(values, table.schema.field(name).type))
    pq.write_table(table, path)
    from ariel.recording.store._manifest import write_manifest

    write_manifest(copy, 0)  # a deliberate edit, not damage: its manifest follows it
    replayed = replay(copy, table.column("eval_id")[0].as_py())
    assert replayed.status == "error" and replayed.identical
    with pytest.raises(ValueError, match="no body to show"):
        replayed.write_video(tmp_path / "x.mp4")


def test_the_viewer_plays_the_evaluated_motion(
    coevolution, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No display here: a stand-in for MuJoCo's passive viewer records what it is shown."""
    import mujoco.viewer

    import ariel.recording.resim._replay_window as window_module

    shown: list[np.ndarray] = []

    class FakeViewer:
        def __init__(self, model, data) -> None:
            self.data = data

        def __enter__(self):
            return self

        def __exit__(self, *exc) -> None:
            return None

        def is_running(self) -> bool:
            return True

        def sync(self) -> None:
            shown.append(self.data.qpos.copy())

    monkeypatch.setattr(window_module, "has_display", lambda: True)
    monkeypatch.setattr(mujoco.viewer, "launch_passive", FakeViewer)
    monkeypatch.setattr(window_module.time, "sleep", lambda seconds: None)
    run_dir, _ = coevolution
    replayed = replay(run_dir, "best")
    replayed.view(loop=False)
    model, dense = replayed.model, replayed.full_rate()
    assert len(shown) == replayed.controls().shape[0]
    joints = model.jnt_qposadr[model.actuator_trnid[:, 0]]
    np.testing.assert_array_equal(shown[-1][joints], dense.joint_angle[-1])
