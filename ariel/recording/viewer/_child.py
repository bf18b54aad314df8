"""The Rerun viewer as a child process: the ``rerun`` binary of rerun-sdk, started in its own
session and never left behind.

Whatever ends this process (its own end, Ctrl-C, SIGTERM, SIGHUP when an SSH session drops)
terminates the child's process group (`stop_on_signals` turns SIGTERM and SIGHUP into
`ViewerStopped`), and on Linux the child also gets SIGTERM if this process is killed outright
(``PR_SET_PDEATHSIG``, `die_with_parent`).
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from ariel.errors import ViewError

__all__ = [
    "Stopped",
    "ViewerStopped",
    "die_with_parent",
    "raise_stopped",
    "rerun_binary",
    "stop_on_signals",
]

STOP_TIMEOUT_S = 5.0


def rerun_binary() -> Path:
    """The ``rerun`` executable of rerun-sdk (``RERUN_CLI_PATH`` overrides it, as in rerun-sdk).

    The binary itself, not the ``rerun`` Python wrapper script: the wrapper would run it as a
    grandchild that outlives the wrapper when that is killed.
    """
    override = os.environ.get("RERUN_CLI_PATH")
    if override:
        return Path(override)
    spec = importlib.util.find_spec("rerun_cli")
    for base in (spec.submodule_search_locations or []) if spec else []:
        for name in ("Rerun.app/Contents/MacOS/Rerun", "rerun", "rerun.exe"):
            candidate = Path(base) / name
            if candidate.is_file():
                return candidate
    found = shutil.which("rerun")
    if found:
        return Path(found)
    raise ViewError("the Rerun viewer is not installed (pip install rerun-sdk)")


def die_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` asking Linux to SIGTERM the child when this process dies."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()
    pr_set_pdeathsig = 1

    def preexec() -> None:
        prctl(pr_set_pdeathsig, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != parent:  # the parent died before prctl took effect
            os.kill(os.getpid(), signal.SIGTERM)

    return preexec


class ViewerStopped(BaseException):  # like KeyboardInterrupt: not caught as an Exception
    """SIGTERM or SIGHUP (``signum``) arrived while a viewer ran (`stop_on_signals`). Not
    `ariel.utils.interrupts.Stopped`, which stops a run."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


#: The name `ViewerStopped` had before (``ariel.recording.viewer.Stopped``).
Stopped = ViewerStopped


def raise_stopped(signum: int, frame: object) -> None:
    raise ViewerStopped(signum)


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """While inside, SIGTERM and SIGHUP (where the platform has it) raise `ViewerStopped`,
    so that the ``finally`` blocks that stop a viewer run; the previous handlers after."""
    handled = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])
    previous = {s: signal.signal(s, raise_stopped) for s in handled}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _terminate(proc: subprocess.Popen[bytes]) -> None:
    """End the child and anything it started (its process group), politely, then not."""
    for sig, grace in ((signal.SIGTERM, STOP_TIMEOUT_S), (signal.SIGKILL, STOP_TIMEOUT_S)):
        if proc.poll() is not None:
            break
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, sig)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=grace)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)  # stragglers of the group, if any
    proc.wait()


def _run_child(
    command: Sequence[str], *, when_started: Callable[[subprocess.Popen[bytes]], None] | None
) -> int:
    """Run ``command`` until it ends or this process is stopped; never leave it behind.

    Returns the child's exit code, 0 after Ctrl-C, 128 + n after signal n (SIGTERM, SIGHUP).
    """
    env = dict(os.environ)
    env.setdefault("RUST_LOG", "warn")  # rerun's info lines repeat (and contradict) ours
    with stop_on_signals():
        proc: subprocess.Popen[bytes] | None = None
        try:
            proc = subprocess.Popen(
                list(command),
                stdin=subprocess.DEVNULL,
                env=env,
                start_new_session=True,  # Ctrl-C reaches us; we stop the whole group
                # Only idle pool threads (pyarrow) exist here, so a preexec_fn is safe enough.
                preexec_fn=die_with_parent(),
            )
            if when_started is not None:
                when_started(proc)
            return proc.wait()
        except KeyboardInterrupt:
            print("\nstopped the Rerun viewer", file=sys.stderr)
            return 0
        except ViewerStopped as stop:
            return 128 + stop.signum
        finally:
            if proc is not None:
                _terminate(proc)
