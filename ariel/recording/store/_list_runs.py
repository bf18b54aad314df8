"""The run folders in a folder, one summary each: `list_runs` (what ``ariel runs`` shows)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TypedDict

from ariel.recording.store._lock import holder_gone
from ariel.recording.store._run_folder import NotARunError, RunFolder, finished_generations
from ariel.utils import path_argument

__all__ = ["IN_PROGRESS", "STOPPED", "UNREADABLE", "RunSummary", "list_runs"]


class RunSummary(TypedDict):
    """One run folder as `list_runs` lists it (run.json's values, checked)."""

    path: str
    run_id: str
    status: str
    generations_done: int
    generations: int | None
    evaluations: int
    best_fitness: float | None
    created: object  # run.json's, as written: an ISO time, or None


#: `list_runs` status of a run whose run.json says "running" but whose lock is free: its
#: process ended without saying so (SIGKILL, power cut, out of memory); `ariel resume` it.
STOPPED = "stopped (killed?)"
#: run.json statuses of a run a process is in ("created": between run.json and its start):
#: `STOPPED` where no process holds the folder's lock.
IN_PROGRESS = ("running", "created")


def list_runs(root: str | Path = Path("data") / "runs") -> list[RunSummary]:
    """One summary per run folder directly under ``root`` (folders that are not runs skipped).

    ``status`` is run.json's, except `STOPPED` for a "running" (or "created") run that no
    process runs.

    Args:
        root: The folder holding run folders; ``data/runs`` by default, relative to the
            current folder (a notebook in analysis/ gives ``"../data/runs"``).

    Returns:
        One dict per run folder, sorted by folder name (``<experiment>-<date>-<time>-s<seed>``
        by default: the newest is ``max(..., key=lambda r: r["created"] or "")``), with keys
        ``path``, ``run_id``, ``status``, ``generations_done``, ``generations``,
        ``evaluations``, ``best_fitness`` (None when none yet) and ``created``. A folder
        whose run.json cannot be read is listed with status `UNREADABLE`. Empty when
        ``root`` is not a folder.
    """

    root = path_argument("root", root, function="list_runs")
    if not root.is_dir():
        return []
    found = []
    for child in sorted(root.iterdir()):
        try:
            if not child.is_dir():
                continue
            info = RunFolder(child).read_info()
            summary = _summary(child, info)
        except OSError:  # a path no file system takes here (over PATH_MAX): listed, not fatal
            summary = _unreadable(child)
        except (NotARunError, TypeError, ValueError, AttributeError):
            if not (child / "run.json").exists():
                continue  # not a run folder at all
            summary = _unreadable(child)  # one bad run.json must not hide the others
        # "created" too: killed between run.json and the run's start, it showed so for ever
        if summary["status"] in IN_PROGRESS and holder_gone(child):
            summary["status"] = STOPPED
        found.append(summary)
    return found


#: `list_runs` status of a folder whose run.json cannot be read or makes no sense.
UNREADABLE = "unreadable"


def _unreadable(child: Path) -> RunSummary:
    return {
        "path": str(child),
        "run_id": child.name,
        "status": UNREADABLE,
        "generations_done": 0,
        "generations": None,
        "evaluations": 0,
        "best_fitness": None,
        "created": None,
    }


def _count(value: object) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise TypeError(f"not a count: {value!r}")
    return value


def _summary(child: Path, info: Mapping[str, object]) -> RunSummary:
    """One row of `list_runs`; `TypeError` / `ValueError` for a run.json that makes no sense."""
    config, run_id = info.get("config", {}), info.get("run_id", child.name)
    status, created = info.get("status", "?"), info.get("created")
    if not isinstance(config, dict) or not isinstance(run_id, str) or not isinstance(status, str):
        raise TypeError("config, run_id or status is not what a run.json holds")
    if created is not None and not isinstance(created, str):  # sorted on: text or None
        raise TypeError("created is not what a run.json holds")
    best = info.get("best_fitness")
    generations = config.get("generations")
    return {
        "path": str(child),
        "run_id": run_id,
        "status": status,
        "generations_done": finished_generations(child, info),
        "generations": _count(generations) if generations is not None else None,
        "evaluations": _count(info.get("evaluations_done", 0)),
        "best_fitness": float(best) if isinstance(best, int | float) else None,
        "created": created,
    }
