"""The ``ariel`` command."""

from __future__ import annotations

import io
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from _helpers import REPO, ariel_run, exit_code, one_error_line, repo_env, snapshot, tiny_run_toml

from ariel import __version__
from ariel.cli import main


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"ariel {__version__}"


def test_plugins_lists_every_kind_with_its_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plugins"]) == 0
    lines = dict(line.split(": ", 1) for line in capsys.readouterr().out.strip().splitlines())
    kinds = {"body_encoder", "world", "controller", "fitness", "body_optimizer", "brain_optimizer"}
    assert set(lines) == kinds | {"executor"}  # --executor's kinds, listed nowhere before
    assert "na_cpg" in lines["controller"] and "flat" in lines["world"]
    assert "map_elites" in lines["body_optimizer"]
    assert lines["executor"] == "serial, local, dask, gpu"


def test_unknown_command_exits_with_usage(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["fly"])
    assert info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# ariel run / resume / runs: the happy path and bad input
# --------------------------------------------------------------------------------------------

TINY_TOML = tiny_run_toml("clitiny", 2, record=None)


@pytest.fixture(scope="module")
def tiny_toml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("config") / "tiny.toml"
    path.write_text(TINY_TOML)
    return path


@pytest.fixture(scope="module")
def finished_run(tiny_toml: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A finished run made by ``ariel run``, and what the command printed."""
    out = tmp_path_factory.mktemp("runs") / "finished"
    return out, ariel_run(tiny_toml, out)


def test_run_prints_the_folder_the_best_fitness_and_how_to_look(finished_run) -> None:
    from ariel.recording import load_run

    out, printed = finished_run
    run = load_run(out)
    assert run.info["status"] == "finished"
    summary = next(line for line in printed.splitlines() if line.startswith("finished: "))
    best = float(re.search(r"best fitness (\S+) ", summary).group(1))  # type: ignore[union-attr]
    assert best == pytest.approx(run.info["best_fitness"], rel=1e-5)
    assert best == pytest.approx(run.bodies["fitness"].max(), rel=1e-5)
    assert f"{len(run.evaluations)} evaluations" in summary
    assert f"run folder: {out}" in printed.splitlines()
    assert f"ariel runs {out.parent}" in printed
    assert f'load_run("{out}")' in printed
    assert f"ariel view {out} " in printed  # it has recordings (record.rerun is on)


def test_how_to_look_offers_the_viewer_only_with_recordings(tmp_path: Path) -> None:
    from ariel.cli import _how_to_look

    assert "ariel view" not in _how_to_look(tmp_path)  # record.rerun = false: none
    (tmp_path / "run.rrd").write_bytes(b"")
    assert f"ariel view {tmp_path} " in _how_to_look(tmp_path)
    assert "trajectories; one Parquet" in _how_to_look(tmp_path)  # a GA run's three tables
    (tmp_path / "novelty").mkdir()  # a novelty run's own table is named too
    assert "trajectories, novelty; one Parquet" in _how_to_look(tmp_path)


def test_runs_lists_a_finished_run(finished_run, capsys: pytest.CaptureFixture[str]) -> None:
    out, _ = finished_run
    assert main(["runs", str(out.parent)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:2] == ["run", "status"]
    row = next(line.split() for line in lines[1:] if line.split()[0] == out.name)
    assert row[1:3] == ["finished", "2/2"]
    assert main(["runs", str(out.parent / "nothing-here")]) == 2  # tests/test_first_hour.py


def test_runs_names_a_renamed_run_folder_by_its_folder_too(
    finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before, only the run id was listed: the name of a copied folder, the one a user types
    next, was nowhere."""
    import shutil

    out, _ = finished_run
    shutil.copytree(out, tmp_path / "my-copy", ignore=shutil.ignore_patterns("recordings"))
    assert main(["runs", str(tmp_path)]) == 0
    row = capsys.readouterr().out.splitlines()[1]
    assert row.startswith(f"my-copy (run id {out.name})  finished")


BAD_RUN_INPUT = {
    # unknown plugin names
    "body-encoder": (["--set", "body.encoder=nope"], "body.encoder: unknown body encoder"),
    "controller": (["--set", "brain.controller=nope"], "brain.controller: unknown controller"),
    "world": (["--set", "world.name=nope"], "world.name: unknown world"),
    "fitness": (["--set", "task.fitness=nope"], "task.fitness: unknown fitness function"),
    "plugin-option": (["--set", "body.options.number_of_modulez=3"], "body.options"),
    # unknown or mistyped keys and values via --set
    "set-unknown-key": (["--set", "brain.nope=1"], "--set brain.nope: no such key"),
    "set-mistyped-key": (["--set", "generation=3"], "--set generation: no such key"),
    "set-value-as-table": (["--set", "seed.x=3"], "'seed' is a value, not a table"),
    "set-without-equals": (["--set", "brain.popsize"], "expected key=value"),
    "set-bad-type": (["--set", "generations=many"], "generations: must be a valid integer"),
    # budgets that are zero or negative
    "generations=0": (["--set", "generations=0"], "generations: must be greater than or equal"),
    "population=0": (["--set", "body.population=0"], "body.population: must be greater"),
    "popsize=0": (["--set", "brain.popsize=0"], "brain.popsize: must be greater"),
    "popsize=1": (["--set", "brain.popsize=1"], "brain.popsize: must be greater"),
    "iterations=0": (["--set", "brain.iterations=0"], "brain.iterations: must be greater"),
    "duration=-1": (["--set", "task.duration=-1"], "task.duration: must be greater than 0"),
    "duration=nan": (["--set", "task.duration=nan"], "task.duration"),
    # executor options
    "workers=0": (["--workers", "0"], "--workers: must be an integer >= 1"),
    "serial-workers": (["--executor", "serial", "--workers", "2"], "executor.workers"),
    "unknown-executor": (["--executor", "gpu9"], "executor.kind: unknown executor 'gpu9'"),
}


@pytest.mark.parametrize(("extra", "message"), BAD_RUN_INPUT.values(), ids=BAD_RUN_INPUT)
def test_bad_run_input_is_one_line_exit_2_and_writes_nothing(
    tiny_toml: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    out = tmp_path / "never"
    assert exit_code(["run", str(tiny_toml), "--out", str(out), "--quiet", *extra]) == 2
    assert message in one_error_line(capsys, subcommand=True)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []


BAD_TOML = {
    "unknown-key": ("generation = 3\n", "unknown key 'generation'"),
    "unknown-section": ("[brian]\npopsize = 3\n", "unknown key 'brian'"),
    "unknown-nested-key": ("[brain]\npopsise = 3\n", "unknown key 'brain.popsise'"),
    "mistyped-value": ('[brain]\npopsize = "many"\n', "brain.popsize: must be a valid integer"),
    "zero-budget": ("generations = 0\n", "generations: must be greater than or equal to 1"),
    "malformed": ("[brain\npopsize = 3\n", "malformed TOML"),
    "not-utf8": (b"name = '\xff\xfe'\n", "not a UTF-8 text file"),
}


@pytest.mark.parametrize(("text", "message"), BAD_TOML.values(), ids=BAD_TOML)
def test_a_bad_config_file_is_one_line_exit_2_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str | bytes, message: str
) -> None:
    config = tmp_path / "bad.toml"
    if isinstance(text, bytes):
        config.write_bytes(text)
    else:
        config.write_text(text)
    out = tmp_path / "never"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    assert message in one_error_line(capsys, subcommand=True)
    assert not out.exists()


def test_a_missing_config_file_is_one_line_exit_2(tmp_path: Path, capsys) -> None:
    out = tmp_path / "never"
    assert main(["run", str(tmp_path / "nope.toml"), "--out", str(out)]) == 2
    assert "nope.toml' not found" in one_error_line(capsys, subcommand=True)
    assert not out.exists()


def test_an_existing_output_folder_is_left_alone(
    tiny_toml: Path, finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    run_dir, _ = finished_run
    said = {
        mine: "already exists; choose another --out (it is not an ariel run folder",
        run_dir: "already exists; pass --overwrite (from Python: overwrite=True) to replace it, "
        "or choose another --out",
    }
    for folder in (mine, run_dir):
        before = snapshot(folder)
        assert main(["run", str(tiny_toml), "--out", str(folder), "--quiet"]) == 2
        assert said[folder] in one_error_line(capsys, subcommand=True)
        assert snapshot(folder) == before
    # --overwrite replaces runs only, never another folder.
    assert main(["run", str(tiny_toml), "--out", str(mine), "--overwrite", "--quiet"]) == 2
    assert "not an ariel run folder" in one_error_line(capsys, subcommand=True)
    assert (mine / "notes.txt").read_text() == "keep me"


@pytest.fixture
def interrupted_run(
    tiny_toml: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> Path:
    """A run stopped by Ctrl-C after its first generation (exit 130, how to resume)."""
    from ariel.evolution._progress import Progress

    def interrupt(self: Progress, generation: int, *args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    out = tmp_path / "interrupted"
    with monkeypatch.context() as patch:
        patch.setattr(Progress, "end_generation", interrupt)
        assert main(["run", str(tiny_toml), "--out", str(out), "--quiet"]) == 130
    # the environment's ariel, e.g. .venv/bin/ariel: tests/test_first_hour.py
    assert re.search(
        rf"continue it with: \S*ariel resume {re.escape(str(out))}$", capsys.readouterr().err, re.M
    )
    return out


@pytest.mark.parametrize("out", [None, "my runs/it's"], ids=["default-folder", "quoted-out"])
def test_ctrl_c_prints_a_resume_line_that_works_pasted(
    out: str | None,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Without --out the line names the run's real folder (data/runs/<run-id>), never a
    placeholder; a folder that needs quoting is quoted."""
    from ariel.evolution._progress import Progress

    def interrupt(self: Progress, generation: int, *args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    Path("tiny.toml").write_text(tiny_run_toml("hint", 1))
    with monkeypatch.context() as patch:
        patch.setattr(Progress, "end_generation", interrupt)
        assert main(["run", "tiny.toml", "--quiet", *(["--out", out] if out else [])]) == 130
    line = capsys.readouterr().err.strip().splitlines()[-1]
    words = shlex.split(line.split("; continue it with: ", 1)[1])  # as a POSIX shell would
    at = words.index("resume")
    assert Path(words[at - 1]).name in {"ariel", "ariel.cli"}, line  # e.g. .venv/bin/ariel
    (made,) = [Path(out)] if out else list(Path("data/runs").iterdir())
    assert words[at + 1 :] == [str(made)], line
    assert json.loads((made / "run.json").read_text())["status"] == "interrupted"
    assert main(words[at:]) == 0  # the pasted command, after its `ariel`
    assert json.loads((made / "run.json").read_text())["status"] == "finished"


def test_resume_refuses_what_it_cannot_resume_and_changes_nothing(
    interrupted_run: Path, finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    finished, _ = finished_run
    info = json.loads((interrupted_run / "run.json").read_text())
    info["config"]["brain"]["popsize"] = 3
    (interrupted_run / "run.json").write_text(json.dumps(info))
    cases = {
        empty: "not an ariel run folder",
        tmp_path / "missing": "not an ariel run folder",
        finished: "already finished",
        interrupted_run: "config was edited",
    }
    for folder, message in cases.items():
        before = snapshot(folder) if folder.exists() else None
        assert main(["resume", str(folder), "--quiet"]) == 2
        assert message in one_error_line(capsys, subcommand=True)
        assert (snapshot(folder) if folder.exists() else None) == before


def test_an_interrupted_run_resumes_from_the_cli(
    interrupted_run: Path, finished_run, capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.recording import load_run

    assert main(["resume", str(interrupted_run), "--quiet"]) == 0
    assert "finished: " in capsys.readouterr().out
    columns = ["eval_id", "fitness"]
    expected = load_run(finished_run[0]).evaluations[columns]
    assert load_run(interrupted_run).evaluations[columns].equals(expected)


@pytest.mark.parametrize(
    ("extra", "message"),
    [(["--workers", "0"], "--workers"), (["--set", "task.fitness=nope"], "task.fitness")],
    ids=["argparse", "config"],
)
def test_bad_input_exit_code_of_the_real_command(
    tiny_toml: Path, tmp_path: Path, extra: list[str], message: str
) -> None:
    out = tmp_path / "never"
    done = subprocess.run(
        [sys.executable, "-m", "ariel.cli", "run", str(tiny_toml), "--out", str(out), *extra],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1 and message in done.stderr, done.stderr
    assert done.stdout == ""
    assert not out.exists()


# --------------------------------------------------------------------------------------------
# ariel replay / report
# --------------------------------------------------------------------------------------------


def _fitness_lines(out: str) -> dict[str, str]:
    """``{"stored": repr, "replayed": repr}`` from what ``ariel replay`` printed."""
    found = {}
    for line in out.splitlines():
        match = re.fullmatch(r"(stored|replayed) fitness: +(\S+) \((\w+)\)", line)
        if match:
            found[match.group(1)] = match.group(2)
    return found


def test_replay_prints_both_fitnesses_in_full_precision(
    finished_run, capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.recording import load_run

    out, _ = finished_run
    evals = load_run(out).evaluations.set_index("eval_id")
    later = evals[evals["generation"] == 1].index[-1]
    for eval_id in ("best", later):
        assert main(["replay", str(out), eval_id]) == 0
        printed = capsys.readouterr().out
        shown = _fitness_lines(printed)
        assert shown["stored"] == shown["replayed"]
        replayed_id = printed.split()[1]
        assert shown["stored"] == repr(float(evals.loc[replayed_id, "fitness"]))  # every digit
        assert "identical: yes, bit for bit" in printed
    assert replayed_id == later


def test_replay_of_an_unknown_evaluation_or_folder_is_one_line_exit_2(
    finished_run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    out, _ = finished_run
    assert main(["replay", str(out), "b999999-i000-c000"]) == 2
    line = one_error_line(capsys, subcommand=True)
    assert "no evaluation 'b999999-i000-c000'" in line and "load_run" in line
    assert main(["replay", str(tmp_path), "best"]) == 2
    assert "not an ariel run folder" in one_error_line(capsys, subcommand=True)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["replay", str(out), "best", "--viewer"]) == 2
    assert "--viewer needs a display" in one_error_line(capsys, subcommand=True)
    assert exit_code(["replay", str(out)]) == 2  # EVAL_ID is required
    assert "EVAL_ID" in one_error_line(capsys, subcommand=True)


def test_replay_exits_1_when_the_stored_fitness_is_not_reproduced(
    finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    import mujoco
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    out, _ = finished_run
    copy = tmp_path / "tampered"
    shutil.copytree(out, copy)
    path = copy / "evaluations" / "gen-000000.parquet"
    table = pq.read_table(path)
    fitness = table.column("fitness").to_pylist()
    fitness[0] = float(np.nextafter(fitness[0], np.inf))  # one ulp away
    index = table.schema.get_field_index("fitness")
    table = table.set_column(index, "fitness", pa.array(fitness, pa.float64()))
    pq.write_table(table, path)
    from ariel.recording.store._manifest import write_manifest

    write_manifest(copy, 0)  # a deliberate edit, not damage: its manifest follows it
    info = json.loads((copy / "run.json").read_text())
    info["versions"]["mujoco"] = "3.0.0"  # as if the run had been made with another MuJoCo
    for segment in info["segments"]:
        segment["versions"]["mujoco"] = "3.0.0"
    (copy / "run.json").write_text(json.dumps(info))
    assert main(["replay", str(copy), table.column("eval_id")[0].as_py()]) == 1
    printed = capsys.readouterr().out
    shown = _fitness_lines(printed)
    assert shown["stored"] == repr(fitness[0]) != shown["replayed"]
    assert "identical: NO" in printed
    assert f"  mujoco: the run used 3.0.0, this replay {mujoco.__version__}" in printed


def test_replay_writes_a_recording_and_a_video(
    finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("ariel.recording.rerun._rerun", reason="Rerun recordings not in this tree")
    import mujoco

    from ariel.utils._gl import create_renderer

    try:
        create_renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 16, 16).close()
    except RuntimeError as exc:
        pytest.skip(str(exc))
    out, _ = finished_run
    rrd, video = tmp_path / "best.rrd", tmp_path / "clips" / "best.mp4"
    argv = ["replay", str(out), "best", "--rrd", str(rrd), "--video", str(video)]
    assert main(argv) == 0
    printed = capsys.readouterr().out.splitlines()
    assert f"wrote {rrd}" in printed and f"wrote {video}" in printed
    assert any(line.startswith("full rate (every physics step, ") for line in printed)
    assert rrd.read_bytes()[:4] == b"RRF2"
    assert video.stat().st_size > 1000
    assert main(["replay", str(out), "best", "--rrd", str(rrd)]) == 0  # not without a word
    assert f"wrote {rrd} (it replaced the file that was there)" in capsys.readouterr().out


def test_report_prints_every_generation_and_the_files_it_wrote(
    finished_run, capsys: pytest.CaptureFixture[str]
) -> None:
    out, _ = finished_run
    assert main(["report", str(out), "--no-render"]) == 0
    printed = capsys.readouterr().out
    lines = printed.splitlines()
    header = next(
        i for i, line in enumerate(lines) if line.split()[:2] == ["generation", "evaluations"]
    )
    assert [line.split()[0] for line in lines[header + 2 : header + 4]] == ["0", "1"]
    for name in ("fitness", "morphology", "trajectory", "joints"):
        path = out / "report" / f"{name}.png"
        assert f"wrote {path}" in lines and path.is_file()
    # Said first, each file as it is written (a long report was silent until its end).
    assert lines[0] == f"drawing the report of {out} (2 generations)"
    assert lines[1].startswith("wrote ")
    assert lines.index(f"wrote {out / 'report' / 'fitness.png'}") < header
    assert "best_body.png: left out (rendering off)" in lines


def test_report_of_a_folder_that_is_not_a_run_is_one_line_exit_2(tmp_path: Path, capsys) -> None:
    assert main(["report", str(tmp_path)]) == 2
    assert "not an ariel run folder" in one_error_line(capsys, subcommand=True)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------
# Headless: MUJOCO_GL only where a command renders; a GL backend that cannot load is one line
# --------------------------------------------------------------------------------------------

#: A ``sitecustomize`` that makes loading any library named *EGL* fail, as on a machine
#: without libEGL. With PyOpenGL installed, ``import mujoco`` under ``MUJOCO_GL=egl`` then
#: raises AttributeError (PyOpenGL's EGL platform has no library); without PyOpenGL, MuJoCo's
#: EGL backend fails when a renderer is made.
NO_EGL_SITECUSTOMIZE = """
import ctypes

_load = ctypes.CDLL.__init__


def _no_egl(self, name, *args, **kwargs):
    if name and "EGL" in str(name):
        raise OSError(f"{name}: cannot open shared object file: No such file or directory")
    _load(self, name, *args, **kwargs)


ctypes.CDLL.__init__ = _no_egl
"""


def _headless_env(tmp_path: Path, *, no_egl: bool = False, **extra: str) -> dict[str, str]:
    """This environment without a display or a GL choice (``extra`` added); ``no_egl``: and
    with libEGL unloadable."""
    drop = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")
    env = {k: v for k, v in repo_env().items() if k not in drop}
    if no_egl:
        shim = tmp_path / "no_egl"
        shim.mkdir()
        (shim / "sitecustomize.py").write_text(NO_EGL_SITECUSTOMIZE)
        env["PYTHONPATH"] = os.pathsep.join([str(shim), env["PYTHONPATH"]])
    return {**env, **extra}


def _ariel_in(
    folder: Path, env: dict[str, str], argv: list[str]
) -> subprocess.CompletedProcess[str]:
    """``ariel argv`` in a child process in ``folder`` with ``env``."""
    return subprocess.run(
        [sys.executable, "-m", "ariel.cli", *argv],
        capture_output=True,
        text=True,
        timeout=180,
        env=env,
        cwd=folder,
    )


def test_replay_and_report_that_render_nothing_choose_no_gl_backend(
    finished_run, tmp_path: Path
) -> None:
    out = str(finished_run[0])
    script = (
        "import os, sys\n"
        "from ariel.cli import main\n"
        f"codes = [main(['replay', {out!r}, 'best']), main(['report', {out!r}, '--no-render'])]\n"
        "print(codes, os.environ.get('MUJOCO_GL', '<unset>'), 'mujoco' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=180,
        env=_headless_env(tmp_path),
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "[0, 0] <unset> True"  # mujoco ran, no GL chosen


@pytest.mark.skipif(sys.platform != "linux", reason="MUJOCO_GL=egl is a Linux backend")
@pytest.mark.parametrize(
    ("video", "user_gl", "hint"),
    [(False, "", None), (True, "", "or run without --video"), (False, "egl", "unset MUJOCO_GL")],
    ids=["replay", "replay-video", "replay-user-egl"],
)
def test_a_gl_backend_that_cannot_load_is_one_line_exit_2(
    finished_run, tmp_path: Path, video: bool, user_gl: str, hint: str | None
) -> None:
    import importlib.util

    if user_gl and importlib.util.find_spec("OpenGL") is None:
        pytest.skip("without PyOpenGL, import mujoco loads no EGL library: nothing to fail")
    argv = ["replay", str(finished_run[0]), "best"]
    argv += ["--video", str(tmp_path / "best.mp4")] if video else []
    env = _headless_env(tmp_path, no_egl=True, **({"MUJOCO_GL": user_gl} if user_gl else {}))
    done = _ariel_in(tmp_path, env, argv)
    if hint is None:  # nothing rendered: no GL library loaded, nothing fails
        assert done.returncode == 0, done.stderr
        assert "identical: yes, bit for bit" in done.stdout
        return
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert lines[0].startswith("ariel: error: no OpenGL backend available"), lines[0]
    assert "(MUJOCO_GL=egl)" in lines[0] and "libegl1" in lines[0] and hint in lines[0]
    assert not (tmp_path / "best.mp4").exists()


def test_a_mujoco_gl_typo_is_said_as_one_not_blamed_on_a_plugin(
    finished_run, tmp_path: Path
) -> None:
    """`MUJOCO_GL=garbage` made `run` say "could not load controller 'na_cpg'" and `report`
    "could not load world 'flat'": the plugin's import had failed in `import mujoco`."""
    env = _headless_env(tmp_path, MUJOCO_GL="garbage")
    for argv in (["run", "--out", "r", "--quiet"], ["report", str(finished_run[0])]):
        done = _ariel_in(tmp_path, env, argv)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert done.returncode == 2 and len(lines) == 1, done.stderr
        assert "MUJOCO_GL='garbage' is not an OpenGL backend MuJoCo knows" in lines[0]
    assert not (tmp_path / "r").exists()


def test_a_folder_named_like_an_option_is_pasteable_in_the_hints() -> None:
    """`ariel run --out=-y` printed `ariel report -y`, which argparse reads as an option."""
    from ariel.cli import _how_to_look
    from ariel.utils import ariel_line

    assert "report ./-y " in _how_to_look(Path("-y"))
    assert ariel_line("resume", Path("--help")).endswith("resume ./--help")
    assert ariel_line("view", Path("r"), "--best", 5).endswith("view r --best 5")


def test_a_reader_that_goes_away_ends_the_command_quietly(
    finished_run,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``ariel plugins | head -1``: a BrokenPipeError traceback before; now exit code 141 (as
    SIGPIPE would end it) and nothing on stderr. Commands printing rich tables (report,
    compare) ended in rich's SystemExit(1), which means damage or no replay elsewhere."""

    class GoneReader(io.StringIO):
        def __init__(self, fd: int) -> None:
            super().__init__()
            self.fd = fd

        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

        def fileno(self) -> int:
            return self.fd  # what the rest of the output is sent to /dev/null through

    with open(tmp_path / "stdout", "w") as file:
        monkeypatch.setattr("sys.stdout", GoneReader(file.fileno()))
        assert main(["plugins"]) == 141
        assert main(["report", str(finished_run[0]), "--no-render"]) == 141
        assert capsys.readouterr().err == ""
        # `ariel run ... | head -1`: the run ended "failed" with no word; it stops as SIGPIPE
        # would, interrupted and resumable, and says so where it still can (stderr).
        run = tmp_path / "run"
        tiny = ["run", str(REPO / "tests/data/run_tiny.toml"), "--set", "generations=2"]
        assert main([*tiny, "--out", str(run)]) == 141
    assert json.loads((run / "run.json").read_text())["status"] == "interrupted"
    assert capsys.readouterr().err.startswith("interrupted (SIGPIPE); continue it with: ")


@pytest.mark.parametrize(
    ("signum", "code", "line"), [(2, 130, "interrupted"), (15, 143, "interrupted (SIGTERM)")]
)
def test_a_command_stopped_by_a_signal_says_so_in_one_line(
    signum: int,
    code: int,
    line: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Ctrl-C or SIGTERM during `ariel report` (export, verify, gallery, ...): a 30- to 80-line
    KeyboardInterrupt traceback before; the figure being written leaves no temporary."""
    import os
    import signal

    import ariel.recording.analysis as analysis
    from ariel.recording.store import atomic_write

    target = tmp_path / "report" / "fitness.png"

    def stopped(*args: object, **kwargs: object) -> None:
        def write(temporary: Path) -> None:
            temporary.write_bytes(b"half")
            os.kill(os.getpid(), signum)  # the signal lands while the file is written

        atomic_write(target, write)

    monkeypatch.setattr(analysis, "make_report", stopped)
    # A shell's background job starts with SIGINT ignored, which `ariel` leaves alone: Ctrl-C
    # as a terminal's foreground command has it.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        assert main(["report", str(tmp_path)]) == code
    finally:
        signal.signal(signal.SIGINT, previous)
    assert capsys.readouterr().err == line + "\n"
    assert list(target.parent.iterdir()) == []  # no temporary left
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the handlers put back


def test_a_new_line_before_interrupted_only_where_a_terminal_echoed_ctrl_c(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``timeout -s INT`` or stderr in a file: "interrupted" came after an empty line, which
    is there only for the ``^C`` a terminal echoes."""
    from ariel.utils import report_interrupted

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    for stream, expected in ((io.StringIO(), "interrupted\n"), (Terminal(), "\ninterrupted\n")):
        monkeypatch.setattr("sys.stderr", stream)
        assert report_interrupted(KeyboardInterrupt(), None) == 130
        assert stream.getvalue() == expected


def test_a_ctrl_c_while_the_commands_load_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The ``ariel`` script's entry point: Ctrl-C in its first second printed an import
    traceback."""
    import types

    class Loading(types.ModuleType):
        def __getattr__(self, name: str) -> object:
            raise KeyboardInterrupt  # as if pressed while `ariel.cli` is being imported

    monkeypatch.setitem(sys.modules, "ariel.cli", Loading("ariel.cli"))
    monkeypatch.delitem(sys.modules, "ariel._console", raising=False)
    import ariel._console

    assert ariel._console.main() == 130
    # No terminal echoed ^C (stderr is captured): the line alone, no empty line before it.
    assert capsys.readouterr().err == "interrupted\n"


def test_numpy_overflow_warnings_of_crafted_values_stay_off_the_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A crafted fitness of 1e308 made `ariel report` print numpy's and matplotlib's
    "overflow encountered" warnings, two lines each, beside its own one-line note."""
    import warnings

    import ariel.recording.analysis as analysis

    def overflowing(*args: object, **kwargs: object) -> None:
        numpy_code = {"__name__": "numpy._core._methods", "warnings": warnings}
        exec("warnings.warn('overflow encountered in reduce', RuntimeWarning)", numpy_code)
        warnings.warn("a warning of ours", UserWarning, stacklevel=1)  # still shown

    monkeypatch.setattr(analysis, "make_report", overflowing)
    monkeypatch.setattr(analysis, "print_report", lambda report, **_: None)
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        assert main(["report", str(tmp_path)]) == 0
    assert [str(w.message) for w in shown] == ["a warning of ours"]


def test_the_software_that_made_a_generation_is_told_apart() -> None:
    """A run made with another MuJoCo (a copy from another machine) went on without a word,
    though its added generations cannot equal an uninterrupted run's (the note itself:
    tests/runs/test_folder_trust.py)."""
    from ariel.recording.store import git_commit, software_versions, version_differences

    here, commit = software_versions(), git_commit()
    segment = {"from_generation": 0, "versions": {**here, "mujoco": "3.0.0"}, "git_commit": commit}
    later = {"from_generation": 2, "versions": dict(here), "git_commit": commit}
    info = {"run_id": "r", "status": "interrupted", "versions": here, "segments": [segment]}
    assert version_differences(info) == {"mujoco": ("3.0.0", here["mujoco"])}
    if commit is not None:  # a checkout: an ariel that recorded no commit is unknown software
        unknown = {**info, "segments": [{**later, "git_commit": None}]}
        assert version_differences(unknown) == {"git_commit": ("not recorded", commit)}
    assert version_differences({**info, "segments": [segment, later]}) == {}  # the last one's
    assert version_differences({**info, "segments": [segment, later]}, 1) != {}  # generation 1


def test_every_command_s_help_has_a_description() -> None:
    """`ariel runs --help` (and resume, plugins, report, ...) showed only usage and options."""
    import argparse

    from ariel.cli import build_parser

    def commands(parser: argparse.ArgumentParser, prefix: str = "") -> dict:
        found = {}
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, command in action.choices.items():
                    found[prefix + name] = command
                    found.update(commands(command, f"{prefix}{name} "))
        return found

    every = commands(build_parser())
    assert {"runs", "resume", "plugins", "campaign status"} <= set(every)
    assert [name for name, command in every.items() if not command.description] == []


def test_a_reader_of_a_running_run_says_it_is_still_running(
    finished_run, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`replay RUN best`, `export RUN best` and `view --screenshot` of a run still going said
    nothing of it: the best so far read as the run's best (probe G1)."""
    import shutil

    from ariel.recording.store import RunFolder, RunLock

    run = Path(shutil.copytree(finished_run[0], tmp_path / "run"))
    RunFolder(run).update_info(status="running")
    with RunLock(run):
        assert main(["replay", str(run), "best"]) == 0
        err = capsys.readouterr().err
        assert f"note: {run} is still running (" in err and "'best' is the best so far" in err
    assert main(["replay", str(run), "best"]) == 0  # its process gone: no such note
    assert "still running" not in capsys.readouterr().err


def test_a_folder_named_like_an_option_gets_a_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ariel verify -x` for a run folder named -x said "the following arguments are
    required: RUN_DIR", though it was given (probe G4)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "-x").mkdir()
    monkeypatch.setattr("sys.argv", ["ariel", "verify", "-x"])
    assert exit_code(["verify", "-x"]) == 2
    assert "'-x' was read as an option: write ./-x for the file or folder" in (
        capsys.readouterr().err
    )


def test_a_run_s_folder_lines_are_escaped_for_the_terminal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A parent folder named with ESC reached the terminal raw in the "run ...:" and "run
    folder:" lines (ESC[31m turned the terminal red; ESC]0; set its title) (probe G4)."""
    out = tmp_path / "a\x1b[31m" / "run"
    tiny = ["run", str(REPO / "tests/data/run_tiny.toml"), "--set", "generations=1"]
    assert main([*tiny, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "run folder: " in printed and "\x1b" not in printed
