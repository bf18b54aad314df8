"""The run's viewer layout (``blueprint.rbl``, `write_blueprint`): an evaluation's robot,
morphology and joints beside the run's fitness and diversity per generation (and a MAP-Elites
archive), and `save_blueprint`, which writes any layout whole (encoded in memory by
`blueprint_bytes`, written by `atomic_write`); `save_layout` writes one a function makes,
encoded once per process.
"""

from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable, Hashable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ariel.recording.rerun._archive import archive_view
from ariel.recording.rerun._chunks import APPLICATION_ID, rerun_module
from ariel.recording.rerun._lineage import lineage_view
from ariel.recording.rerun._views import robot_view, summary_bars
from ariel.recording.store import atomic_write_bytes

if TYPE_CHECKING:
    from rerun.blueprint import Blueprint, BlueprintPart, Container, ContainerLike, View

__all__ = ["blueprint", "blueprint_bytes", "save_blueprint", "save_layout", "write_blueprint"]


def blueprint(
    *,
    panels: bool = True,
    archive: bool | str = False,
    fitness_unit: str | None = None,
    run_curves: bool = True,
) -> Blueprint:
    """The default layout: the 3D replay and the morphology (and, with ``archive``, a MAP-Elites
    run's archive, `ARCHIVE_ENTITY`: True or ``"grid"``, or ``"cvt"``, `archive_view`) above,
    joints and the run's fitness and diversity per generation below; the time panel on
    ``sim_time`` (the evaluation's clock).

    The morphology view shows an evaluation's ``/graph`` and run.rrd's best body of each
    generation (``/best/graph``). Fitness and diversity per generation are static bar charts
    (`run_summary_chunks`, drawn whatever the timeline), one view per series, titled with its
    name and unit (``fitness_unit``, e.g. "m"); with ``run_curves`` each group has a second
    tab of run.rrd's curves on the ``generation`` timeline, and the morphology a tab of its
    lineage graph (`lineage_view`). The 3D camera looks at the start, from 1.5 m away.
    ``panels=False`` collapses the side panels (the blueprint tree, the selection, the time
    panel) for pictures of the views alone.
    """
    rrb = rerun_module().blueprint
    unit = f" ({fitness_unit})" if fitness_unit else ""
    fitness, diversity = _run_views(unit, run_curves)
    top: list[ContainerLike] = [
        robot_view("robot", "/world"),
        rrb.GraphView(name="morphology", origin="/", contents=["/graph/**", "/best/graph/**"]),
    ]
    if run_curves:  # run.rrd's lineage, a tab beside the morphology
        top[1] = rrb.Tabs(top[1], lineage_view(), active_tab=0)
    if archive:  # measure 0 across, measure 1 up
        top.append(archive_view(archive, unit, sliced=True))
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(*top, column_shares=[4, 2, 2] if archive else [3, 1]),
            rrb.Horizontal(
                rrb.TimeSeriesView(name="joint targets (rad)", origin="/joints/target"),
                rrb.TimeSeriesView(name="joint angles (rad)", origin="/joints/angle"),
                fitness,
                diversity,
            ),
            row_shares=[3, 2],
        ),
        *_side_panels(panels),
        collapse_panels=False,
    )


def _side_panels(panels: bool) -> list[BlueprintPart]:
    """The time panel on ``sim_time``; ``panels=False``: it and the side panels collapsed."""
    rrb = rerun_module().blueprint
    time_panel = rrb.TimePanel(timeline="sim_time", **({} if panels else {"state": "collapsed"}))
    return (
        [time_panel]
        if panels
        else [
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            time_panel,
        ]
    )


def _run_views(unit: str, run_curves: bool) -> tuple[ContainerLike, ContainerLike]:
    """The fitness and the diversity per generation: bar charts, one per series, and with
    ``run_curves`` a second tab of run.rrd's curves on the ``generation`` timeline."""
    rrb = rerun_module().blueprint
    hidden = rrb.PlotLegend(visible=False)

    def curve(entity: str, title: str) -> View:
        return rrb.TimeSeriesView(name=title, origin=entity, plot_legend=hidden)

    fitness: Container = rrb.Vertical(
        summary_bars("best_fitness", unit),
        summary_bars("mean_fitness", unit),
        name="fitness per generation",
    )
    diversity: Container = rrb.Vertical(
        summary_bars("diversity", unit),
        summary_bars("distinct_morphologies", unit),
        name="diversity per generation",
    )
    if run_curves:
        fitness = rrb.Tabs(
            fitness,
            rrb.TimeSeriesView(
                name=f"fitness{unit} (generation timeline)",
                origin="/fitness",
                plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftTop),
            ),
            active_tab=0,
        )
        diversity = rrb.Tabs(
            diversity,
            rrb.Vertical(
                curve("/diversity/descriptor_distance", "descriptor distance"),
                curve("/diversity/distinct_morphologies", "distinct bodies"),
                name="diversity (generation timeline)",
            ),
            active_tab=0,
        )
    return fitness, diversity


def write_blueprint(
    path: str | os.PathLike[str],
    *,
    panels: bool = True,
    archive: bool | str = False,
    fitness_unit: str | None = None,
    run_curves: bool = True,
) -> Path:
    """Write the default viewer layout (``blueprint.rbl``, application id ``ariel``).

    Open it with the recordings: ``rerun blueprint.rbl run.rrd recordings/gen-000000/*.rrd``.

    Args:
        path: The blueprint file to write (whole, replacing an existing one), usually
            ``blueprint.rbl`` beside the recordings.
        panels: False collapses the side panels (the blueprint tree, the selection, the time
            panel) for pictures of the views alone.
        archive: Whether to add a view of a MAP-Elites run's archive (`ARCHIVE_ENTITY`):
            False, True or ``"grid"`` (a tensor view), ``"cvt"`` (a 2D view of its points).
        fitness_unit: The fitness's unit (e.g. ``"m"``) for the fitness views' titles; None:
            no unit.
        run_curves: Whether the fitness and diversity views get a second tab of run.rrd's
            curves on the ``generation`` timeline, and the morphology one of its lineage.

    Returns:
        ``path``, as a `Path`.
    """
    return save_layout(
        path,
        blueprint,
        APPLICATION_ID,
        panels=panels,
        archive=archive,
        fitness_unit=fitness_unit,
        run_curves=run_curves,
    )


def save_layout(
    path: str | os.PathLike[str],
    make: Callable[..., Blueprint],
    application_id: str,
    **options: Hashable,
) -> Path:
    """`save_blueprint` of ``make(**options)``, its bytes encoded once per process for each
    ``make``, ``application_id`` and ``options`` (every run writes the same few layouts, and
    Rerun keeps the threads of each blueprint it encodes until the process ends)."""
    data = _layout_bytes(make, application_id, tuple(sorted(options.items())))
    atomic_write_bytes(Path(path), data)
    return Path(path)


@functools.lru_cache(maxsize=64)
def _layout_bytes(
    make: Callable[..., Blueprint], application_id: str, options: tuple[tuple[str, Hashable], ...]
) -> bytes:
    return blueprint_bytes(make(**dict(options)), application_id)


def save_blueprint(path: str | os.PathLike[str], layout: Blueprint, application_id: str) -> Path:
    """Write the blueprint ``layout`` for ``application_id`` whole to ``path``.

    Rerun encodes it in memory (`blueprint_bytes`) and the bytes are written here, under
    `atomic_write`'s temporary, so a failed write (disk full, quota, file too large, I/O error)
    is an `OSError` naming ``path``, and nothing but that temporary (removed) is ever made.
    Rerun's own writer (``Blueprint.save``, a file sink) only logs a failed write, leaves a cut
    file and then waits for ever for the dead sink's flush, deaf to Ctrl-C and SIGTERM.
    """
    path = Path(path)
    data = blueprint_bytes(layout, application_id)
    atomic_write_bytes(path, data)
    return path


#: (application id, $RERUN) -> a carrier recording and its memory sink. Rerun never drops a
#: recording made from Python (its batcher threads live on), so a fresh carrier per blueprint
#: left 2 threads behind each (and the blueprint's own stream 2 more: `save_layout`).
_CARRIERS: dict[tuple[str, str | None], tuple[Any, Any]] = {}
_CARRIERS_LOCK = threading.Lock()


def _carrier(application_id: str) -> tuple[Any, Any]:
    key = (application_id, os.environ.get("RERUN"))
    if key not in _CARRIERS:
        rr = rerun_module()
        carrier = rr.RecordingStream(
            application_id, make_default=False, make_thread_default=False, send_properties=False
        )
        if not rr.is_enabled(carrier):  # the RERUN environment variable switches streams off
            raise RuntimeError("Rerun is switched off (RERUN=off): it encodes no blueprint")
        sink = carrier.memory_recording()
        sink.drain_as_bytes()  # the carrier's store info: not a blueprint's
        _CARRIERS[key] = carrier, sink
    return _CARRIERS[key]


def blueprint_bytes(layout: Blueprint, application_id: str) -> bytes:
    """The bytes of a blueprint file (``.rbl``) of ``layout``, as ``Blueprint.save`` writes one:
    the blueprint's store (application id ``application_id``), then the command that makes it
    the application's active and default layout.

    Public API only: `RecordingStream.send_blueprint` hands the blueprint's messages and that
    command to a carrier recording's sink, here a memory sink. The sink first receives the
    carrier's own store info (an empty recording), drained and dropped before the blueprint is
    sent, so that the bytes hold the blueprint alone (tests/recording/rerun/
    test_write_failures.py checks this against ``Blueprint.save``'s file, should Rerun change).
    One carrier per application id serves the whole process (`_carrier`).
    """
    with _CARRIERS_LOCK:  # one blueprint at a time through a carrier's sink
        carrier, sink = _carrier(application_id)
        carrier.send_blueprint(layout, make_active=True, make_default=True)
        data = sink.drain_as_bytes()
    if not data.startswith(b"RRF"):
        raise RuntimeError(f"Rerun encoded no blueprint file ({len(data)} bytes)")
    return data
