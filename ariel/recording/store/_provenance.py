"""What software made (and resumed) a run, for run.json: the installed versions of what
decides results (`software_versions`), the git commit of the ariel checkout (`git_commit`), and
the ``segments`` entry of each process that ran it (`software_segment`)."""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import platform
import subprocess
from collections.abc import Mapping
from pathlib import Path

__all__ = [
    "DECISIVE",
    "git_commit",
    "now",
    "software_segment",
    "software_versions",
    "version_differences",
]

#: The packages whose versions decide a run's numbers (a replay or resume with others may
#: give other ones; torch: the NDE decodes genotypes with it).
DECISIVE = ("mujoco", "numpy", "torch", "ariel")

_VERSIONED = ("ariel", "mujoco", "numpy", "torch", "cma", "pyarrow", "pandas", "rerun-sdk")


def now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def software_versions() -> dict[str, str | None]:
    """Installed versions of what decides results (read from metadata; nothing imported)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def software_segment(kind: str, *, generation: object = 0) -> dict[str, object]:
    """One entry of run.json's ``segments``: who ran the run from ``generation`` on."""
    return {
        "kind": kind,
        "from_generation": generation,
        "started": now(),
        "versions": software_versions(),
        "git_commit": git_commit(),
    }


def git_commit() -> str | None:
    """The commit of the ariel source checkout, when running from one (else None)."""
    source = Path(__file__).resolve().parents[3]  # ariel/recording/store/ -> the checkout
    if not (source / ".git").exists():
        return None
    # --no-optional-locks: `status` would otherwise take .git/index.lock to refresh the index,
    # a write outside the run folder that can fail the user's own git command meanwhile.
    git = ["git", "--no-optional-locks", "-C", str(source)]
    try:
        out = subprocess.run(
            [*git, "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
        dirty = subprocess.run(
            [*git, "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def version_differences(
    info: Mapping[str, object], generation: int | None = None
) -> dict[str, tuple[object, object]]:
    """``{package: (recorded, here)}`` for the versions that decide a run's numbers
    (`DECISIVE`, and the ariel checkout's ``git_commit``) where the software that ran
    ``generation`` (run.json ``info``: the last of its ``segments``, one per run or resume,
    that started at or before it; None: the last of all; else the run's own) differs from
    this. A replay says them beside a fitness that differs; a resume notes them."""
    versions, commit = info.get("versions") or {}, info.get("git_commit")
    segments = info.get("segments")
    for segment in segments if isinstance(segments, list) else []:
        start = segment.get("from_generation") if isinstance(segment, dict) else None
        if isinstance(start, int) and (generation is None or start <= generation):
            versions, commit = segment.get("versions") or {}, segment.get("git_commit")
    recorded = versions if isinstance(versions, dict) else {}
    here = software_versions()
    differences: dict[str, tuple[object, object]] = {
        name: (recorded.get(name), here.get(name))
        for name in DECISIVE
        if name in recorded and recorded.get(name) != here.get(name)
    }
    now_commit = git_commit()
    if now_commit and commit != now_commit:
        # None: an ariel that recorded no commit (not run from a checkout, or older than
        # commits in run.json): which it was is unknown, and its version number says nothing.
        differences["git_commit"] = (commit or "not recorded", now_commit)
    return differences
