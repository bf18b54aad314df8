"""`CampaignSource`: what ``ariel watch CAMPAIGN_DIR`` shows of a campaign, read as it runs.

It logs, reading only the campaign folder (never writing there, never taking a lock):

* every run's best-so-far fitness on the ``evaluations`` timeline at
  ``/condition/<name>/seed/<n>``, as ``campaign.rrd`` has it (`curve_chunks`), one generation
  at a time as each becomes complete;
* ``/status``: a table of condition x seed (status, generations done / total, evaluations,
  best fitness so far) and each condition's best body, a Markdown `TextDocument`, sent again
  when it changes;
* ``/best/<condition>/graph``: the morphology of each condition's best body so far (from the
  bodies table's ``graph`` column, drawn as run.rrd draws ``/best/graph``), replaced when a
  better one appears.

A generation counts once its manifest is complete and its tables match it, read as `RunSource`
reads a run: a half-written one is skipped silently until a later poll finds it whole. Runs
that appear later (a campaign still making its runs, or resumed) are picked up; each poll
sends only what is new, and what is kept between polls is a few numbers per run, never a
table.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.rerun import (
    campaign_views,
    condition_colours,
    curve_chunks,
    graph_archetypes,
    rerun_module,
    static_chunk,
)
from ariel.recording.store import (
    CAMPAIGN_JSON,
    STOPPED,
    NotARunError,
    RunFolder,
    best_so_far,
    fitness_maximise,
    fitness_unit,
    holder_gone,
    manifest_file,
    manifests_expected,
    read_campaign_info,
    terminal_text,
)
from ariel.recording.viewer._unreadable import UNREADABLE, check_still_there
from ariel.recording.viewer._watch_run import FINAL, _read_generation

if TYPE_CHECKING:
    import pandas as pd
    import rerun as rr
    from rerun.blueprint import Blueprint
    from rerun.chunk import Chunk

    from ariel.recording.store import JsonObject

__all__ = ["CampaignSource"]

STATUS_ENTITY = "/status"


@dataclass
class _Run:
    """What the watcher keeps of one run between polls: a few numbers, no table."""

    condition: str
    seed: int
    path: Path
    total: object  # the config's generations
    status: str = "not started"
    generations: int = 0  # complete generations logged
    evaluations: int = 0  # evaluations counted in them
    best: float = -math.inf  # best fitness so far, oriented (sign x fitness)
    sign: float = 1.0  # 1: fitness maximised, -1: minimised
    styled: bool = False  # the curve's style was sent
    stat: tuple[int, int, int] | None = None  # run.json's (mtime, size, inode) when last read
    info: Any = None  # run.json when last read
    checked: bool = True  # its generations have manifests (all but runs made before them)
    damaged: str = ""  # its next generation cannot be read though the run has ended

    @property
    def best_fitness(self) -> float:
        return self.sign * self.best if math.isfinite(self.best) else math.nan


@dataclass
class _Best:
    """A condition's best body so far."""

    oriented: float
    body_id: str
    seed: int
    generation: int
    fitness: float


class CampaignSource:
    """A campaign folder, watched: see the module's docstring.

    Args:
        path: The campaign folder.

    Raises:
        NotACampaignError: When ``path`` has no readable ``campaign.json``.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._info = read_campaign_info(self.path)
        self._info_stat = _stat(self.path / CAMPAIGN_JSON)
        self._conditions = [str(c["name"]) for c in self._info.get("conditions", [])]
        self._colours = condition_colours(self._conditions)
        self._runs: dict[tuple[str, int], _Run] = {}
        self._best: dict[str, _Best] = {}
        self._status_sent = ""
        self._finished = False

    # --- the layout -------------------------------------------------------------------------

    def blueprint(self) -> Blueprint:
        """Every run's curve and the status table above, one curve view per condition, then
        each condition's best body."""
        rrb = rerun_module().blueprint
        unit, maximise = self._fitness()
        every, views = campaign_views(self._conditions, fitness_unit=unit, maximise=maximise)
        status = rrb.TextDocumentView(name="status: condition x seed", origin=STATUS_ENTITY)
        bodies = [
            rrb.GraphView(name=f"{name}: best body so far", origin=f"/best/{name}")
            for name in self._conditions
        ]
        return rrb.Blueprint(
            rrb.Vertical(
                rrb.Horizontal(every, status, column_shares=[3, 2]),
                rrb.Grid(*views),
                rrb.Grid(*bodies),
                row_shares=[3, 2, 2],
            ),
            collapse_panels=False,
        )

    def _fitness(self) -> tuple[str | None, bool]:
        """The fitness function's unit and direction, from the first run (its run.json where
        made, else its config in campaign.json)."""
        for entry in self._info.get("runs", []):
            name = entry.get("config", {}).get("task", {}).get("fitness")
            unit = fitness_unit(name) if isinstance(name, str) and name else None
            try:
                info = RunFolder(self.path / entry["path"]).read_info()
            except NotARunError:
                info = {"config": entry.get("config", {})}
            try:
                return unit, fitness_maximise(info)
            except Exception:  # the fitness function is not installed here
                return unit, True
        return None, True

    # --- polling -----------------------------------------------------------------------------

    def poll(self, rec: rr.RecordingStream) -> bool:
        """Log to ``rec`` what is new in the campaign folder since the last poll; True when
        anything was logged."""
        check_still_there(self.path)
        ended = self._campaign_ended()  # first: whatever it says, all was written before
        chunks: list[Chunk] = []
        for entry in self._info.get("runs", []):
            key = (str(entry["condition"]), int(entry["seed"]))
            run = self._runs.get(key)
            if run is None:
                total = entry.get("config", {}).get("generations")
                run = self._runs[key] = _Run(key[0], key[1], self.path / entry["path"], total)
            chunks += self._poll_run(run)
        status = self._status_text()
        if status != self._status_sent:
            rr = rerun_module()
            text = rr.TextDocument(status, media_type=rr.MediaType.MARKDOWN)
            chunks.append(static_chunk(STATUS_ENTITY, text))
            self._status_sent = status
        if chunks:
            rec.send_chunks(chunks)
        self._finished = ended
        return bool(chunks)

    def finished(self) -> bool:
        """The campaign has ended (campaign.json says how, or its process is gone) and the
        last poll logged everything its runs wrote."""
        return self._finished

    def _campaign_ended(self) -> bool:
        """Re-read campaign.json where it changed (runs may be added); whether the campaign
        has ended."""
        stat = _stat(self.path / CAMPAIGN_JSON)
        if stat != self._info_stat:
            with contextlib.suppress(NotARunError):  # damaged: the last one read stands
                self._info = read_campaign_info(self.path)
                self._info_stat = stat
        status = self._info.get("status")
        return status in FINAL or holder_gone(self.path)

    def _read_info(self, run: _Run) -> None:
        """The run's status from its run.json (read again only when it changed)."""
        stat = _stat(run.path / "run.json")
        if stat is None:
            run.status, run.info, run.stat = "not started", None, None
            return
        if stat != run.stat:
            try:
                run.info, run.stat = RunFolder(run.path).read_info(), stat
            except NotARunError:
                run.status = "damaged" if run.info is None else run.status
                return
            run.sign = 1.0 if _maximise(run.info) else -1.0
            run.checked = manifests_expected(run.path, run.info)[0]
        run.status = str(run.info.get("status", "?"))
        if run.status in ("running", "created") and holder_gone(run.path):
            with contextlib.suppress(NotARunError):  # it may have just ended, saying how
                run.info = RunFolder(run.path).read_info()
            run.stat = _stat(run.path / "run.json")
            status = str(run.info.get("status", "?"))
            run.status = status if status in FINAL else STOPPED

    def _poll_run(self, run: _Run) -> list[Chunk]:
        """The chunks of the run's generations completed since the last poll."""
        self._read_info(run)
        if run.info is None:
            return []
        chunks: list[Chunk] = []
        run.damaged = ""
        while self._ready(run):
            config = run.info.get("config")
            try:
                tables = _read_generation(run.path, run.generations, config, run.checked)
            except UNREADABLE:  # being written; a run that has ended: damaged, said in its row
                if run.status in (*FINAL, STOPPED):
                    run.damaged = f"generation {run.generations} damaged"
                break
            chunks += self._curve(run, tables["evaluations"])
            chunks += self._best_body(run, tables["bodies"], run.generations)
            run.generations += 1
        return chunks

    @staticmethod
    def _ready(run: _Run) -> bool:
        """Whether the run's next generation may be complete: its manifest is there (a run
        made before manifests: run.json counts it finished), as `RunSource` reads a run."""
        if not run.checked:
            return run.generations < int(run.info.get("generations_done", 0) or 0)
        return manifest_file(run.path, run.generations).is_file()

    def _curve(self, run: _Run, evaluations: pd.DataFrame) -> list[Chunk]:
        """The run's best-so-far curve over one more generation's ``evaluations``."""
        x, best = best_so_far(evaluations, run.sign > 0)
        oriented = np.where(np.isfinite(best), run.sign * best, -np.inf)
        oriented = np.maximum.accumulate(np.maximum(oriented, run.best)) if len(x) else oriented
        if len(x):
            run.best = float(oriented[-1])
        best = np.where(np.isfinite(oriented), run.sign * oriented, np.nan)
        colour = self._colours.get(run.condition, (127, 127, 127))
        x = x + run.evaluations
        run.evaluations += len(x)
        chunks = curve_chunks(run.condition, run.seed, x, best, colour, style=not run.styled)
        run.styled = run.styled or bool(chunks)
        return chunks

    def _best_body(self, run: _Run, bodies: pd.DataFrame, generation: int) -> list[Chunk]:
        """The condition's best body's graph, where this generation has a better one."""
        fitness = bodies["fitness"].to_numpy(dtype=np.float64) if len(bodies) else np.zeros(0)
        oriented = np.where(np.isfinite(fitness), run.sign * fitness, -np.inf)
        if not len(oriented) or not np.isfinite(oriented.max()):
            return []
        row = int(np.argmax(oriented))
        held = self._best.get(run.condition)
        if held is not None and held.oriented >= oriented[row]:
            return []
        body = bodies.iloc[row]
        self._best[run.condition] = _Best(
            float(oriented[row]), str(body["body_id"]), run.seed, generation, float(fitness[row])
        )
        graph = body.get("graph")
        try:
            archetypes = graph_archetypes(graph) if isinstance(graph, str) and graph else []
        except (ValueError, KeyError, TypeError, AttributeError):  # not a robot graph
            archetypes = []
        return [static_chunk(f"/best/{run.condition}/graph", *archetypes)] if archetypes else []

    def _status_text(self) -> str:
        """The status table (Markdown): one row per run, then each condition's best body."""

        def cell(value: object) -> str:
            return terminal_text(value).replace("|", "\\|")

        lines = [
            "| condition | seed | status | generations | evaluations | best |",
            "|---|---:|---|---:|---:|---:|",
        ]
        for run in self._runs.values():
            total = run.total if isinstance(run.total, int) else "?"
            best = f"{run.best_fitness:.6g}" if math.isfinite(run.best_fitness) else "-"
            status = f"{run.status} ({run.damaged})" if run.damaged else run.status
            lines.append(
                f"| {cell(run.condition)} | {run.seed} | {cell(status)} | "
                f"{run.generations}/{total} | {run.evaluations} | {best} |"
            )
        if self._best:
            lines += ["", "| condition | best body | seed | generation | fitness |"]
            lines.append("|---|---|---:|---:|---:|")
            for name in self._conditions:
                best_body = self._best.get(name)
                if best_body is None:
                    continue
                lines.append(
                    f"| {cell(name)} | {cell(best_body.body_id)} | {best_body.seed} | "
                    f"{best_body.generation} | {best_body.fitness:.6g} |"
                )
        return "\n".join(lines)


def _maximise(info: JsonObject) -> bool:
    """Whether the run's fitness is maximised (run.json's ``maximise``, else its fitness
    function's; True where neither tells)."""
    try:
        return fitness_maximise(info)
    except Exception:  # an old run whose fitness function is not installed here
        return True


def _stat(path: Path) -> tuple[int, int, int] | None:
    """(mtime, size, inode) of ``path``: a file replaced whole (renamed over) changes it."""
    try:
        info = path.stat()
    except OSError:
        return None
    return info.st_mtime_ns, info.st_size, info.st_ino
