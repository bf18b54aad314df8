"""What the live view of a run shows (`RunSource`), read from the run folder alone.

A generation is shown once its manifest (``manifests/gen-NNNNNN.json``, written after its
tables) is there and its tables are what it lists; until then it is skipped, silently, and a
later poll finds it. Once the run has ended, a generation that still cannot be read (or whose
manifest is missing) is damage: one line (`ariel.recording.viewer._unreadable`), never a
wait for ever. Only the new generation's tables are read (evaluations and bodies, a
MAP-Elites run's archive), never the whole run's. Nothing is written in or beside the folder
and its lock is never taken: a 3D replay made on demand goes to a `tempfile` folder.

Entities (``generation``: the generation timeline; ``sim_time``: the best body's clock):

* ``/fitness/*``, ``/diversity/*`` (`RUN_SERIES`, on ``generation``): as ``run.rrd`` has them;
  ``/morphology``: the population's mean morphology descriptors; ``/qd/*`` (MAP-Elites):
  coverage and QD-scores, as ``load_run(...).generations`` has them.
* ``/run/*``: the same per generation as static bar charts (`run_summary_chunks`) and a
  MAP-Elites run's last archive (`archive_chunks`), seen whatever the timeline; ``/archive``:
  the archive of each generation (on ``generation``, as ``run.rrd`` has it), to scrub.
* ``/progress``: evaluations done and total, evaluations/s and ETA, a text (static) and
  scalars (``/progress/*`` on ``generation``).
* ``/lineage``: every body as a graph node coloured by fitness (bright: better), larger while
  in the population, with directed edges from its parents (`Lineage`, as ``run.rrd`` has
  it); logged whole each generation, at that generation and at ``sim_time`` 0 (so it shows
  on either timeline).
* ``/best``: the best evaluation so far, walking (``/best/world``, its joints ``/best/joints``
  and morphology ``/best/graph``, from its own recording or a replay made on demand) and
  ``/best/info``; cleared (``Clear(recursive=True)``) and logged again when a better one
  appears.
"""

from __future__ import annotations

import contextlib
import math
import os
from datetime import datetime
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.evolution import ExperimentConfig, budget
from ariel.recording.rerun import (
    LINEAGE_ENTITY,
    RUN_SERIES,
    SUMMARY_SERIES,
    Lineage,
    archive_chunks,
    archive_image,
    archive_view,
    generation_summary,
    lineage_view,
    rerun_module,
    robot_view,
    run_summary_chunks,
    summary_bars,
)
from ariel.recording.store import (
    STOPPED,
    Manifest,
    NotARunError,
    Run,
    RunFolder,
    archive_quality_table,
    fitness_unit,
    generation_file,
    holder_gone,
    manifest_entries,
    manifest_file,
    manifests_expected,
    population_after_selection,
    read_file,
    to_pandas,
)
from ariel.recording.viewer._archive_panel import archive_beside
from ariel.recording.viewer._unreadable import (
    UNREADABLE,
    Unreadable,
    check_still_there,
    missing_manifest,
)
from ariel.recording.viewer._watch_body import BestBody

if TYPE_CHECKING:
    import pandas as pd
    import rerun as rr
    from rerun.blueprint import Blueprint, TimeSeriesView

    from ariel.recording.store import JsonObject

__all__ = ["RunSource", "run_blueprint"]

#: run.json statuses of a run that has ended.
FINAL = ("finished", "failed", "interrupted")
QD_ENTITIES = {"coverage": "/qd/coverage", "qd_score": "/qd/qd_score"}
_BODY_COLUMNS = ("generation", "body_id", "parent_ids", "born_generation", "graph", "status")
_EVALUATION_COLUMNS = ["generation", "eval_id", "body_id", "fitness", "status"]


def _read_generation(
    folder: Path, generation: int, config: JsonObject, checked: bool
) -> dict[str, pd.DataFrame]:
    """Generation ``generation``'s tables (``evaluations``, ``bodies``, a MAP-Elites run's
    ``archive``) as DataFrames, checked against its manifest; raises one of `UNREADABLE`
    while it is not complete (no manifest yet, or its files are not what the manifest
    lists), or where it is damaged."""

    columns = {
        "evaluations": _EVALUATION_COLUMNS,
        "bodies": [*_BODY_COLUMNS, "fitness", "selected", *DESCRIPTOR_NAMES],
        "archive": None,
    }
    files = manifest_entries(folder, generation, checked)
    manifest = Manifest(folder, generation + 1, checked, files, config)
    for name, entry in files.items():
        manifest.check_present(name, entry)
    listed = {folder / name for name in files}
    tables = {}
    for table, wanted in columns.items():
        path = generation_file(folder, table, generation)
        if table == "archive" and path not in listed and not (not checked and path.exists()):
            continue
        part = read_file(folder, path, table, manifest=manifest, columns=wanted)
        tables[table] = to_pandas(part)
    return tables


def _total_evaluations(config: JsonObject, brain_only: bool) -> int | None:
    """The evaluations the run will make (`budget`), None where its config cannot say."""
    try:
        return int(budget(ExperimentConfig.from_plain(config), brain_only))
    except Exception:  # a config of another version, a plugin not installed here
        return None


def _seconds(text: object) -> float | None:
    """A run.json time (ISO 8601) as seconds since the epoch; None where it is not one."""
    try:
        return datetime.fromisoformat(str(text)).timestamp()
    except ValueError:
        return None


def _duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours} h {rest // 60:02d} min" if hours else f"{rest // 60} min {rest % 60:02d} s"


class RunSource:
    """A run folder as the live view shows it (the module docstring lists what)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self.info = RunFolder(self.path).read_info()
        self.run = Run(path=self.path, info=self.info)  # maximise, qd_offset: no table read
        self.config = self.run.config
        self.run_id = str(self.info.get("run_id") or self.path.name)
        self.checked = manifests_expected(self.path, self.info)[0]
        self.map_elites = self.config.get("body", {}).get("optimizer") == "map_elites"
        self.shown = 0  # generations logged
        self._rows: dict[int, int] = {}  # generation -> its evaluations (for the rate)
        self._summary: dict[str, list[float]] = {c: [] for c in ("generation", *SUMMARY_SERIES)}
        self.lineage = Lineage(maximise=self.run.maximise)
        self.best = BestBody(self.path, self.run.maximise)
        self._total = _total_evaluations(self.config, bool(self.info.get("brain_only")))
        self._started = False
        self._progress = ""
        self._unreadable = Unreadable(self.path)

    # -- the Source protocol ---------------------------------------------------------------

    def blueprint(self) -> Blueprint:
        name = self.config.get("task", {}).get("fitness")
        unit = fitness_unit(name) if isinstance(name, str) and name else None
        options = self.config.get("body", {}).get("optimizer_options") or {}
        kind = self.map_elites and str(options.get("archive") or "grid")  # as the run's
        return run_blueprint(archive=kind, fitness_unit=unit)

    def poll(self, rec: rr.RecordingStream) -> bool:
        """Log what is new in the folder; True when anything was."""
        try:
            self.info = RunFolder(self.path).read_info()
        except NotARunError:
            check_still_there(self.path)
            return False  # rewritten just now: the next poll sees
        logged = False
        if not self._started:
            self._log_static(rec)
            self._started = logged = True
        before = self.shown
        while self._ready(self.shown):
            try:
                tables = _read_generation(self.path, self.shown, self.config, self.checked)
            except UNREADABLE as exc:  # being written; once the run has ended, damaged
                self._unreadable.meet(self.shown, exc, ended=self._ended())
                break
            self._log_generation(rec, self.shown, tables)
            self.shown += 1
        done = int(self.info.get("generations_done", 0) or 0)
        if self.shown < done and not self._ready(self.shown) and self._ended():
            raise missing_manifest(self.path, self.shown, done)  # else it waits for ever
        if self.shown > before:  # the bar charts once for all the new generations
            rec.send_chunks(run_summary_chunks(self._summary))
            logged = True
        logged = self.best.update(rec, ended=self._ended()) or logged
        return self._log_progress(rec, new=self.shown > before) or logged

    def finished(self) -> bool:
        """The run has ended (a final status, or its process is gone) and every generation it
        finished, its best body and how it ended are logged."""
        status = self.info.get("status")
        ended = self._ended()
        if self.info.get("status") != status:  # it ended since the last poll: one more logs how
            return False
        done = int(self.info.get("generations_done", 0) or 0)
        return ended and self.shown >= done and self.best.settled

    def _ended(self) -> bool:
        """Whether the run has ended. Its process gone while run.json (as last read) says
        running: read again, since a run writes how it ended just before it lets go of its lock
        (a process killed never does)."""
        status = self.info.get("status")
        if status == "running" and holder_gone(self.path):
            with contextlib.suppress(NotARunError):
                self.info = RunFolder(self.path).read_info()
            return True
        return status in FINAL

    def close(self) -> None:
        """Remove the scratch folder of 3D replays."""
        self.best.close()

    # -- generations -----------------------------------------------------------------------

    def _ready(self, generation: int) -> bool:
        if not self.checked:  # a run made before manifests: its run.json counts
            return generation < int(self.info.get("generations_done", 0) or 0)
        return manifest_file(self.path, generation).is_file()

    def _log_static(self, rec: rr.RecordingStream) -> None:

        rr = rerun_module()
        for column, entity in RUN_SERIES.items():
            rec.log(entity, rr.SeriesLines(names=[column.replace("_", " ")]), static=True)
        rec.log("/morphology", rr.SeriesLines(names=list(DESCRIPTOR_NAMES)), static=True)
        for column, entity in QD_ENTITIES.items() if self.map_elites else ():
            rec.log(entity, rr.SeriesLines(names=[column.replace("_", " ")]), static=True)
        rec.log("/progress/evaluations", rr.SeriesLines(names=["done", "total"]), static=True)
        rec.log("/best/info", rr.TextDocument("no finished generation yet"), static=True)

    def _log_generation(
        self, rec: rr.RecordingStream, generation: int, tables: dict[str, pd.DataFrame]
    ) -> None:

        rr = rerun_module()
        bodies, evaluations = tables["bodies"], tables["evaluations"]
        candidates = evaluations["fitness"].tolist() if self.run.brain_only else None
        row, _ = generation_summary(
            generation, bodies.to_dict("records"), self.run.maximise, candidates
        )
        _at(rec, generation)
        for column, entity in RUN_SERIES.items():
            rec.log(entity, rr.Scalars(row[column]))
        population = population_after_selection(bodies)[list(DESCRIPTOR_NAMES)]
        means = population.astype("Float64").mean().to_numpy(dtype=float, na_value=math.nan)
        rec.log("/morphology", rr.Scalars(means))
        for column in self._summary:
            self._summary[column].append(row[column])
        self._rows[generation] = len(evaluations)
        if "archive" in tables:
            self._log_archive(rec, generation, tables["archive"])
        self.lineage.grow(bodies.to_dict("records"), generation)
        _at(rec, generation, sim_time=True)
        rec.log(LINEAGE_ENTITY, *self.lineage.archetypes())
        self.best.offer(evaluations, generation)

    def _log_archive(self, rec: rr.RecordingStream, generation: int, archive: pd.DataFrame) -> None:
        rr = rerun_module()
        shown = SimpleNamespace(archive=archive, config=self.config, info=self.info, path=self.path)
        beside = archive_beside(shown)
        if beside is None:
            return
        grid, dimensions = beside
        named = isinstance(grid, np.ndarray)  # a grid's tensor, its measures named; a CVT's points
        rec.log("/archive", rr.Tensor(grid, dim_names=dimensions) if named else archive_image(grid))
        rec.send_chunks(archive_chunks(grid, dimensions))
        quality = archive_quality_table(archive, self.run.qd_offset, self.run.maximise)
        for column, entity in QD_ENTITIES.items():
            rec.log(entity, rr.Scalars(float(quality[column].iloc[-1])))

    # -- progress --------------------------------------------------------------------------

    def _log_progress(self, rec: rr.RecordingStream, *, new: bool) -> bool:
        """The progress text when a generation or the status changed (its ETA: as of the
        newest generation's end), and its scalars at each new generation."""
        rr = rerun_module()
        done, total = sum(self._rows.values()), self._total
        ended = self._ended()  # a killed run's run.json still says running
        status = str(self.info.get("status", "?"))
        status = STOPPED if status == "running" and ended else status
        rate, eta = self._rate(done)
        parts = [f"**{status}**", f"generation {self.shown} of {self.config.get('generations')}"]
        share = f" of {total:,} ({100 * done / total:.0f} %)" if total else ""
        parts.append(f"evaluations {done:,}{share}")
        if rate:
            parts.append(f"{rate:.3g} evaluations/s")
        if eta is not None and status not in FINAL and not ended:
            parts.append(f"ETA {_duration(eta)} after generation {self.shown - 1}")
        text = f"run {self.run_id}: " + " · ".join(parts)
        if text == self._progress:
            return False
        self._progress = text
        rec.log("/progress", rr.TextDocument(text, media_type="text/markdown"), static=True)
        if new:
            _at(rec, self.shown - 1)
            rec.log("/progress/evaluations", rr.Scalars([done, total or math.nan]))
            rec.log("/progress/evaluations_per_s", rr.Scalars(rate or math.nan))
            rec.log("/progress/eta_s", rr.Scalars(math.nan if eta is None else eta))
        return True

    def _rate(self, done: int) -> tuple[float | None, float | None]:
        """Evaluations per second of the run's current segment (since it started or last
        resumed, or once it has two, since its first generation ended; up to its newest
        manifest), and the seconds left at that rate."""
        info = self.info
        if info.get("status") in FINAL and info.get("wall_seconds"):
            return done / float(info["wall_seconds"]), 0.0
        segments = info.get("segments") or [{}]
        segment = segments[-1] if isinstance(segments[-1], dict) else {}
        started = _seconds(segment.get("started", info.get("created")))
        first = int(segment.get("from_generation", 0) or 0)
        if not self.shown or started is None:
            return None, None
        try:
            last = manifest_file(self.path, self.shown - 1).stat().st_mtime
        except OSError:
            return None, None
        if self.shown - first >= 2:  # from the end of its first generation: the start-up
            with contextlib.suppress(OSError):  # (seconds, before any evaluation) made a
                started = manifest_file(self.path, first).stat().st_mtime  # 5x long ETA
                first += 1
        made = sum(n for g, n in self._rows.items() if g >= first)
        if last <= started or not made:
            return None, None
        rate = made / (last - started)
        return rate, (max(0, self._total - done) / rate if self._total else None)


def _at(rec: rr.RecordingStream, generation: int, *, sim_time: bool = False) -> None:
    """Log what follows at ``generation`` (and at ``sim_time`` 0, to show on that timeline)."""
    rec.reset_time()
    rec.set_time("generation", sequence=generation)
    if sim_time:
        rec.set_time("sim_time", duration=0.0)


def run_blueprint(*, archive: bool | str = False, fitness_unit: str | None = None) -> Blueprint:
    """The live view's layout: the best body walking, its morphology and the lineage, the
    progress (and a MAP-Elites archive) above; its joints and the run's fitness, diversity
    and morphology per generation below (bar charts, seen on any timeline, and curves on the
    ``generation`` timeline). The time panel plays ``sim_time`` in a loop: the body walks."""
    rrb = rerun_module().blueprint
    unit = f" ({fitness_unit})" if fitness_unit else ""

    def curves(origin: str, title: str) -> TimeSeriesView:
        return rrb.TimeSeriesView(name=f"{title} (generation timeline)", origin=origin)

    top = [
        robot_view("best body so far", "/best/world"),  # as `ariel view`'s: 1.5 m from the start
        rrb.Tabs(
            lineage_view(),
            rrb.GraphView(name="best body's morphology", origin="/best/graph"),
        ),
    ]
    if archive:
        top.append(
            rrb.Tabs(
                archive_view(archive, unit),
                archive_view(archive, origin="/archive", name="archive per generation"),
                curves("/qd", "coverage and QD-score"),
            )
        )
    top.append(
        rrb.Vertical(
            rrb.TextDocumentView(name="progress", origin="/progress"),
            rrb.TextDocumentView(name="best so far", origin="/best/info"),
            curves("/progress", "progress"),
        )
    )
    bottom = [
        rrb.TimeSeriesView(name="joint targets (rad)", origin="/best/joints/target"),
        rrb.TimeSeriesView(name="joint angles (rad)", origin="/best/joints/angle"),
        rrb.Tabs(
            summary_bars("best_fitness", unit),
            summary_bars("mean_fitness", unit),
            curves("/fitness", "fitness"),
        ),
        rrb.Tabs(
            summary_bars("diversity", unit),
            summary_bars("distinct_morphologies", unit),
            curves("/diversity", "diversity"),
            curves("/morphology", "mean morphology"),
        ),
    ]
    return rrb.Blueprint(
        rrb.Vertical(rrb.Horizontal(*top), rrb.Horizontal(*bottom), row_shares=[3, 2]),
        rrb.TimePanel(timeline="sim_time", play_state="playing", loop_mode="all"),
        collapse_panels=False,
    )
