"""A new campaign's folder: its default name (`new_campaign_id`, under `DEFAULT_CAMPAIGN_ROOT`)
and the check that a folder may become one (`check_new_folder`), with what to do instead with
a campaign folder that is there already."""

from __future__ import annotations

import datetime as _dt
import os
from pathlib import Path

from ariel.errors import ArielError
from ariel.recording.store import (
    CAMPAIGN_JSON,
    LOCK_NAME,
    RunLock,
    check_path_names,
    load_campaign,
)
from ariel.utils import ariel_line, free_path

__all__ = ["DEFAULT_CAMPAIGN_ROOT", "check_new_folder", "new_campaign_id"]


#: Where a campaign without ``out`` goes (relative to the current directory).
DEFAULT_CAMPAIGN_ROOT = Path("data") / "campaigns"


def new_campaign_id(name: str) -> str:
    """``<name>-<date>-<time>``, with ``-2``, ``-3``, ... where `DEFAULT_CAMPAIGN_ROOT` has that
    folder already (named, not made: `ariel.runs.run_campaign` claims its folder itself)."""
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return free_path(DEFAULT_CAMPAIGN_ROOT, f"{name}-{stamp}").name


def check_new_folder(path: Path, *, locked: bool = False) -> None:
    """``path`` is no folder yet, or an empty one (``locked``: this process holds its lock,
    which it has just made). A folder in use by another campaign run is said so, as a run's."""
    check_path_names(path)
    if path.is_symlink():  # never made or written through: a dangling one would be followed
        raise FileExistsError(
            f"output {str(path)!r} is a symbolic link (to {os.readlink(path)!r}); choose "
            "another --out"
        )
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"output {str(path)!r} is a file; choose another --out")
    if not locked and os.path.lexists(path / LOCK_NAME):
        with RunLock(path):  # RunInUseError, one line, while another process runs it
            pass  # else a stale lock (of a killed process): taken, and gone on release
    if path.exists() and any(p.name != LOCK_NAME or not locked for p in path.iterdir()):
        raise FileExistsError(
            f"campaign folder {str(path)!r} already exists; choose another --out, or "
            f"{_existing_campaign_hint(path)}"
        )


def _existing_campaign_hint(path: Path) -> str:
    """What else to do with the folder ``path`` that is there: compare a finished campaign's
    runs (there is nothing to resume), continue any other campaign, empty another folder."""
    if not (path / CAMPAIGN_JSON).is_file():
        return "empty it (it is not a campaign folder: there is nothing to continue)"
    try:
        campaign = load_campaign(path)
        finished = all(row["status"] == "finished" for row in campaign.status())
        # its own records too: stopped after its last run, a resume writes them
        finished = finished and campaign.info.get("status") == "finished"
    except (ArielError, OSError, ValueError):  # damaged: `campaign resume` says how
        finished = False
    if finished:
        return f"compare its runs (it is finished): {ariel_line('compare', path)}"
    return f"continue it with: {ariel_line('campaign', 'resume', path)}"
