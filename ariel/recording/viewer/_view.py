"""`ariel view`: open a run's Rerun recordings in the viewer, native or served to a browser.

The viewer is the ``rerun`` binary of rerun-sdk, started as a child process in its own
session: whatever ends this command (its own end, Ctrl-C, SIGTERM, SIGHUP when an SSH session
drops) terminates the child's process group, and on Linux the child also gets SIGTERM if this
process is killed outright (``PR_SET_PDEATHSIG``). ``--web`` binds to 127.0.0.1 only, never
opens a browser, and prints the SSH tunnel that reaches it from another machine.
"""

from __future__ import annotations

import contextlib
import dataclasses
import getpass
import importlib.util
import math
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

from ariel.errors import ViewError
from ariel.recording.store import (
    GENERATION_BLUEPRINT,
    check_eval_id,
    generation_recording_path,
    recording_path,
)
from ariel.recording.viewer._archive_panel import archive_beside as _archive_beside
from ariel.utils import ariel_line, has_display

__all__ = [
    "DEFAULT_GRPC_PORT",
    "DEFAULT_WEB_PORT",
    "Selection",
    "ViewError",
    "best_evaluations",
    "recording_path",
    "rerun_binary",
    "select_recordings",
    "view",
]

RECORDINGS = "recordings"
RUN_RECORDING = "run.rrd"
BLUEPRINT = "blueprint.rbl"
DEFAULT_WEB_PORT = 9090  # rerun's defaults: the web viewer over HTTP, and its gRPC proxy
DEFAULT_GRPC_PORT = 9876
LOCALHOST = "127.0.0.1"
READY_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 5.0
_EVAL_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
# A recording's file name is the id plus ".rrd": longer ones cannot exist (NAME_MAX 255), and
# asking the file system about them fails with ENAMETOOLONG.
_MAX_EVAL_ID = 200


@dataclass(frozen=True)
class Selection:
    """The recordings to open: ``.rrd`` paths, the blueprint (or None) and a description."""

    run_dir: Path
    recordings: tuple[Path, ...]
    blueprint: Path | None
    description: str
    #: The best evaluation's recording: the default view opens it alone, with the run's
    #: fitness, diversity (and archive) beside it (`write_view_recording`), so the viewer
    #: starts on its robot, morphology and joints.
    overview: Path | None = None
    #: Layouts of other application ids among the recordings (a generation's
    #: ``evaluations.rrd`` has its own, ``generation.rbl``).
    more_layouts: tuple[Path, ...] = ()
    #: The recordings are the run's, of application ``ariel`` (evaluations' own, run.rrd):
    #: each is opened as a copy with the run's charts beside it, laid out for the run (see
    #: `_prepared`). Not a generation's ``evaluations.rrd`` nor a campaign's recording.
    beside_run: bool = False

    @property
    def files(self) -> list[Path]:
        """Every file to hand the viewer: recordings, then layouts."""
        layouts = [self.blueprint] if self.blueprint else []
        return [*self.recordings, *layouts, *self.more_layouts]


def _rrd_files(folder: Path) -> list[Path]:
    """The finished ``.rrd`` files in ``folder`` (temporaries are hidden ``.name.tmp`` files)."""
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.glob("*.rrd") if p.is_file() and not p.name.startswith("."))


def best_evaluations(evaluations: Any, k: int, *, maximise: bool) -> Any:
    """The ``k`` best finished evaluations (status ``ok``, finite fitness), best first; ties
    keep table order (earlier generation, then earlier evaluation)."""
    finite = evaluations["fitness"].map(lambda f: math.isfinite(f))
    ok = evaluations[(evaluations["status"] == "ok") & finite]
    return ok.sort_values("fitness", ascending=not maximise, kind="stable").head(k)


def _no_recordings(run: Any) -> ViewError:
    rerun_on = bool(run.config.get("record", {}).get("rerun", False))
    why = (
        "none written yet"
        if rerun_on
        else "the run was made with record.rerun = false; "
        "run it with --set record.rerun=true to record them"
    )
    return ViewError(f"no Rerun recordings in {run.path} ({why})")


def select_recordings(
    run_dir: str | Path,
    *,
    best: int | None = None,
    generation: int | None = None,
    eval_id: str | None = None,
) -> Selection:
    """Pick recordings of a run: the ``best`` K evaluations, one ``generation``'s, one
    ``eval_id``'s, or by default ``run.rrd`` and the best evaluation's. Raises `ViewError`."""
    from ariel.recording.store import NotARunError, load_run

    if sum(x is not None for x in (best, generation, eval_id)) > 1:
        raise ViewError("choose one of --best, --generation and EVAL_ID")
    if (Path(run_dir) / "campaign.json").is_file():
        return _campaign_selection(Path(run_dir), best, generation, eval_id)
    try:
        run = load_run(run_dir)
    except NotARunError as exc:
        raise ViewError(str(exc)) from None
    folder = run.path
    blueprint = folder / BLUEPRINT
    blueprint_or_none = blueprint if blueprint.is_file() else None
    run_rrd = folder / RUN_RECORDING
    if not run_rrd.is_file() and not any((folder / RECORDINGS).glob("gen-*/*.rrd")):
        raise _no_recordings(run)

    def chosen(paths: Sequence[Path], description: str) -> Selection:
        return Selection(folder, tuple(paths), blueprint_or_none, description, beside_run=True)

    if eval_id is not None:
        if len(eval_id) > _MAX_EVAL_ID or not _EVAL_ID.fullmatch(eval_id):
            shown = (
                eval_id if len(eval_id) <= 60 else f"{eval_id[:40]}...({len(eval_id)} characters)"
            )
            raise ViewError(f"not an evaluation id: {shown!r} (ids look like b000012-i003-c005)")
        found = sorted((folder / RECORDINGS).glob(f"gen-*/{eval_id}.rrd"))
        if found:
            return chosen(*_with_body_poses(run, eval_id, found[0]))
        known = run.evaluations["eval_id"] == eval_id
        if known.any():
            generation_of = int(run.evaluations.loc[known, "generation"].iloc[0])
            return _replayed_or_generation(run, eval_id, generation_of, blueprint_or_none)
        raise ViewError(
            f"no evaluation {eval_id} in {folder} (ids look like b000012-i003-c005; "
            f"{ariel_line('view', run_dir, '--best', 5)} opens the 5 best)"
        )

    if generation is not None:
        shared = generation_recording_path(folder, generation)
        if shared.is_file():
            return _generation_selection(run, generation, f"generation {generation}'s evaluations")
        found = _rrd_files(folder / RECORDINGS / f"gen-{generation:06d}")
        if found:  # a run recorded before generation recordings: its evaluations' own files
            return chosen(found, f"generation {generation}")
        done = run.generations_done
        if not 0 <= generation < max(done, 1) or done == 0:
            span = f"generations 0..{done - 1}" if done else "no finished generation"
            raise ViewError(f"no generation {generation} in {folder} (it has {span})")
        raise ViewError(f"no recordings of generation {generation} in {folder}")

    evaluations = run.evaluations
    ranked = best_evaluations(
        evaluations, best or 1, maximise=run.maximise if len(evaluations) else True
    )
    # Ids from the table name files: a crafted one (``../../x``) is refused, never opened.
    paths = [
        recording_path(folder, g, check_eval_id(e, folder))
        for g, e in zip(ranked["generation"], ranked["eval_id"])
    ]
    if best is not None:
        paths = [_own_or_replayed(run, path) for path in paths]
        if not paths:
            raise ViewError(f"no finished evaluation in {folder} to rank")
        return chosen(paths, f"the {len(paths)} best evaluations")

    # Default: the best evaluation's recording (its own, else its 3D replay made on demand;
    # the viewer opens on its robot) and the run-level recording, whichever exist.
    picked, parts = [], []
    overview = _best_recording(run, paths[0]) if paths else None
    if overview is not None:
        picked.append(overview)
        parts.append(f"the best evaluation {overview.stem}")
    if run_rrd.is_file():
        picked.append(run_rrd)
        parts.append(RUN_RECORDING)
    if not picked:
        raise _no_recordings(run)
    return dataclasses.replace(chosen(picked, " and ".join(parts)), overview=overview)


def _best_recording(run: Any, path: Path) -> Path | None:
    """The best evaluation's recording: its own, else its 3D replay made on demand; None (with
    a note) where neither can be had."""
    if path.is_file():
        return path
    try:
        return _own_or_replayed(run, path)
    except ViewError as exc:
        print(f"ariel: {exc}; showing {RUN_RECORDING} alone", file=sys.stderr)
        return None


def _run_series(run: Any) -> Any:
    """Per generation: fitness and diversity of the population, as run.rrd has them."""
    import pandas as pd

    from ariel.recording.rerun import generation_summary

    bodies = run.bodies
    rows = [
        generation_summary(int(g), group.to_dict("records"), run.maximise)[0]
        for g, group in (bodies.groupby("generation") if len(bodies) else [])
    ]
    return pd.DataFrame(rows) if rows else pd.DataFrame({"generation": []})


def _graph_of(run: Any, eval_id: str) -> str | None:
    """The morphology (node-link JSON, the bodies table's) of evaluation ``eval_id``'s body;
    None for another recording (run.rrd) or a body without one."""
    evaluations, bodies = run.evaluations, run.bodies
    if not len(evaluations) or not len(bodies) or "graph" not in bodies:
        return None
    body = evaluations.loc[evaluations["eval_id"] == eval_id, "body_id"]
    if body.empty:
        return None
    graphs = bodies.loc[bodies["body_id"] == body.iloc[0], "graph"]
    graph = graphs.iloc[0] if len(graphs) else None
    return graph if isinstance(graph, str) and graph else None


def _fitness_unit(run: Any) -> str | None:
    from ariel.recording.store import fitness_unit

    name = run.config.get("task", {}).get("fitness")
    return fitness_unit(name) if isinstance(name, str) and name else None


@contextlib.contextmanager
def _prepared(selection: Selection, *, panels: bool = True) -> Iterator[Selection]:
    """``selection`` as the viewer is given it, for as long as the viewer runs (scratch files;
    the run folder is never written to).

    A run's recordings (`Selection.beside_run`) are each replaced by a copy that also holds
    the run's fitness and diversity per generation and, for a MAP-Elites run, its archive
    (`write_view_recording`), so every panel of the layout has data whichever recording the
    viewer shows. The default view opens the best evaluation's copy alone: given ``run.rrd``
    as well, the viewer opens on that, and the robot, morphology and joint views stay empty.
    The layout is written for what is shown: the archive view for a run with an archive, the
    fitness function's unit in the titles, the tabs of curves on the ``generation`` timeline
    where ``run.rrd`` is shown (``panels=False``: the side panels collapsed, for pictures). A
    generation's or a campaign's recording is given as it is.
    """
    if not selection.beside_run:
        yield selection
        return
    import tempfile

    from ariel.recording.rerun import archive_kind, write_blueprint, write_view_recording
    from ariel.recording.store import load_run

    scratch = Path(tempfile.mkdtemp(prefix="ariel-view-"))
    try:
        run = load_run(selection.run_dir)
        beside = _archive_beside(run)
        grid, dimensions = beside if beside is not None else (None, None)
        generations = _run_series(run)
        sources = (selection.overview,) if selection.overview else selection.recordings
        recordings = tuple(
            write_view_recording(
                scratch / f"{k:03d}" / path.name,  # one folder each: names may repeat
                path,
                generations,
                archive=grid,
                archive_dimensions=dimensions,
                graph_json=_graph_of(run, path.stem),
            )
            for k, path in enumerate(sources)
        )
        layout = write_blueprint(
            scratch / "views.rbl",
            panels=panels,
            archive=archive_kind(grid),
            fitness_unit=_fitness_unit(run),
            run_curves=any(path.name == RUN_RECORDING for path in sources),
        )
        description = selection.description
        if selection.overview is not None:
            description = (
                f"the best evaluation {selection.overview.stem} "
                "with the run's fitness and diversity per generation"
            )
        yield dataclasses.replace(
            selection, recordings=recordings, blueprint=layout, description=description
        )
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _own_or_replayed(run: Any, path: Path) -> Path:
    """An evaluation's own recording, else its 3D replay made on demand (an evaluation that
    was not an elite is recorded in its generation's ``evaluations.rrd`` only)."""
    from ariel.errors import MissingPluginError
    from ariel.recording.resim import on_demand_recording

    if path.is_file():
        return path
    try:
        return on_demand_recording(run.path, path.stem)
    except (MissingPluginError, ValueError) as exc:
        where = path.relative_to(run.path)
        raise ViewError(f"{where} is not recorded and cannot be replayed: {exc}") from None


def _replayed_or_generation(
    run: Any, eval_id: str, generation: int, blueprint: Path | None
) -> Selection:
    """An evaluation without its own recording: its 3D replay made on demand, else (without
    the run's plugins) its generation's recording of every evaluation, with a note."""
    from ariel.errors import MissingPluginError
    from ariel.recording.resim import on_demand_recording

    shared = generation_recording_path(run.path, generation)
    try:
        made = on_demand_recording(run.path, eval_id)
    except (MissingPluginError, ValueError) as exc:
        if not shared.is_file():
            raise ViewError(
                f"evaluation {eval_id} has no recording and no 3D replay: {exc}"
            ) from None
        print(
            f"ariel: no 3D replay of {eval_id}: {exc}; showing its generation's recording",
            file=sys.stderr,
        )
        return _generation_selection(
            run, generation, f"generation {generation}'s evaluations ({eval_id} among them)"
        )
    return Selection(
        run.path,
        (made,),
        blueprint,
        f"evaluation {eval_id} (3D replay re-simulated on demand)",
        beside_run=True,
    )


def _generation_selection(run: Any, generation: int, description: str) -> Selection:
    """The generation's recording of every evaluation, alone, with its layout. Alone: given
    the elites' 3D replays as well, the viewer opens on one of those instead. (They open
    one at a time: ``ariel view RUN EVAL_ID``.)"""
    layout = run.path / GENERATION_BLUEPRINT
    return Selection(
        run.path,
        (generation_recording_path(run.path, generation),),
        None,
        description,
        more_layouts=(layout,) if layout.is_file() else (),
    )


def _with_body_poses(run: Any, eval_id: str, recorded: Path) -> tuple[list[Path], str]:
    """The evaluation's recording when it holds the bodies' poses (or was not written by the
    loop), else its 3D replay made on demand by exact re-simulation (`on_demand_recording`;
    cached in the run folder). Without the run's plugins, the recording as it is, with a
    note."""
    from ariel.errors import MissingPluginError
    from ariel.recording.resim import has_body_poses, on_demand_recording

    if not run.config.get("record", {}).get("rerun") or has_body_poses(recorded):
        return [recorded], f"evaluation {eval_id}"
    try:
        made = on_demand_recording(run.path, eval_id)
    except (MissingPluginError, ValueError) as exc:
        print(f"ariel: no 3D replay of {eval_id}: {exc}", file=sys.stderr)
        return [recorded], f"evaluation {eval_id} (no 3D replay)"
    return [made], f"evaluation {eval_id} (3D replay re-simulated on demand)"


def _view_line(
    run_dir: str | Path, best: int | None, generation: int | None, eval_id: str | None, *more: str
) -> str:
    """The ``ariel view`` command line (pasteable) of these options."""
    words: list[object] = [run_dir, *([eval_id] if eval_id is not None else [])]
    words += ["--best", best] if best is not None else []
    words += ["--generation", generation] if generation is not None else []
    return ariel_line("view", *words, *more)


def _campaign_selection(
    folder: Path, best: int | None, generation: int | None, eval_id: str | None
) -> Selection:
    """A campaign folder: campaign.rrd (every run's best-so-far curve) with campaign.rbl."""
    from ariel.recording.rerun import CAMPAIGN_BLUEPRINT, write_campaign_recording
    from ariel.recording.store import NotARunError, read_campaign_info

    try:  # a damaged or crafted campaign.json (a run path out of the folder) is one line
        read_campaign_info(folder)
    except NotARunError as exc:
        raise ViewError(str(exc)) from None
    if (best, generation, eval_id) != (None, None, None):
        runs = sorted(folder.glob("runs/condition=*/seed=*"))
        one = runs[0] if runs else folder / "runs" / "condition=NAME" / "seed=N"
        raise ViewError(
            f"{folder} is a campaign: --best, --generation and EVAL_ID apply to one of its runs, "
            f"e.g. {_view_line(one, best, generation, eval_id)}"
        )
    recording = folder / "campaign.rrd"
    if not recording.is_file():  # a campaign killed before it wrote one
        write_campaign_recording(folder)
    blueprint = folder / CAMPAIGN_BLUEPRINT
    return Selection(
        folder,
        (recording,),
        blueprint if blueprint.is_file() else None,
        "campaign.rrd (every run's best fitness so far)",
    )


# --- the rerun binary and its child process --------------------------------------------------


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
    import ctypes

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


class Stopped(BaseException):  # like KeyboardInterrupt: not caught as an Exception
    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def raise_stopped(signum: int, frame: object) -> None:
    raise Stopped(signum)


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
    handled = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])
    previous = {s: signal.signal(s, raise_stopped) for s in handled}
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
    except Stopped as stop:
        return 128 + stop.signum
    finally:
        if proc is not None:
            _terminate(proc)
        for s, handler in previous.items():
            signal.signal(s, handler)


# --- web: ports, readiness, the tunnel --------------------------------------------------------


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server will
        try:
            s.bind((LOCALHOST, port))
        except OSError:
            return False
    return True


def _any_free_port(exclude: set[int]) -> int:
    while True:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.bind((LOCALHOST, 0))
            port = int(s.getsockname()[1])
        if port not in exclude:
            return port


def _choose_port(requested: int | None, default: int, option: str, taken: set[int]) -> int:
    """``requested`` as given (0: any free port); unset: ``default``, or a free one if busy."""
    if requested:
        if requested in taken or not _port_free(requested):
            raise ViewError(f"port {requested} on {LOCALHOST} is in use; choose another {option}")
        return requested
    if requested is None and default not in taken and _port_free(default):
        return default
    return _any_free_port(taken)


def _listening(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(0.5)
        return s.connect_ex((LOCALHOST, port)) == 0


def web_url(web_port: int, grpc_port: int) -> str:
    """The web viewer's address, connected to the gRPC proxy that serves the recordings."""
    proxy = f"rerun+http://{LOCALHOST}:{grpc_port}/proxy"
    return f"http://{LOCALHOST}:{web_port}/?url={quote(proxy, safe='')}"


def tunnel_command(ports: Sequence[int]) -> str:
    """The SSH command that forwards ``ports`` of this machine's 127.0.0.1 to the same ports
    on the caller's machine."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = os.environ.get("USER", "user")
    forwards = " ".join(f"-L {p}:{LOCALHOST}:{p}" for p in ports)
    return f"ssh -N {forwards} {shlex.quote(user)}@{socket.gethostname()}"


def _memory_limit(paths: Sequence[Path]) -> str:
    """The gRPC server keeps what it serves in memory and drops the oldest data beyond its
    limit (1 GiB by default): make room for three times the files."""
    total = sum(p.stat().st_size for p in paths)
    return f"{max(1024, math.ceil(3 * total / 2**20))}MiB"


def web_command(selection: Selection, web_port: int, grpc_port: int) -> list[str]:
    files = selection.files
    return [
        str(rerun_binary()),
        "--serve-web",  # serve, never open a browser
        "--bind",
        LOCALHOST,
        "--web-viewer-port",
        str(web_port),
        "--port",
        str(grpc_port),
        "--server-memory-limit",
        _memory_limit(files),
        *map(str, files),
    ]


def native_command(selection: Selection) -> list[str]:
    return [str(rerun_binary()), *map(str, selection.files)]


def _wait_until_serving(proc: subprocess.Popen[bytes], web_port: int, grpc: int) -> bool:
    """Whether both ports listen (False: the server ended; its messages are above)."""
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not (_listening(web_port) and _listening(grpc)):
        if proc.poll() is not None:
            return False
        if time.monotonic() > deadline:
            raise ViewError(f"the Rerun server did not start in {READY_TIMEOUT_S:.0f} s")
        time.sleep(0.1)
    return True


def _serve_web(selection: Selection, port: int | None, grpc_port: int | None) -> int:
    web_port = _choose_port(port, DEFAULT_WEB_PORT, "--port", set())
    grpc = _choose_port(grpc_port, DEFAULT_GRPC_PORT, "--grpc-port", {web_port})
    command = web_command(selection, web_port, grpc)

    def announce(proc: subprocess.Popen[bytes]) -> None:
        if not _wait_until_serving(proc, web_port, grpc):
            return  # it failed; the exit code follows
        count = len(selection.recordings)
        print(
            f"Rerun web viewer: {selection.description} ({count} file{'s' * (count != 1)}) "
            f"of {selection.run_dir}\n"
            f"  open  {web_url(web_port, grpc)}\n"
            f"From another computer (this one being a cluster node), tunnel both ports first:\n"
            f"  {tunnel_command([web_port, grpc])}\n"
            f"  (add -J user@login-node when this node is reached through a login node)\n"
            f"The server listens on {LOCALHOST} only. Ctrl-C stops it.",
            flush=True,
        )

    code = _run_child(command, when_started=announce)
    if code not in (0, 128 + signal.SIGTERM, 128 + getattr(signal, "SIGHUP", 1)):
        print(f"ariel: the Rerun server exited with code {code}", file=sys.stderr)
    return code


def _screenshot(selection: Selection, out: Path, size: tuple[int, int], settle_s: float) -> int:
    """Serve the web viewer on free ports, draw it in a headless browser, save a PNG."""
    import tempfile

    from ariel.recording.store import atomic_write_bytes
    from ariel.recording.viewer._browser import BrowserError, HeadlessChromium, find_chromium

    try:
        chromium = find_chromium()
    except BrowserError as exc:
        raise ViewError(f"--screenshot: {exc}") from None
    web_port = _any_free_port(set())
    grpc = _any_free_port({web_port})
    taken: list[str] = []
    scratch = tempfile.mkdtemp(prefix="ariel-screenshot-")  # the browser profile, the layout
    # The layout of what is shown (a generation's recording, a campaign; a run's is written by
    # `_prepared`) with the side panels collapsed: the picture shows the views.
    if selection.more_layouts:
        from ariel.recording.rerun import write_generation_blueprint

        shared = write_generation_blueprint(Path(scratch) / "generation.rbl", panels=False)
        selection = dataclasses.replace(selection, more_layouts=(shared,))
    elif (selection.run_dir / "campaign.json").is_file():
        from ariel.recording.rerun import write_campaign_blueprint

        layout = write_campaign_blueprint(
            Path(scratch) / "views.rbl", selection.run_dir, panels=False
        )
        selection = dataclasses.replace(selection, blueprint=layout)

    def capture(proc: subprocess.Popen[bytes]) -> None:
        try:
            if not _wait_until_serving(proc, web_port, grpc):
                return
            with HeadlessChromium(Path(scratch), size=size, binary=chromium) as browser:
                browser.open(web_url(web_port, grpc))
                atomic_write_bytes(out, wait_for_drawing(browser, settle_s))
            taken.append(str(out))
        except BrowserError as exc:
            raise ViewError(f"--screenshot: {exc}") from None
        finally:
            _terminate(proc)

    try:
        code = _run_child(web_command(selection, web_port, grpc), when_started=capture)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    if not taken:
        return code or 1
    print(f"wrote {out} ({selection.description} of {selection.run_dir})")
    return 0


def wait_for_drawing(browser: Any, settle_s: float) -> bytes:
    """The viewer page as a PNG once it has drawn: its canvas is shown (the app started), then
    ``settle_s`` seconds for the recordings to stream in, then until two captures a second
    apart agree (or another ``settle_s`` passed)."""
    deadline = time.monotonic() + READY_TIMEOUT_S
    while browser.evaluate(_CANVAS_SHOWN) is not True:
        if time.monotonic() > deadline:
            raise ViewError(f"the web viewer did not start in {READY_TIMEOUT_S:.0f} s")
        time.sleep(0.25)
    time.sleep(settle_s)
    last, deadline = browser.png(), time.monotonic() + settle_s
    while time.monotonic() < deadline:
        time.sleep(1.0)
        now = browser.png()
        if now == last:
            break
        last = now
    return last


# The viewer's canvas is shown once its WebAssembly app runs (the loading text is hidden then).
_CANVAS_SHOWN = "document.getElementById('the_canvas_id')?.className === 'visible'"


def view(
    run_dir: str | Path,
    *,
    best: int | None = None,
    generation: int | None = None,
    eval_id: str | None = None,
    web: bool = False,
    port: int | None = None,
    grpc_port: int | None = None,
    screenshot: str | Path | None = None,
    size: tuple[int, int] = (1600, 900),
    settle_s: float = 10.0,
) -> int:
    """Open the chosen recordings (see `select_recordings`) with the run's blueprint.

    ``web``: serve the web viewer on 127.0.0.1 (``port``, default 9090; its gRPC proxy on
    ``grpc_port``, default 9876; busy defaults fall back to free ports, 0 asks for any) until
    Ctrl-C. Otherwise the native viewer, which needs a display. ``screenshot``: instead,
    draw the web viewer (``size`` pixels) in a headless Chromium, save it as that PNG and stop.
    Returns the exit code; bad input raises `ViewError`.
    """
    selection = select_recordings(run_dir, best=best, generation=generation, eval_id=eval_id)
    if screenshot is not None or web:
        with _prepared(selection, panels=screenshot is None) as shown:
            if screenshot is not None:
                return _screenshot(shown, Path(screenshot), size, settle_s)
            return _serve_web(shown, port, grpc_port)
    if not has_display():
        web_line = _view_line(run_dir, best, generation, eval_id, "--web")
        raise ViewError(
            "no display to open the Rerun viewer on (DISPLAY and WAYLAND_DISPLAY are unset); "
            f"serve it to a browser instead: {web_line}"
        )
    with _prepared(selection) as shown:
        print(f"Rerun viewer: {shown.description} of {shown.run_dir}", flush=True)
        return _run_child(native_command(shown), when_started=None)
