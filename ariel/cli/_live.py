"""``--live`` (and ``--web``) for ``ariel run``, ``ariel resume`` and ``ariel campaign run |
resume``: the live view of the run beside it.

The live view is ``ariel watch`` itself, as a child process reading the folder: one mechanism
for a run watched from here, from another terminal or from another machine. The child starts
before the run, waits for the folder's ``run.json`` (``campaign.json``) to be written
(`ariel.cli._live_child`), then becomes ``python -m ariel.cli watch DIR [--web]`` (``exec``).
The run never waits on it: it shares nothing with it but the folder, which the watcher only
reads. The child dies with this process (Linux: ``PR_SET_PDEATHSIG``). It ignores SIGINT:
Ctrl-C interrupts the run, which then stops the watcher (SIGTERM: it saves what it logged and
ends). When the run ends, the command says that the view stays open and waits until its
window is closed (with ``--web``: until Ctrl-C).

``ARIEL_WATCH_ARGS``: more options for the watcher (``--no-viewer --save FILE.rrd
--until-finished`` in the tests and benchmarks), split as a shell would.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from ariel import runs
from ariel.cli._common import DEFAULT_RUNS
from ariel.errors import ConfigError
from ariel.recording import viewer
from ariel.utils import has_display, no_display_why

if TYPE_CHECKING:
    from ariel.evolution import ExperimentConfig

__all__ = ["WATCH_ARGS_ENV", "LiveView"]

T = TypeVar("T")

#: Environment variable with more options for the watcher, e.g. ``--no-viewer --save F.rrd``.
WATCH_ARGS_ENV = "ARIEL_WATCH_ARGS"
#: Seconds a stopped watcher gets to end before it is killed.
STOP_TIMEOUT_S = 5.0
#: The child's module: it waits for the folder, then becomes the watcher.
CHILD = "ariel.cli._live_child"
#: The watcher's (and its viewer's) niceness: below the run's when the CPUs are all busy,
#: its share then is a small one; idle CPUs it gets in full.
WATCHER_NICENESS = 10


class LiveView:
    """The live view of one command's run or campaign (nothing when not asked for).

    Args:
        args: The command's arguments (``live``, ``web``).
        marker: The file that makes the folder a run (``run.json``) or campaign
            (``campaign.json``): the watcher starts once it is written.
    """

    def __init__(self, args: argparse.Namespace, marker: str = "run.json") -> None:
        self.web = bool(getattr(args, "web", False))
        self.enabled = bool(getattr(args, "live", False)) or self.web
        self.marker = marker
        self.folder: Path | None = None
        self.proc: subprocess.Popen[bytes] | None = None
        self.interrupted = False

    def command(self, folder: str | Path) -> list[str]:
        """The watcher's command for ``folder``."""
        extra = shlex.split(os.environ.get(WATCH_ARGS_ENV, ""))
        web = ["--web"] if self.web else []
        return [sys.executable, "-m", "ariel.cli", "watch", str(folder), *web, *extra]

    def run_folder(
        self,
        out: str | None,
        config: ExperimentConfig | str | Path | dict[str, Any] | None,
        overrides: Sequence[str],
    ) -> str | None:
        """``ariel run``'s folder (``out``, else the default one, named as `run_experiment`
        names it) with the watcher started on it; ``out`` unchanged when not live."""
        if not self.enabled:
            return out
        if out is None:
            out = str(Path(DEFAULT_RUNS) / runs.new_run_id(runs.load_config(config, overrides)))
        self.start(out)
        return out

    def campaign_folder(self, out: str | None, file: str, overrides: Sequence[str]) -> str | None:
        """``ariel campaign run``'s folder (``out``, else the default one, named as
        `run_campaign` names it) with the watcher started on it; ``out`` unchanged when not
        live."""
        if not self.enabled:
            return out
        if out is None:
            spec = runs.load_campaign_file(file, tuple(overrides))
            out = str(Path("data") / "campaigns" / runs.new_campaign_id(spec.name))
        self.start(out)
        return out

    def start(self, folder: str | Path) -> None:
        """Start the child that waits for ``folder``'s marker file to be written from now on
        (a run folder about to be replaced has an old one; a run or campaign resumed has
        one that says how it ended before), then becomes the watcher. Nothing when not
        live."""
        if not self.enabled or self.proc is not None:
            return
        self._check_display()
        self.folder = Path(folder)
        since = time.time() - 0.05  # file times may lag the clock a little
        waiter = [sys.executable, "-m", CHILD, str(folder), self.marker, str(since)]
        die = viewer.die_with_parent()

        def preexec() -> None:  # started before the run: no busy threads yet
            # Ctrl-C is this process's to handle: it stops the watcher then, with SIGTERM
            # (once, whenever it comes: a SIGINT in the watcher's imports is a traceback).
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            with contextlib.suppress(OSError):
                os.nice(WATCHER_NICENESS)  # the run first, where the CPUs are all busy
            if die is not None:
                die()

        self.proc = subprocess.Popen(
            [*waiter, *self.command(folder)], stdin=subprocess.DEVNULL, preexec_fn=preexec
        )
        atexit.register(self.stop)

    def _check_display(self) -> None:
        """The native viewer needs a display: without one, say so before the run starts."""
        headless = "--no-viewer" in shlex.split(os.environ.get(WATCH_ARGS_ENV, ""))
        if not (self.web or headless or has_display()):
            raise ConfigError(
                f"--live: no display to open the Rerun viewer on ({no_display_why()}); add "
                "--web to serve the live view to a browser (the address and an SSH tunnel line "
                "are printed)"
            )

    def guard(self, start: Callable[[], T]) -> Callable[[], T]:
        """``start``, noting an interruption (Ctrl-C, SIGTERM): the view then stops too."""

        def guarded() -> T:
            try:
                return start()
            except KeyboardInterrupt:
                self.interrupted = True
                raise

        return guarded

    def finish(self, code: int) -> int:
        """After the run: a run that did not end well (interrupted, failed, never made its
        folder) stops the view; else say that it stays open and wait for it (Ctrl-C ends
        it). Returns ``code``."""
        proc = self.proc
        if proc is None:
            return code
        made = self.folder is not None and (self.folder / self.marker).is_file()
        if code != 0 or self.interrupted or not made or proc.poll() is not None:
            self.stop()
            return code
        if "--no-viewer" in self.command(self.folder or "."):
            line = "waiting for the watcher to end (Ctrl-C stops it)"
        else:
            until = "Ctrl-C" if self.web else "you close its window (or press Ctrl-C)"
            line = f"the live view stays open until {until}"
        print(line, file=sys.stderr, flush=True)
        try:
            proc.wait()
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()
        return code

    def stop(self) -> None:
        """End the watcher (SIGTERM, then SIGKILL) and reap it."""
        proc = self.proc
        if proc is None:
            return
        for stop in (proc.terminate, proc.kill):
            if proc.poll() is not None:
                break
            with contextlib.suppress(ProcessLookupError):
                stop()
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=STOP_TIMEOUT_S)
        proc.wait()
