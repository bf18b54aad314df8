"""`ariel watch`: a live view of a running (or finished) run or campaign, read from its folder.

A `Watcher` polls the folder (its `Source`: `RunSource` for a run, `CampaignSource` for a
campaign) every ``poll_s`` seconds and logs what is new to its own `rerun.RecordingStream`
(application id ``ariel``, recording id and name from the folder). That stream's sinks
(`RecordingStream.set_sinks`) are a `rerun.GrpcSink` to a ``rerun`` child process the watcher
starts bound to 127.0.0.1 only (the native viewer, or with ``viewer="web"`` the web viewer and
its gRPC proxy, ``--serve-web``: no browser is opened; with ``viewer="notebook"`` a gRPC
server only, ``--serve-grpc``, which Rerun's notebook widget shows) and, with ``save``, a
`rerun.FileSink`.
There is no server of ours. The child runs in its own session and dies with the watcher
(`_child.die_with_parent`); the web server keeps what it serves within its memory limit
(dropping the oldest), so a browser that is slow, closed or never opened holds nothing back.

The watcher never writes in the watched folder and never takes its lock: it reads files only
(run.json, manifests, a new generation's tables, recordings), so it works from another
terminal, from another machine over a shared or mounted file system, and after the run ended.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import rerun as rr

from ariel.errors import NotARunError, ViewError
from ariel.recording.rerun import APPLICATION_ID
from ariel.recording.store import one_line, output_file_problem
from ariel.recording.viewer._child import _terminate, die_with_parent, rerun_binary
from ariel.recording.viewer._watch_run import RunSource
from ariel.recording.viewer._web import (
    DEFAULT_GRPC_PORT,
    DEFAULT_WEB_PORT,
    LOCALHOST,
    _choose_port,
    _wait_until_serving,
    web_url,
)
from ariel.utils import ariel_line, has_display, in_notebook_kernel, no_display_why

if TYPE_CHECKING:
    from rerun.blueprint import Blueprint
    from rerun.notebook import Viewer

__all__ = ["VIEWERS", "Source", "Watcher", "source_for", "watch"]

VIEWERS = ("native", "web", "notebook", "none")
#: How long a poll waits for its data to reach the sinks (a slow viewer: it goes on later).
FLUSH_TIMEOUT_S = 1.0
#: How long a viewer whose ports answer must keep running to be ours: two watchers started
#: at once chose the same free ports, and the one whose server could not bind them streamed
#: into the other's and ended.
STARTED_GRACE_S = 0.5
#: How long closing waits for the last data to reach the sinks (the saved file above all).
CLOSE_TIMEOUT_S = 30.0


class Source(Protocol):
    """What a watched folder is: a run (`RunSource`) or a campaign (`CampaignSource`)."""

    path: Path

    def blueprint(self) -> Blueprint:
        """The `rerun.blueprint.Blueprint` laid out for it."""
        ...

    def poll(self, rec: rr.RecordingStream) -> bool:
        """Log to ``rec`` (a `rerun.RecordingStream`) whatever is new in the folder since the
        last poll; True when anything was logged. Reads only."""
        ...

    def finished(self) -> bool:
        """The run or campaign has ended (any final status) and the last poll logged
        everything it wrote."""
        ...


def source_for(path: str | os.PathLike[str]) -> Source:
    """The `Source` of a folder: a run folder (``run.json``) or a campaign folder
    (``campaign.json``); `NotARunError`, one line, for anything else."""
    folder = Path(path)
    if not folder.is_dir():
        problem = "is not a folder" if folder.exists() else "does not exist"
        raise NotARunError(f"{str(folder)!r} {problem}")
    if (folder / "campaign.json").is_file():
        try:
            # lazy: a tree without campaigns has no _watch_campaign; said in one line below
            from ariel.recording.viewer._watch_campaign import CampaignSource
        except ModuleNotFoundError as exc:
            if exc.name != "ariel.recording.viewer._watch_campaign":
                raise
            raise NotARunError(
                f"{str(folder)!r} is a campaign: watching a campaign is not available in this "
                "version; watch one of its runs (runs/condition=NAME/seed=N)"
            ) from None
        return CampaignSource(folder)
    if not os.path.lexists(folder / "run.json"):
        raise NotARunError(
            f"{str(folder)!r} is not an ariel run or campaign folder (no run.json or campaign.json)"
        )
    return RunSource(folder)


def _spawn(command: list[str]) -> subprocess.Popen[bytes]:
    """Start the ``rerun`` child in its own session (Ctrl-C reaches the watcher, which stops
    the whole group), terminated by Linux when the watcher dies."""
    env = dict(os.environ)
    env.setdefault("RUST_LOG", "warn")  # rerun's info lines repeat ours
    return subprocess.Popen(
        command,
        stdin=subprocess.DEVNULL,
        env=env,
        start_new_session=True,
        preexec_fn=die_with_parent(),
    )


class Watcher:
    """Follows a `Source`, logging what is new to a Rerun viewer (and a file); see the module
    docstring. Made by `watch`; a context manager (leaving it `close`s).

    Args:
        source: What to follow (`source_for`).
        viewer: ``"native"``, ``"web"``, ``"notebook"`` or ``"none"`` (see `watch`).
        port: The web viewer's port; None: 9090, or a free one when busy; 0: any free one.
        grpc_port: The viewer's gRPC port; None: 9876, or a free one when busy; 0: any.
        save: An ``.rrd`` file (outside the watched folder) to also write the stream to.
        poll_s: Seconds between polls in `follow`.
    """

    def __init__(
        self,
        source: Source,
        *,
        viewer: str = "native",
        port: int | None = None,
        grpc_port: int | None = None,
        save: str | os.PathLike[str] | None = None,
        poll_s: float = 0.5,
    ) -> None:
        _check(source, viewer, save, poll_s)
        self.source = source
        self.poll_s = float(poll_s)
        #: Where the viewer is: ``web`` (the page to open) and ``grpc`` (the proxy to stream
        #: to), each on 127.0.0.1; empty without a viewer.
        self.urls: dict[str, str] = {}
        #: The viewer's ports on 127.0.0.1 (the web viewer's first); empty without a viewer.
        self.ports: list[int] = []
        self._child: subprocess.Popen[bytes] | None = None
        self._closed = False
        self._thread: threading.Thread | None = None
        #: With ``viewer="notebook"``: Rerun's notebook widget, connected to the stream.
        self.widget: Any = None
        name = Path(source.path).resolve().name or "run"
        self.rec: Any = None
        try:
            sinks: list[rr.GrpcSink | rr.FileSink] = []
            if viewer != "none":  # first: the child is forked before the stream's threads
                sinks.append(rr.GrpcSink(self._start_viewer(viewer, port, grpc_port)))
            self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=name)
            self.rec.set_log_time_enabled(False)  # the generation and sim_time timelines only
            self.rec.set_log_tick_enabled(False)
            if save is not None:
                sinks.append(rr.FileSink(str(save)))
            try:
                self.rec.set_sinks(*sinks)
            except RuntimeError as exc:  # the file sink's first write: a full disk, a quota
                if save is None:
                    raise
                raise ViewError(f"cannot write --save {str(save)!r}: {one_line(exc)}") from None
            rr.send_recording_name(f"live: {name}", recording=self.rec)
            self.rec.send_blueprint(source.blueprint(), make_active=True, make_default=True)
            if viewer == "notebook":
                self.widget = _notebook_widget(self.urls["grpc"])
        except BaseException:
            self.close()
            raise

    def _start_viewer(self, viewer: str, port: int | None, grpc_port: int | None) -> str:
        """Start the ``rerun`` child bound to 127.0.0.1; returns its gRPC proxy's URL."""
        binary = str(rerun_binary())
        if viewer == "web":
            web = _choose_port(port, DEFAULT_WEB_PORT, "--port", set())
            grpc = _choose_port(grpc_port, DEFAULT_GRPC_PORT, "--grpc-port", {web})
            command = [binary, "--serve-web", "--bind", LOCALHOST, "--web-viewer-port", str(web)]
        elif viewer == "notebook":  # a gRPC server only: the notebook's widget is the viewer
            web = grpc = _choose_port(grpc_port, DEFAULT_GRPC_PORT, "--grpc-port", set())
            command = [binary, "--serve-grpc", "--bind", LOCALHOST]
        else:
            web = grpc = _choose_port(grpc_port, DEFAULT_GRPC_PORT, "--grpc-port", set())
            command = [binary, "--bind", LOCALHOST, "--expect-data-soon"]
        self._child = _spawn([*command, "--port", str(grpc)])
        serving = _wait_until_serving(self._child, web, grpc)
        if serving:  # another watcher's viewer may hold the ports: this one then ends at once
            time.sleep(STARTED_GRACE_S)
        if not serving or self._child.poll() is not None:
            code = self._child.poll()
            raise ViewError(
                f"the Rerun viewer ended (exit code {code}) as it started; if another viewer "
                "took its ports at the same moment, start it again"
            )
        self.urls["grpc"] = f"rerun+http://{LOCALHOST}:{grpc}/proxy"
        self.ports = sorted({web, grpc}, key=[web, grpc].index)
        if viewer == "web":
            self.urls["web"] = web_url(web, grpc)
        return self.urls["grpc"]

    def poll(self) -> bool:
        """Log what is new in the folder; True when anything was."""
        logged = bool(self.source.poll(self.rec))
        if logged:
            self._flush(FLUSH_TIMEOUT_S)
        return logged

    def viewer_running(self) -> bool:
        """Whether the viewer child still runs (True without a viewer)."""
        return self._child is None or self._child.poll() is None

    def follow(self, until_finished: bool = False) -> str:
        """Poll every ``poll_s`` seconds until the viewer ends (its window closed), or with
        ``until_finished`` until the source is finished; Ctrl-C raises `KeyboardInterrupt`.
        Returns why it stopped: ``"finished"``, ``"viewer closed"`` or ``"closed"`` (`close`
        was called, from another thread)."""
        while not self._closed:
            started = time.monotonic()
            self.poll()
            if until_finished and self.source.finished():
                return "finished"
            if not self.viewer_running():
                return "viewer closed"
            time.sleep(max(0.0, self.poll_s - (time.monotonic() - started)))
        return "closed"

    def follow_in_background(self, until_finished: bool = True) -> threading.Thread:
        """`follow` in a daemon thread, so a notebook's kernel stays free while the view
        updates (`watch` starts it for ``viewer="notebook"``); `close` stops it."""
        if self._thread is None or not self._thread.is_alive():

            def follow() -> None:
                with contextlib.suppress(Exception):  # closed under it: nothing to report
                    self.follow(until_finished=until_finished)

            self._thread = threading.Thread(target=follow, name="ariel-watch", daemon=True)
            self._thread.start()
        return self._thread

    def _flush(self, timeout: float) -> None:
        with contextlib.suppress(Exception):  # a slow viewer: the rest goes on in the background
            self.rec.flush(timeout_sec=timeout)

    def close(self) -> None:
        """Send what is logged (the saved file is complete after this), stop the viewer child
        and remove scratch files. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=self.poll_s + FLUSH_TIMEOUT_S + 5.0)
        try:
            if self.rec is not None:
                self._flush(CLOSE_TIMEOUT_S)
                self.rec.disconnect()  # ends the file (its footer) and the gRPC connection
        finally:
            if self._child is not None:
                _terminate(self._child)
            closing = getattr(self.source, "close", None)
            if callable(closing):
                closing()

    def __enter__(self) -> Watcher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _notebook_widget(url: str) -> Viewer:
    """Rerun's notebook viewer, connected to the gRPC server at ``url`` (rerun-sdk[notebook])."""
    try:
        from rerun.notebook import Viewer  # lazy: heavy optional library (its notebook extra)
    except ImportError:
        raise ViewError(
            "the notebook viewer needs rerun-sdk's notebook extra: pip install "
            "'rerun-sdk[notebook]' (make setup installs it)"
        ) from None
    try:
        return Viewer(url=url, width="auto", height=720, use_global_recording=False)
    except ImportError:  # rerun-notebook missing: the Viewer says so when made
        raise ViewError(
            "the notebook viewer needs rerun-sdk's notebook extra: pip install "
            "'rerun-sdk[notebook]' (make setup installs it)"
        ) from None


def _check(source: Source, viewer: str, save: str | os.PathLike[str] | None, poll_s: float) -> None:
    """Bad arguments as `ViewError`, one line, before anything starts."""
    if viewer not in VIEWERS:
        raise ViewError(f"viewer must be one of {', '.join(VIEWERS)}, not {viewer!r}")
    if not poll_s > 0:
        raise ViewError(f"the poll interval must be above 0 s, not {poll_s!r}")
    if viewer == "none" and save is None:
        raise ViewError("without a viewer, give a file to save the live recording in (--save)")
    if viewer == "native" and not has_display():
        raise ViewError(
            f"no display to open the Rerun viewer on ({no_display_why()}); "
            f"serve it to a browser instead: {ariel_line('watch', source.path, '--web')} "
            '(from Python: viewer="web")'
        )
    if save is not None:
        out, folder = Path(save).resolve(), Path(source.path).resolve()
        if out.suffix != ".rrd":
            raise ViewError(f"--save must name an .rrd file, not {str(save)!r}")
        if out == folder or folder in out.parents:
            raise ViewError(f"--save {str(save)!r} is in the watched folder: it is never written")
        problem = output_file_problem(save)  # another run's run.rrd was written over
        if problem is None and out.is_file() and out.stat().st_nlink > 1:
            problem = (
                f"{str(save)!r} has other names (hard links), written over too; give a new FILE"
            )
        if problem is not None:
            raise ViewError(f"--save: {problem}")
        if not out.parent.is_dir():  # named as given (relative), as every path printed is
            raise ViewError(f"--save: folder {str(Path(save).parent)!r} does not exist")


def watch(
    path: str | os.PathLike[str],
    *,
    viewer: str | None = None,
    port: int | None = None,
    grpc_port: int | None = None,
    save: str | os.PathLike[str] | None = None,
    poll_s: float = 0.5,
) -> Watcher:
    """Watch the run or campaign in ``path`` live: a `Watcher` streaming to a Rerun viewer.

    Args:
        path: A run folder or a campaign folder, running or finished; only read.
        viewer: ``"native"`` (a window; needs a display), ``"web"`` (the web viewer served on
            127.0.0.1: open ``watcher.urls["web"]``), ``"notebook"`` (Rerun's notebook widget,
            shown at once in Jupyter; needs ``rerun-sdk[notebook]``) or ``"none"`` (with
            ``save`` only). None (the default): ``"notebook"`` in a Jupyter kernel, else
            ``"native"``.
        port: The web viewer's port (default 9090; busy: a free one; 0: any free one).
        grpc_port: The viewer's gRPC port the data is streamed to (default 9876, likewise).
        save: Also write the live recording to this ``.rrd`` file (outside ``path``).
        poll_s: Seconds between looks at the folder.

    Returns:
        The started `Watcher`: call ``follow()`` (until Ctrl-C or the viewer's window is
        closed; ``follow(until_finished=True)``: until the run has ended and is all shown),
        or ``poll()`` yourself; ``close()`` (or leave its ``with`` block) at the end. With the
        notebook viewer it already follows in the background, until the run has ended.

    Raises:
        NotARunError: For a folder that is not a run or campaign.
        ViewError: For bad arguments, a busy port, or a viewer that cannot start.

    Example:
        ```python
        from ariel.recording import watch

        with watch("data/runs/my-run", viewer="web") as watcher:
            print(watcher.urls["web"])
            watcher.follow()
        ```

        In a Jupyter notebook, ``watch("data/runs/my-run")`` shows the live view below the cell
        and keeps it updating while the kernel runs other cells.
    """
    if viewer is None:
        viewer = "notebook" if in_notebook_kernel() else "native"
    watcher = Watcher(
        source_for(path), viewer=viewer, port=port, grpc_port=grpc_port, save=save, poll_s=poll_s
    )
    if viewer == "notebook":
        watcher.follow_in_background(until_finished=True)
        if in_notebook_kernel():
            watcher.widget.display()
    return watcher
