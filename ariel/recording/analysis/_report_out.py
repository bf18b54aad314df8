"""`make_report`'s ``out``: a folder of the user's for a report, e.g. of a run on a shared,
read-only disk. As `ariel compare --out` it must be new, empty or an earlier report's: a
report replaces its own files there, and never a file it did not write (``--out ~``)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ariel.errors import ArielError, NotARunError, UnsafePathError
from ariel.recording.store import LOCK_NAME, RunFolder, records_folder_of, written_path
from ariel.utils import ariel_line

if TYPE_CHECKING:
    from ariel.recording.store import Run

__all__ = ["REPORT_FILES", "ReportFolderError", "check_report_folder", "refuse_if_replaced"]

#: What a report writes into its folder (the gallery's thumbnails go to ``thumbnails/``).
REPORT_FILES = (
    "fitness.png",
    "morphology.png",
    "trajectory.png",
    "joints.png",
    "best_body.png",
    "archive.png",
    "lineage.png",
    "gallery.png",
    "gallery.html",
)
_OURS = (*REPORT_FILES, LOCK_NAME)


class ReportFolderError(ArielError, ValueError):
    """A report's ``out`` that cannot take it: one line naming the folder and why."""


def check_report_folder(out: str | os.PathLike[str]) -> Path:
    """``out`` as a report's folder (made later, by the report), or the one-line reason it
    cannot be: a symbolic link (`UnsafePathError`), a place inside a run or campaign folder,
    a file, or a folder holding anything a report does not write (`ReportFolderError`)."""
    folder = Path(out)
    if folder.is_symlink():
        raise UnsafePathError(
            f"refusing to write the report into {str(folder)!r}: it is a symbolic link (to "
            f"{os.readlink(folder)!r}); name the folder itself with --out DIR"
        )
    records = records_folder_of(folder)
    if records is not None:
        raise ReportFolderError(
            f"--out {str(folder)!r} is inside the run or campaign folder {str(records)!r}, "
            "whose records are never written among (a run's own report goes to RUN/report "
            "without --out): name a folder outside it"
        )
    if os.path.lexists(folder) and not folder.is_dir():
        raise ReportFolderError(f"--out {str(folder)!r} is not a folder: name a folder")
    if folder.is_dir():
        foreign = sorted(p.name for p in folder.iterdir() if not _ours(p))
        if foreign:
            more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
            raise ReportFolderError(
                f"--out {str(folder)!r} holds files a report does not write "
                f"({foreign[0]!r}{more}): name a new or empty folder, or an earlier report's"
            )
    return folder


def _ours(path: Path) -> bool:
    """A report's file (or a killed report's temporary of one), its lock or thumbnails (a
    real folder: a link there would take them elsewhere)."""
    if path.name == "thumbnails":
        return path.is_dir() and not path.is_symlink()
    name = written_path(path)
    return path.name in _OURS or (name is not None and name.name in REPORT_FILES)


def refuse_if_replaced(run: Run) -> None:
    """`NotARunError`, one line, when run.json now names another run than the one the report
    drew (``ariel run --overwrite`` into the folder meanwhile): report/ may then hold figures
    of both."""
    try:
        now = RunFolder(run.path).read_info()
    except NotARunError:
        now = {}
    drawn = (run.info.get("run_id"), run.info.get("created"))
    if (now.get("run_id"), now.get("created")) != drawn:
        raise NotARunError(
            f"run folder {str(run.path)!r} was replaced by another run while its report was "
            "drawn (e.g. `ariel run --overwrite` into it): report/ may hold figures of both; "
            f"make the report again: {ariel_line('report', run.path)}"
        )
