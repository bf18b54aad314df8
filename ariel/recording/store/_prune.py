"""`ariel runs --prune`: remove the run folders that hold nothing, failed or interrupted before
their first generation finished.

A folder is prunable when it is a run folder directly under the runs folder (itself, not a
symbolic link to one), its run.json says ``failed`` or ``interrupted``, or ``running`` while
no process holds its lock (`list_runs`' ``stopped (killed?)``), its ``generations_done`` is 0,
and nothing of a finished generation is on disk: no checkpoint, no manifest and no table file
of any generation. A finished run, a run with a finished generation, a running run, a folder
whose run.json cannot be read and one holding anything a run does not write (the user's notes:
`RUN_FOLDER_NAMES`) are never prunable.

`prune_run` checks all of that again while it holds the run's lock (`RunLock`), so a run that
`ariel resume` starts meanwhile is refused instead of deleted, then deletes the folder with
`shutil.rmtree`, which removes a symbolic link inside the folder, never what it points to.
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ariel.errors import ArielError
from ariel.evolution import ERROR_LOG
from ariel.recording.store._files import written_path
from ariel.recording.store._list_runs import IN_PROGRESS, STOPPED, RunSummary, list_runs
from ariel.recording.store._lock import LOCK_NAME, RunLock
from ariel.recording.store._run_folder import RunFolder
from ariel.recording.store._tables import MANIFEST_DIR, TABLES, table_generations

__all__ = ["PruneError", "prunable_runs", "prune_run"]

#: What a run writes at the top of its folder (`ariel run`, `report`, `gallery`, `view`): a
#: folder holding anything else is the user's too (tests/test_first_hour_small.py keeps this
#: in step with a real run's folder).
RUN_FOLDER_NAMES = frozenset(
    {"run.json", LOCK_NAME, "checkpoints", MANIFEST_DIR, ERROR_LOG, *TABLES}
    | {"recordings", "run.rrd", "blueprint.rbl", "generation.rbl", "report", "gallery"}
)
#: What `_why_not` says of a folder holding a file no run writes (listed as left alone).
_NOT_A_RUN_S = "which no run writes"
#: `list_runs` statuses of a run that no process runs and that did not finish.
PRUNABLE_STATUSES = ("failed", "interrupted", STOPPED)


class PruneError(ArielError, OSError):
    """A run folder that `prune_run` refuses or fails to delete (one line)."""


def _finished_work(path: Path) -> str | None:
    """What of a finished generation ``path`` holds (a checkpoint, a manifest, a table
    file), or None."""
    if RunFolder(path).checkpoint.exists():
        return "a checkpoint"
    manifests = path / MANIFEST_DIR
    if manifests.is_dir() and any(manifests.glob("gen-*.json")):
        return "a generation's manifest"
    for table in TABLES:
        if table_generations(path, table):
            return f"a generation's {table} table"
    return None


def _foreign(path: Path) -> str | None:
    """The name of a file or folder in the run folder ``path`` that no run writes (the user's
    notes, a script), or None: the folder is then the user's too, and left alone. A symbolic
    link is not counted: deleting it deletes nothing it points to."""
    for entry in sorted(path.iterdir()):
        if entry.name in RUN_FOLDER_NAMES or entry.is_symlink() or written_path(entry):
            continue
        return entry.name
    return None


def _why_not(summary: Mapping[str, Any]) -> str | None:
    """Why the `list_runs` row ``summary`` is not prunable, or None when it is."""
    path = Path(summary["path"])
    if path.is_symlink():
        return "it is a symbolic link (remove the link yourself)"
    if summary["status"] not in PRUNABLE_STATUSES:
        return f"its status is {summary['status']!r}"
    if summary["generations_done"] != 0:
        return f"run.json says {summary['generations_done']!r} generation(s) finished"
    held = _finished_work(path)
    if held:
        return f"it holds {held}"
    foreign = _foreign(path)
    if foreign is not None:
        return f"it holds {foreign!r}, {_NOT_A_RUN_S} (move it out, or delete the folder yourself)"
    return None


def prunable_runs(root: str | Path) -> tuple[list[RunSummary], list[tuple[str, str]]]:
    """The `list_runs` rows of ``root`` that `prune_run` would remove, and ``(path, why)``
    for each run folder that looks prunable but is left alone: a symbolic link to one, or one
    holding a file that no run writes."""
    found, left_alone = [], []
    for summary in list_runs(root):
        why = _why_not(summary)
        if why is None:
            found.append(summary)
        elif summary["status"] in PRUNABLE_STATUSES and (
            Path(summary["path"]).is_symlink() or _NOT_A_RUN_S in why
        ):
            left_alone.append((summary["path"], why))
    return found, left_alone


def prune_run(root: str | Path, path: str | Path) -> None:
    """Delete the run folder ``path`` directly under ``root`` when it is prunable (checked
    again while holding its lock); `PruneError` (one line) otherwise, or when it cannot be
    deleted."""
    root, path = Path(root), Path(path)
    if path.is_symlink() or not path.is_dir():
        raise PruneError(f"{str(path)!r}: not a folder (a symbolic link is never followed)")
    if path.resolve().parent != root.resolve():
        raise PruneError(f"{str(path)!r} is not a folder directly under {str(root)!r}")
    try:
        with RunLock(path):
            info = RunFolder(path).read_info()
            status = info.get("status")
            summary = {
                "path": str(path),
                # we hold the lock: a "running" (or "created") run.json is a run no process runs
                "status": STOPPED if status in IN_PROGRESS else status,
                "generations_done": info.get("generations_done", 0),
            }
            why = _why_not(summary)
            if why is not None:
                raise PruneError(f"{str(path)!r} is left alone: {why}")
            shutil.rmtree(path)
    except (ArielError, OSError) as exc:
        if isinstance(exc, PruneError):
            raise
        raise PruneError(f"{str(path)!r} is left alone: {exc}") from None
