"""One process per run folder: `RunLock` (fcntl.flock on RUN_DIR/.lock) end to end.

A second `ariel run` on the same folder, `ariel run --overwrite` of a running run and
`ariel resume` of a running run all refuse with one line (exit 2) and change nothing; a
SIGKILLed run leaves no stuck lock: `ariel runs` calls it "stopped (killed?)" and
`ariel resume` finishes it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from _helpers import one_error_line, repo_env, snapshot, tiny_run_toml

from ariel.cli import main
from ariel.recording import RunInUseError, RunLock, list_runs
from ariel.recording.store._lock import LOCK_NAME, lock_holder

pytestmark = pytest.mark.skipif(
    not hasattr(os, "killpg") or sys.platform == "win32", reason="needs POSIX flock and killpg"
)

TOML = tiny_run_toml("locked", 3)

# `ariel` (argv[2:]) whose run pauses after generation 0 (checkpoint and run.json written):
# it touches the marker argv[1] and sleeps until killed, holding the run folder's lock.
PAUSING = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path

    from ariel.evolution._progress import Progress

    original = Progress.end_generation

    def end_generation(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        Path(sys.argv[1]).touch()
        time.sleep(3600)

    Progress.end_generation = end_generation
    from ariel.cli import main

    sys.exit(main(sys.argv[2:]))
    """
)


@contextlib.contextmanager
def _started(argv: list[str], cwd: Path) -> Iterator[subprocess.Popen]:
    """A process in its own session (stderr in ``process.log``), SIGKILLed with its group on
    the way out."""
    path = cwd / f"stderr-{time.monotonic_ns()}.txt"
    with open(path, "wb") as log:
        process = subprocess.Popen(
            argv,
            cwd=cwd,
            env=repo_env(),
            stdout=subprocess.DEVNULL,
            stderr=log,
            start_new_session=True,
        )
        process.log = path  # type: ignore[attr-defined]
        try:
            yield process
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)


def _wait_for(path: Path, processes: list[subprocess.Popen], timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while not path.exists():
        ended = [p.returncode for p in processes if p.poll() is not None]
        if len(ended) == len(processes):
            pytest.fail(f"every run ended (exit codes {ended}) before {path.name} appeared")
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {path}")
        time.sleep(0.01)


# --------------------------------------------------------------------------------------------
# The lock itself
# --------------------------------------------------------------------------------------------


def test_a_held_lock_refuses_a_second_holder_and_names_the_first(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    with RunLock(run) as lock:
        assert lock.held
        holder = f"pid {os.getpid()} on host {socket.gethostname()}"
        assert lock_holder(run) == holder
        with pytest.raises(RunInUseError, match=f"is in use by {holder}"):
            RunLock(run).acquire()  # another open file: flock conflicts even in one process
        assert lock.held  # the refused attempt did not take or drop anything
    assert lock_holder(run) is None
    assert list(run.iterdir()) == []  # released: the lock file is gone
    with RunLock(tmp_path / "never", create=True):
        assert (tmp_path / "never" / LOCK_NAME).is_file()
    assert not (tmp_path / "never").exists()  # made for the lock, left empty: removed again


def test_a_killed_holder_leaves_no_stuck_lock(tmp_path: Path) -> None:
    holder = textwrap.dedent(
        """
        import sys, time
        from pathlib import Path
        from ariel.recording.store._lock import RunLock

        lock = RunLock(sys.argv[1]).acquire()
        Path(sys.argv[2]).touch()
        time.sleep(3600)
        """
    )
    marker = tmp_path / "locked"
    with _started([sys.executable, "-c", holder, str(tmp_path), str(marker)], tmp_path) as p:
        _wait_for(marker, [p])
        assert lock_holder(tmp_path) == f"pid {p.pid} on host {socket.gethostname()}"
        with pytest.raises(RunInUseError, match=f"pid {p.pid}"):
            RunLock(tmp_path).acquire()
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    assert (tmp_path / LOCK_NAME).is_file()  # left behind by the kill, but free
    assert lock_holder(tmp_path) is None
    with RunLock(tmp_path):
        assert lock_holder(tmp_path) == f"pid {os.getpid()} on host {socket.gethostname()}"


# --------------------------------------------------------------------------------------------
# ariel run / resume / runs
# --------------------------------------------------------------------------------------------


def test_two_runs_on_one_folder_the_second_refuses_and_a_kill_leaves_it_resumable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "locked.toml"
    config.write_text(TOML)
    out = tmp_path / "runs" / "shared"
    marker = tmp_path / "paused"
    argv = [sys.executable, "-c", PAUSING, str(marker), "run", str(config), "--out", str(out)]
    argv.append("--quiet")
    host = socket.gethostname()
    # Two runs started at once on a new folder: one runs (and pauses holding the lock) ...
    with _started(argv, tmp_path) as first, _started(argv, tmp_path) as second:
        _wait_for(marker, [first, second])
        holder = lock_holder(out)
        running, other = (
            (first, second)
            if holder == f"pid {first.pid} on host {host}"
            else (
                second,
                first,
            )
        )
        assert holder == f"pid {running.pid} on host {host}"
        # ... the other refuses: one line, exit 2.
        assert other.wait(timeout=120) == 2
        refusal = other.log.read_text()  # type: ignore[attr-defined]
        assert refusal.splitlines() == [
            f"ariel: error: run folder {str(out)!r} is in use by pid {running.pid} on host "
            f"{host}; wait for that run to end (or stop it), then try again"
        ], refusal
        assert running.poll() is None
        before = snapshot(out)
        assert (out / LOCK_NAME).is_file()
        # A third run, a run that overwrites and a resume refuse too, and change nothing.
        for command in (
            ["run", str(config), "--out", str(out), "--quiet"],
            ["run", str(config), "--out", str(out), "--overwrite", "--quiet"],
            ["resume", str(out), "--quiet"],
        ):
            assert main(command) == 2, command
            line = one_error_line(capsys)
            assert f"{str(out)!r} is in use by pid {running.pid} on host {host}" in line, line
        assert snapshot(out) == before
        assert [r["status"] for r in list_runs(out.parent)] == ["running"]
        os.killpg(running.pid, signal.SIGKILL)
        running.wait(timeout=30)
    # The kill left run.json saying "running"; `ariel runs` sees that no process runs it.
    assert [r["status"] for r in list_runs(out.parent)] == ["stopped (killed?)"]
    assert main(["runs", str(out.parent)]) == 0
    assert "stopped (killed?)" in capsys.readouterr().out
    assert main(["resume", str(out), "--quiet"]) == 0
    assert "finished: " in capsys.readouterr().out
    assert [r["status"] for r in list_runs(out.parent)] == ["finished"]
    assert not (out / LOCK_NAME).exists()


def test_runs_calls_a_run_stopped_only_when_its_lock_is_surely_free(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ariel.recording.store._lock as lock_module
    from ariel.recording import RunFolder

    RunFolder.create(tmp_path / "r", {"run_id": "r", "status": "running"}, overwrite=False)
    with RunLock(tmp_path / "r"):
        assert [r["status"] for r in list_runs(tmp_path)] == ["running"]
    assert [r["status"] for r in list_runs(tmp_path)] == ["stopped (killed?)"]
    # a free .lock naming a live process (its pid reused since): the free lock decides
    (tmp_path / "r" / LOCK_NAME).write_text(f"pid {os.getpid()} on host {socket.gethostname()}")
    assert [r["status"] for r in list_runs(tmp_path)] == ["stopped (killed?)"]
    assert lock_module.holder_gone(tmp_path / "r")  # the one rule report and watch use too
    monkeypatch.setattr(lock_module, "fcntl", None)  # a platform that cannot tell
    assert [r["status"] for r in list_runs(tmp_path)] == ["running"]  # that process lives
    (tmp_path / "r" / LOCK_NAME).write_text(f"pid {2**22 + 7} on host {socket.gethostname()}")
    assert [r["status"] for r in list_runs(tmp_path)] == ["stopped (killed?)"]  # no such pid


def test_a_run_killed_before_it_started_is_stopped_and_prunable(tmp_path: Path) -> None:
    """Killed between run.json and its start, a run read "created" for ever and --prune kept
    it (probe G1); a run.json whose created is no text stopped the notebooks' choice of run
    (sorted on it) for every run beside it (probe G2)."""
    from ariel.recording import RunFolder
    from ariel.recording.store._prune import prune_run

    RunFolder.create(tmp_path / "r", {"run_id": "r", "status": "created"}, overwrite=False)
    with RunLock(tmp_path / "r"):
        assert [r["status"] for r in list_runs(tmp_path)] == ["created"]  # starting now
    assert [r["status"] for r in list_runs(tmp_path)] == ["stopped (killed?)"]
    RunFolder.create(tmp_path / "odd", {"run_id": "odd", "created": 17}, overwrite=False)
    rows = {r["run_id"]: r for r in list_runs(tmp_path)}
    assert rows["odd"]["status"] == "unreadable" and rows["odd"]["created"] is None
    prune_run(tmp_path, tmp_path / "r")
    assert not (tmp_path / "r").exists()


def test_one_entry_whose_path_is_too_long_does_not_stop_the_listing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`ariel runs PARENT` stopped with exit 2 over one entry whose path no file system takes
    here (over PATH_MAX), listing none of the others (probe G4)."""
    import errno
    from pathlib import PosixPath

    from ariel.recording import RunFolder

    RunFolder.create(tmp_path / "good", {"run_id": "good", "status": "finished"}, overwrite=False)
    (tmp_path / "long").mkdir()
    real = PosixPath.is_dir

    def is_dir(self: Path) -> bool:
        if self.name == "long":
            raise OSError(errno.ENAMETOOLONG, "File name too long", str(self))
        return real(self)

    monkeypatch.setattr(PosixPath, "is_dir", is_dir)
    rows = {r["run_id"]: r["status"] for r in list_runs(tmp_path)}
    assert rows == {"good": "finished", "long": "unreadable"}
