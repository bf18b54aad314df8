"""Bad input that used to pass the checks and crash later (issue 16): one line, exit 2, nothing
written; plugins checked before a run and failing during one; signals; workers that outlive
their driver; a script without a ``__main__`` guard."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from _helpers import ariel_run, exit_code, one_error_line, repo_env, tiny_run_toml

from ariel.cli import main
from ariel.plugins import fitness_function, fitness_functions
from ariel.recording import load_run


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_run_toml("bad", 1))
    return path


# --- 9: every float finite, sizes this machine can hold, strict types ----------------------


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("brain.sigma0=inf", r"^brain.sigma0: must be a finite number"),
        ("task.spawn_position=[nan,0,0]", r"^task.spawn_position.0: must be a finite number"),
        ("task.duration=1e9", r"^task.duration: one generation would need about [\d.]+ GiB"),
        ("body.population=100000", r"^body.population: one generation would need about"),
        ("brain.popsize=1e23", r"^brain.popsize: must be a valid integer \(got 1e\+23, a float"),
        ("brain.popsize=100000000000000000000000", r"^brain.popsize: one generation would"),
        ("generations=true", r"^generations: must be a valid integer \(got True, a boolean"),
        ('generations="3"', r"^generations: must be a valid integer \(got '3', a string"),
        ("record.rerun=1", r"^record.rerun: must be a valid boolean"),
    ],
)
def test_bad_values_are_one_line_and_write_nothing(
    tiny: Path, tmp_path: Path, override: str, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    import re

    out = tmp_path / "out"
    assert exit_code(["run", str(tiny), "--out", str(out), "--quiet", "--set", override]) == 2
    line = one_error_line(capsys).removeprefix("ariel: error: ")
    assert re.search(expected, line), line
    assert not out.exists()


def test_a_control_period_longer_than_the_run_allocates_nothing_big(
    tiny: Path, tmp_path: Path
) -> None:
    """``brain.control_period=1e9`` once tried to hold 1e9 controls per call: now the one
    controller call holds for the whole run, as the tutorial's Controller would."""
    out = tmp_path / "out"
    ariel_run(tiny, out, "--set", "brain.control_period=1000000000")
    assert set(load_run(out).evaluations["status"]) == {"ok"}


# --- 10, 7: a fitness function returning NaN or infinity ------------------------------------


@pytest.fixture
def fitness_plugin():
    """Register fitness functions for one test: ``add(name, fn)``."""
    added: list[str] = []

    def add(name: str, fn: Any) -> None:
        fitness_functions.register(name, fitness_function(maximise=True)(fn))
        added.append(name)

    yield add
    for name in added:
        fitness_functions.unregister(name)


def test_a_nan_fitness_is_invalid_with_its_value_and_run_json_stays_json(
    tiny: Path, tmp_path: Path, fitness_plugin: Any
) -> None:
    def late_nan(record: Any) -> float:
        # Finite for the plugin check's 0.5 s, NaN or inf in this run's 0.6 s.
        if record.time[-1] < 0.55:
            return 1.0
        return math.nan if record.joint_angle.size % 2 == 0 else math.inf

    fitness_plugin("test_late_nan", late_nan)
    out = tmp_path / "out"
    printed = ariel_run(
        tiny, out, "--set", "task.fitness=test_late_nan", "--set", "task.duration=0.6"
    )
    # No best: said, and no `replay RUN best` hint that cannot work when pasted.
    assert ": no evaluation succeeded (the evaluations table's status and error say why)" in printed
    assert " best " not in printed.replace("# ", "") and "replay" not in printed, printed
    from ariel.recording import replay
    from ariel.recording.resim import UnknownEvaluationError

    with pytest.raises(
        UnknownEvaluationError, match="has a finite fitness, so none is 'best'; give an"
    ):
        replay(out, "best")
    run = load_run(out)
    evaluations = run.evaluations
    assert set(evaluations["status"]) == {"invalid"}
    assert evaluations["error"].str.contains(r"returned (?:nan|inf), not a finite number").all()
    assert run.generations["invalid"].sum() == len(evaluations)

    def refuse(token: str) -> None:
        raise AssertionError(f"not JSON: {token}")

    info = json.loads((out / "run.json").read_text(), parse_constant=refuse)
    assert info["best_fitness"] is None


# --- 11: plugins checked before anything is written; a failure during a run -------------------


def test_a_plugin_that_fails_its_check_stops_the_run_before_it_starts(
    tiny: Path, tmp_path: Path, fitness_plugin: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    fitness_plugin("test_always_nan", lambda record: math.nan)
    out = tmp_path / "out"
    argv = ["run", str(tiny), "--out", str(out), "--quiet", "--set", "task.fitness=test_always_nan"]
    assert exit_code(argv) == 2
    line = one_error_line(capsys)
    assert "task.fitness: the plugin check failed: fitness function 'test_always_nan'" in line
    assert not out.exists()


def test_a_plugin_failing_during_a_run_stops_it_in_one_line_resumable(
    tiny: Path, tmp_path: Path, fitness_plugin: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = {"on": True}

    def fails_late(record: Any) -> float:
        if broken["on"] and record.time[-1] > 0.55:
            raise ZeroDivisionError("the plugin's own bug")
        return float(record.core_pos[-1, 0])

    fitness_plugin("test_fails_late", fails_late)
    out = tmp_path / "out"
    argv = ["run", str(tiny), "--out", str(out), "--quiet"]
    argv += ["--set", "task.fitness=test_fails_late", "--set", "task.duration=0.6"]
    assert exit_code(argv) == 2
    line = one_error_line(capsys)
    assert re.search(
        r"fitness function 'test_fails_late' failed in evaluation b\d{6}-i000-c\d{3}", line
    )
    assert "ZeroDivisionError: the plugin's own bug" in line and "error.log" in line
    # registered by this module, not ariel's nor an entry point: `ariel resume` would not
    # know it, so the hint names the script's way (pasted, the CLI line failed: unknown plugin)
    assert line.endswith(
        f"fix the plugin, then resume_experiment({str(out)!r}) in the script that registers "
        "its fitness function 'test_fails_late' (the ariel command does not know it)"
    ), line
    assert "Traceback" in (out / "error.log").read_text()
    assert json.loads((out / "run.json").read_text())["status"] == "failed"
    plugin = fitness_functions.unregister("test_fails_late")  # as in a new `ariel resume`
    assert exit_code(["resume", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert "fitness function 'test_fails_late'" in line and "registered by the script" in line
    assert f"resume_experiment({str(out)!r})" in line

    # Another function under the name (a notebook cell edited and run again): refused, the
    # run went on with it before; and the same function made to minimise.
    @fitness_function(maximise=True)
    def another(record: Any) -> float:
        return 0.0

    fitness_functions.register("test_fails_late", another)
    assert exit_code(["resume", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert line.startswith("ariel: error: fitness function 'test_fails_late' is '"), line
    assert "another' here, but run" in line and "resuming would mix two plugins" in line, line
    plugin.maximise = False
    fitness_functions.register("test_fails_late", plugin, replace=True)
    assert exit_code(["resume", str(out), "--quiet"]) == 2
    assert "is minimised here, but run" in one_error_line(capsys)
    plugin.maximise = True
    fitness_functions.register("test_fails_late", plugin, replace=True)
    broken["on"] = False  # the plugin fixed
    assert main(["resume", str(out), "--quiet"]) == 0
    assert load_run(out).info["status"] == "finished"


# --- 12: signals, config paths that are not files, a long EVAL_ID ---------------------------


# SIGHUP takes the same path as SIGTERM; its variant runs with the soak tests (~10 s each).
@pytest.mark.parametrize(
    "signum", [signal.SIGTERM, pytest.param(signal.SIGHUP, marks=pytest.mark.soak)]
)
def test_sigterm_and_sighup_stop_a_run_like_ctrl_c(
    tmp_path: Path, signum: int, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "long.toml"
    config.write_text(tiny_run_toml("long", 1, generations=200))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "ariel.cli", "run", str(config), "--out", str(out), "--quiet"]
    process = subprocess.Popen(
        command, env=repo_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        run_json = out / "run.json"
        if run_json.is_file() and json.loads(run_json.read_text()).get("generations_done", 0):
            break
        time.sleep(0.1)
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines  # the environment's ariel, e.g. .venv/bin/ariel
    name = signal.Signals(signum).name
    assert re.fullmatch(
        rf"interrupted \({name}\); continue it with: \S*ariel resume {re.escape(str(out))}",
        lines[0],
    ), lines[0]
    assert json.loads((out / "run.json").read_text())["status"] == "interrupted"
    assert not (out / ".lock").exists()


def test_a_config_path_that_is_no_file_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    for path, what in (
        (tmp_path, "is a folder"),
        ("/dev/null", "character device"),
        (fifo, "FIFO"),
    ):
        assert exit_code(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
        assert what in one_error_line(capsys)


def test_a_300_character_eval_id_is_one_line_in_view(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    ariel_run(tiny, out, "--set", "record.rerun=true")
    assert exit_code(["view", str(out), "b" * 300]) == 2
    assert "300 characters" in one_error_line(capsys)


# --- 13: a script without a __main__ guard --------------------------------------------------


@pytest.mark.parametrize(
    "out",
    [pytest.param("run", marks=pytest.mark.soak), None],  # ~12 s each: one in `make test`
    ids=["out", "default-folder"],
)
def test_a_script_without_a_main_guard_stops_in_one_line_per_worker(
    tmp_path: Path, out: str | None
) -> None:
    script = tmp_path / "noguard.py"
    script.write_text(
        "from ariel.evolution import run_experiment\n"
        f"run_experiment(None, out={out!r}, executor='local', workers=2, overrides=["
        '"generations=1", "body.population=2", "body.offspring=2", "brain.popsize=2", '
        '"brain.iterations=1", "task.duration=0.3", "record.rerun=false"])\n'
    )
    result = subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path,
        env=repo_env(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2
    lines = result.stderr.splitlines()
    assert 1 <= len(lines) <= 2 and "Traceback" not in result.stderr, result.stderr[-2000:]
    assert all("whose top level calls run_experiment" in line for line in lines), lines
    assert result.stdout == ""  # no terminal: no progress
    assert not list(tmp_path.rglob("run.json"))  # no run folder left, failed or any other
    assert not (tmp_path / "run").exists()


# --- 3: local workers die with their driver -------------------------------------------------

_DRIVER = """
import time
from ariel.evaluation import make_executor

def slow(x):
    time.sleep(120)
    return x

if __name__ == "__main__":
    with make_executor("local", workers=2) as pool:
        futures = [pool.submit(slow, i) for i in range(2)]
        print("submitted", flush=True)
        time.sleep(300)
"""


def _descendants(pid: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            children.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process tree from /proc")
@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM])
def test_local_workers_die_with_their_driver(tmp_path: Path, signum: int) -> None:
    script = tmp_path / "driver.py"
    script.write_text(_DRIVER)
    driver = subprocess.Popen(
        [sys.executable, str(script)], env=repo_env(), stdout=subprocess.PIPE, text=True
    )
    assert driver.stdout is not None and driver.stdout.readline().strip() == "submitted"
    deadline = time.monotonic() + 60
    workers: set[int] = set()
    while len(workers) < 3 and time.monotonic() < deadline:  # the fork server and 2 workers
        time.sleep(0.2)
        workers = _descendants(driver.pid)
    assert len(workers) >= 3
    os.kill(driver.pid, signum)  # the driver alone, not its process group
    driver.wait(timeout=30)
    deadline = time.monotonic() + 5
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = [pid for pid in workers if _alive(pid)]
    for pid in left:  # do not leave them behind when the test fails
        os.kill(pid, signal.SIGKILL)
    assert not left, f"workers outlived their driver: {left}"
