"""A run SIGKILLed at any moment resumes (`ariel resume`) to exactly the uninterrupted records.

Every run here is a real `ariel` process (its whole process group is killed, workers too):
before the first generation finished, after a generation's checkpoint, and while a Parquet
table, the checkpoint or run.json is half written. The "while writing" kills are
deterministic: a test-only launcher wraps `atomic_write` so that, at the chosen write, it
leaves the temporary file half written and waits to be killed. After every kill `load_run`
must still load (finished generations only, equal to the reference's), and after the resume
the records must equal those of an uninterrupted run bit for bit, with no temporary file and
no table file of an unfinished generation left.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _helpers import plain_rows, repo_env

from ariel.evolution import run_experiment
from ariel.recording import load_run
from ariel.recording.store._tables import TABLES as ALL_TABLES

TABLES = tuple(t for t in ALL_TABLES if t not in ("archive", "novelty"))  # not GA tables

REPO = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(
    not hasattr(os, "killpg"), reason="needs POSIX process groups (os.killpg)"
)

# Co-evolution: 3 generations of 2 + 2 bodies, 3 x 2 brain evaluations each. Inherited brains
# (x0 = the parent's best parameters) make the resumed run depend on the checkpointed bodies.
KILL_CONFIG = """
name = "killme"
seed = 11
generations = 3

[body]
options = { number_of_modules = 10 }
population = 2
offspring = 2

[brain]
popsize = 3
iterations = 2
inherit = true

[task]
duration = 0.5

[executor]
kind = "serial"
"""

# Brain-only: the gecko's one CMA-ES run goes on across generations (its state in the
# checkpoint).
BRAIN_CONFIG = """
name = "brainonly"
seed = 4
generations = 3

[body]
encoder = "prebuilt"
genotype = "gecko"

[brain]
popsize = 4
iterations = 2

[task]
duration = 0.5

[executor]
kind = "serial"
"""

# Runs the CLI (argv[4:]) with `atomic_write` wrapped: the first write of a path ending in
# argv[1] after int(argv[2]) finished checkpoint writes is left half written under its
# temporary name; the launcher then touches the marker file and sleeps until killed.
PAUSING_LAUNCHER = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path

    import ariel.recording.store._files as files
    import ariel.recording.rerun._rerun as rerun_files
    import ariel.recording.store._tables as tables

    target, checkpoints_before, marker = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3])
    original = files.atomic_write
    checkpoints = 0

    def atomic_write(path, write, **options):
        global checkpoints
        path = Path(path)
        if path.as_posix().endswith(target) and checkpoints == checkpoints_before:
            def half_written(temporary):
                write(temporary)
                data = temporary.read_bytes()
                temporary.write_bytes(data[: len(data) // 2])
                marker.touch()
                time.sleep(3600)

            original(path, half_written, **options)
        original(path, write, **options)
        if path.as_posix().endswith("checkpoints/state.json"):
            checkpoints += 1

    files.atomic_write = atomic_write
    tables.atomic_write = atomic_write
    rerun_files.atomic_write = atomic_write
    from ariel.cli import main

    sys.exit(main(sys.argv[4:]))
    """
)


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


_STARTED: list[_Process] = []  # killed at teardown if a failing test left one running


class _Process:
    """An `ariel` process in its own session (so the kill reaches its workers too)."""

    def __init__(self, argv: list[str], cwd: Path) -> None:
        _STARTED.append(self)
        self.log = cwd / f"log-{time.monotonic_ns()}.txt"
        with open(self.log, "wb") as log:
            self.popen = subprocess.Popen(
                argv,
                cwd=cwd,
                env=repo_env(),
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def wait_until(self, condition: Callable[[], bool], what: str, timeout: float = 120) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if self.popen.poll() is not None:
                pytest.fail(
                    f"the run ended (exit {self.popen.returncode}) before {what}:\n{self.output()}"
                )
            if time.monotonic() > deadline:
                self.kill()
                pytest.fail(f"timed out waiting for {what}:\n{self.output()}")
            time.sleep(0.005)

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.popen.pid, signal.SIGKILL)
        self.popen.wait(timeout=30)
        _wait_group_gone(self.popen.pid)

    def finish(self, timeout: float = 300) -> int:
        try:
            return self.popen.wait(timeout=timeout)
        finally:
            if self.popen.poll() is None:
                self.kill()


def _wait_group_gone(pgid: int, timeout: float = 30) -> None:
    """Wait until no live process (zombies aside) of the killed group is left."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        alive = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                alive.append(stat.parent.name)
        if not alive:
            return
        time.sleep(0.05)
    pytest.fail(f"processes of the killed group {pgid} still run: {alive}")


@pytest.fixture(autouse=True)
def _no_process_left_running() -> Iterator[None]:
    yield
    while _STARTED:
        process = _STARTED.pop()
        if process.popen.poll() is None:
            process.kill()


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "ariel.cli", *args]


def _kill_while_writing(
    launcher: Path, target: str, checkpoints_before: int, cli: list[str], run_dir: Path
) -> None:
    """Run ``ariel *cli`` on ``run_dir``; kill it while ``target`` is half written (after it
    wrote ``checkpoints_before`` checkpoints), and check the half file is there."""
    tmp_path = run_dir.parent
    marker = tmp_path / f"paused-{time.monotonic_ns()}"
    argv = [sys.executable, str(launcher), target, str(checkpoints_before), str(marker), *cli]
    process = _Process(argv, tmp_path)
    process.wait_until(marker.exists, f"the write of {target}")
    process.kill()
    assert process.popen.returncode == -signal.SIGKILL
    written = run_dir / target
    halves = list(written.parent.glob(f".{written.name}.*.tmp"))
    assert len(halves) == 1, f"{target}: the kill missed the write"
    assert halves[0].stat().st_size > 0, f"{target}: the kill missed the write"


def _stamp(path: Path) -> tuple[int, int] | None:
    """Which version of a file is there (each atomic write is a new inode)."""
    try:
        stat = path.stat()
    except FileNotFoundError:
        return None
    return stat.st_ino, stat.st_mtime_ns


def _first_new_body(reference: Path, generation: int) -> str:
    bodies = load_run(reference).bodies
    born = bodies[(bodies["generation"] == generation) & bodies["is_new"]]
    return str(sorted(born["body_id"])[0])


def _assert_recordings_like(run_dir: Path, reference: Path) -> None:
    """The same recordings as the uninterrupted run, every one readable."""
    import rerun as rr

    def names(folder: Path) -> list[str]:
        return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.rrd"))

    assert names(run_dir) == names(reference)
    for path in run_dir.rglob("*.rrd"):
        (entry,) = rr.chunk.RrdReader(path).recordings()
        shared = path.name == "evaluations.rrd"  # a generation's evaluations
        assert entry.application_id == ("ariel-generation" if shared else "ariel"), path


def _run_info(run_dir: Path) -> dict[str, Any]:
    try:
        return json.loads((run_dir / "run.json").read_text())
    except (OSError, ValueError):
        return {}


# Columns that differ between two runs of one config: the run id (the folder name) and times.
_VARYING = {"run_id", "wall_seconds"}
_SORT = {
    "evaluations": ["eval_id"],
    "bodies": ["generation", "body_id"],
    "trajectories": ["eval_id", "t"],
}


def _records(run_dir: Path, before_generation: int | None = None) -> dict[str, list[tuple]]:
    """Every table of a run (finished generations < ``before_generation``), bit-exact rows."""
    run = load_run(run_dir)
    found = {}
    for table in TABLES:
        frame = getattr(run, table)
        if before_generation is not None:
            frame = frame[frame["generation"] < before_generation]
        columns = [c for c in frame.columns if c not in _VARYING]
        found[table] = plain_rows(frame, columns, _SORT[table])
    return found


def _assert_same_records(run_dir: Path, reference: Path, before: int | None = None) -> None:
    mine, theirs = _records(run_dir, before), _records(reference, before)
    for table in TABLES:
        assert len(mine[table]) == len(theirs[table]), table
        for row, expected in zip(mine[table], theirs[table]):
            assert row == expected, f"{table}: {row[:3]} differs from the uninterrupted run"


def _assert_killed_run_loads(run_dir: Path, reference: Path) -> int:
    """A killed run loads: its finished generations only, equal to the reference's."""
    run = load_run(run_dir)
    done = run.generations_done
    # "created": killed after the folder was made, before the driver marked it running (on a
    # busy machine that window is wide enough for a random kill to land in).
    assert run.info["status"] in ("created", "running")
    for table in TABLES:
        assert set(getattr(run, table)["generation"]) == set(range(done)), table
    assert list(run.generations["generation"]) == list(range(done))
    _assert_same_records(run_dir, reference, before=done)
    return done


def _resume_and_check(run_dir: Path, reference: Path, generations: int = 3, *extra: str) -> None:
    resumed = _Process(_cli("resume", str(run_dir), "--quiet", *extra), run_dir.parent)
    assert resumed.finish() == 0, resumed.output()
    assert "finished" in resumed.output()
    info = _run_info(run_dir)
    assert info["status"] == "finished" and info["generations_done"] == generations
    assert list(run_dir.rglob("*.tmp")) == [], "a temporary file was left behind"
    expected = sorted(f"gen-{g:06d}.parquet" for g in range(generations))
    for table in TABLES:
        assert sorted(os.listdir(run_dir / table)) == expected, table
    _assert_same_records(run_dir, reference)
    _assert_recordings_like(run_dir, reference)


# --------------------------------------------------------------------------------------------
# Fixtures: the config files and the uninterrupted reference runs (in this process)
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def configs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("configs")
    paths = {"coevolve": folder / "kill.toml", "brain": folder / "brain.toml"}
    paths["coevolve"].write_text(KILL_CONFIG)
    paths["brain"].write_text(BRAIN_CONFIG)
    (folder / "pause.py").write_text(PAUSING_LAUNCHER)
    return paths


@pytest.fixture(scope="module")
def reference(configs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "reference"
    result = run_experiment(configs["coevolve"], out=out)
    assert result.status == "finished"
    assert set(load_run(out).evaluations["generation"]) == {0, 1, 2}
    return out


@pytest.fixture(scope="module")
def brain_reference(configs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "brain"
    assert run_experiment(configs["brain"], out=out).status == "finished"
    return out


# --------------------------------------------------------------------------------------------
# Kills at chosen moments
# --------------------------------------------------------------------------------------------


@pytest.mark.soak  # ~20 s; the default suite kills runs in test_lock and test_watch
def test_killed_before_the_first_generation_then_after_a_checkpoint(
    configs, reference, tmp_path: Path
) -> None:
    run_dir = tmp_path / "run"
    process = _Process(
        _cli(
            "run",
            str(configs["coevolve"]),
            "--out",
            str(run_dir),
            "--executor",
            "serial",
            "--quiet",
        ),
        tmp_path,
    )
    process.wait_until(lambda: _run_info(run_dir).get("status") == "running", "the run started")
    process.kill()
    assert process.popen.returncode == -signal.SIGKILL
    assert not (run_dir / "checkpoints" / "state.json").exists()
    assert _assert_killed_run_loads(run_dir, reference) == 0
    assert len(load_run(run_dir).evaluations) == 0
    # The resumed run (starting over) is killed again, after generation 1's checkpoint.
    process = _Process(_cli("resume", str(run_dir), "--quiet"), tmp_path)
    process.wait_until(
        lambda: _run_info(run_dir).get("generations_done", 0) >= 2, "generation 1's checkpoint"
    )
    process.kill()
    assert process.popen.returncode == -signal.SIGKILL
    assert _assert_killed_run_loads(run_dir, reference) == 2
    _resume_and_check(run_dir, reference)


@pytest.mark.soak
def test_killed_while_writing_again_and_again(configs, reference, tmp_path: Path) -> None:
    """Each kill leaves one file half written under its temporary name; each resume is killed
    again at the next kind of write, until the last one finishes the run."""
    run_dir, launcher = tmp_path / "run", configs["coevolve"].parent / "pause.py"
    # (what is being written, checkpoints this process wrote before, generations done after)
    kills = [
        # Generation 1's first table: no file of generation 1 exists yet.
        ("evaluations/gen-000001.parquet", 1, 1),
        # Its last table: evaluations and trajectories of generation 1 are already complete.
        ("bodies/gen-000001.parquet", 0, 1),
        # Its checkpoint: all tables of generation 1 exist, the checkpoint is generation 0's.
        ("checkpoints/state.json", 0, 1),
        # run.json after generation 1's checkpoint: it still says 1 generation done.
        ("run.json", 1, 1),
        # The run-level recording after generation 2's tables (the resume went on from
        # generation 1's checkpoint, and run.json says so again).
        ("run.rrd", 0, 2),
        # An evaluation's recording of generation 2, redone (written while its brains learn).
        ("-i001-c002.rrd", 0, 2),
    ]
    command = ["run", str(configs["coevolve"]), "--out", str(run_dir), "--executor", "serial"]
    for target, checkpoints_before, finished in kills:
        if target.endswith("-i001-c002.rrd"):  # its body's id: the first one of generation 2
            target = f"recordings/gen-000002/{_first_new_body(reference, 2)}{target}"
        _kill_while_writing(launcher, target, checkpoints_before, [*command, "--quiet"], run_dir)
        assert _assert_killed_run_loads(run_dir, reference) == finished, target
        command = ["resume", str(run_dir)]
    _resume_and_check(run_dir, reference)


@pytest.mark.soak
def test_killed_at_random_moments_many_times(configs, reference, tmp_path: Path) -> None:
    """SIGKILL after a random delay, again and again (the delays drawn from a seeded
    generator, so a failure reproduces): every kill leaves a run that loads and resumes, and
    the last resume ends with the uninterrupted records."""
    rng = np.random.default_rng(20261123)
    run_dir = tmp_path / "run"
    command = ["run", str(configs["coevolve"]), "--out", str(run_dir), "--executor", "serial"]
    kills = 0
    for _ in range(10):
        before = _stamp(run_dir / "run.json")
        process = _Process(_cli(*command, "--quiet"), tmp_path)
        # From the moment it runs (it rewrites run.json; the imports before take longer than
        # the run itself, ~1.5 s on 2 cores), a random delay: anywhere in a generation,
        # between writes or in one.
        process.wait_until(lambda b=before: _stamp(run_dir / "run.json") != b, "the run to start")
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.popen.wait(timeout=float(rng.uniform(0.0, 1.0)))
        if process.popen.poll() is not None:
            assert process.popen.returncode == 0, process.output()
            break
        process.kill()
        kills += 1
        if _run_info(run_dir).get("status") == "finished":  # killed while exiting, after its end
            break
        _assert_killed_run_loads(run_dir, reference)
        command = ["resume", str(run_dir)]
    assert kills >= 2, "the kills came too late to interrupt the run"
    if _run_info(run_dir).get("status") != "finished":
        _resume_and_check(run_dir, reference)
    else:
        _assert_same_records(run_dir, reference)
        _assert_recordings_like(run_dir, reference)


@pytest.mark.slow
def test_killed_local_executor_run_with_its_workers(configs, reference, tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    process = _Process(
        _cli(
            "run",
            str(configs["coevolve"]),
            "--out",
            str(run_dir),
            "--executor",
            "local",
            "--workers",
            "2",
            "--quiet",
        ),
        tmp_path,
    )
    process.wait_until(
        lambda: _run_info(run_dir).get("generations_done", 0) >= 1, "generation 0's checkpoint"
    )
    process.kill()  # the whole group: the pool's workers (and its forkserver) too
    assert _run_info(run_dir)["executor"] == {"kind": "local", "workers": 2, "address": None}
    assert _assert_killed_run_loads(run_dir, reference) >= 1
    _resume_and_check(run_dir, reference, 3, "--workers", "2")  # the local executor again


@pytest.mark.slow
def test_killed_brain_only_run_resumes_its_cma_es(configs, brain_reference, tmp_path) -> None:
    run_dir, launcher = tmp_path / "run", configs["coevolve"].parent / "pause.py"
    # Killed writing generation 2's first table: the checkpoint holds generation 1's CMA-ES.
    cli = ["run", str(configs["brain"]), "--out", str(run_dir), "--executor", "serial", "--quiet"]
    _kill_while_writing(launcher, "evaluations/gen-000002.parquet", 2, cli, run_dir)
    assert _assert_killed_run_loads(run_dir, brain_reference) == 2
    _resume_and_check(run_dir, brain_reference)
    # The resumed CMA-ES went on where the checkpoint left it: iterations 0-5 of one run.
    assert sorted(set(load_run(run_dir).evaluations["iteration"])) == list(range(6))
