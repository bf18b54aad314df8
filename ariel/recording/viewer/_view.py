"""`ariel view`: open a run's Rerun recordings in the viewer, native or served to a browser.

The viewer is the ``rerun`` binary of rerun-sdk, started as a child process in its own
session: whatever ends this command (its own end, Ctrl-C, SIGTERM, SIGHUP when an SSH session
drops) terminates the child's process group, and on Linux the child also gets SIGTERM if this
process is killed outright (``PR_SET_PDEATHSIG``). ``--web`` binds to 127.0.0.1 only, never
opens a browser, and prints the SSH tunnel that reaches it from another machine.

What is opened is chosen in `ariel.recording.viewer._select`, the child process is run by
`ariel.recording.viewer._child` and the web viewer served by `ariel.recording.viewer._web`;
this module prepares the recordings (`_prepared`) and opens them (`view`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ariel.errors import ViewError
from ariel.recording.rerun import (
    archive_kind,
    generation_summary,
    write_blueprint,
    write_view_recording,
)
from ariel.recording.store import fitness_unit, load_run, recording_path
from ariel.recording.viewer._archive_panel import archive_beside as _archive_beside
from ariel.recording.viewer._child import (
    Stopped as Stopped,
    ViewerStopped as ViewerStopped,
    _run_child,
    die_with_parent as die_with_parent,
    raise_stopped as raise_stopped,
    rerun_binary,
    stop_on_signals as stop_on_signals,
)
from ariel.recording.viewer._select import (
    RUN_RECORDING,
    Selection,
    _view_line,
    best_evaluations,
    select_recordings,
)
from ariel.recording.viewer._web import (
    DEFAULT_GRPC_PORT,
    DEFAULT_WEB_PORT,
    LOCALHOST as LOCALHOST,
    _screenshot,
    _serve_web,
    tunnel_command as tunnel_command,
    web_url as web_url,
)
from ariel.utils import has_display, no_display_why

if TYPE_CHECKING:
    from ariel.recording.store import Run

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


def _run_series(run: Run) -> pd.DataFrame:
    """Per generation: fitness and diversity of the population, as run.rrd has them."""
    bodies, evaluations = run.bodies, run.evaluations
    fitness: dict[object, list[float]] = (
        {g: list(v) for g, v in evaluations.groupby("generation")["fitness"]}
        if run.brain_only and len(evaluations)
        else {}
    )

    def candidates(g: object) -> list[float] | None:  # a brain-only run's: as report draws
        return fitness.get(g, []) if run.brain_only else None

    rows = [
        generation_summary(int(g), group.to_dict("records"), run.maximise, candidates(g))[0]
        for g, group in (bodies.groupby("generation") if len(bodies) else [])
    ]
    return pd.DataFrame(rows) if rows else pd.DataFrame({"generation": []})


def _graph_of(run: Run, eval_id: str) -> str | None:
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


def _fitness_unit(run: Run) -> str | None:
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
        try:
            yield selection
        finally:
            if selection.scratch is not None:
                shutil.rmtree(selection.scratch, ignore_errors=True)
        return
    scratch = Path(tempfile.mkdtemp(prefix="ariel-view-"))
    try:
        run = load_run(selection.run_dir)
        beside = _archive_beside(run)
        grid, dimensions = beside if beside is not None else (None, None)
        generations = _run_series(run)
        sources = (selection.overview,) if selection.overview else selection.recordings
        recordings = tuple(
            _view_copy(
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


def _view_copy(path: Path, recording: Path, *args: object, **kwargs: object) -> Path:
    """`write_view_recording`, where a recording Rerun cannot read (damaged after it was
    checked, or in a way the check does not see) is one line naming it, not a traceback."""
    try:
        return write_view_recording(path, recording, *args, **kwargs)  # type: ignore[arg-type]
    except RuntimeError as exc:  # Rerun's reader fails with RuntimeError
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise ViewError(
            f"{str(recording)!r} cannot be read by Rerun ({reason}); restore it from a copy"
        ) from None


def native_command(selection: Selection) -> list[str]:
    return [str(rerun_binary()), *map(str, selection.files)]


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
            f"no display to open the Rerun viewer on ({no_display_why()}); "
            f"serve it to a browser instead: {web_line}"
        )
    with _prepared(selection) as shown:
        print(f"Rerun viewer: {shown.description} of {shown.run_dir}", flush=True)
        return _run_child(native_command(shown), when_started=None)
