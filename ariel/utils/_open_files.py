"""How many files this process may open (``ulimit -n``), raised where it may be: a campaign
holds a lock file per run, a pool or cluster pipes and sockets per worker, and Rerun's own
import aborts the process (a Rust panic, 170 lines) below about 26."""

from __future__ import annotations

import contextlib

try:
    import resource
except ImportError:  # pragma: no cover - not POSIX
    resource = None  # type: ignore[assignment]

__all__ = ["MIN_OPEN_FILES", "open_files_short"]

#: What any ariel command may need open at once: its imports (Rerun's runtime), a run's
#: records, its lock.
MIN_OPEN_FILES = 64


def open_files_short(needed: int) -> int | None:
    """None when this process may open ``needed`` files at once, after raising the soft limit
    towards the hard one where it is lower (twice ``needed`` where the hard limit allows, for
    what the estimate misses); else the most it may open (``ulimit -n`` can reach no more)."""
    if resource is None:  # pragma: no cover - not POSIX
        return None
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY or soft >= needed:
        return None
    if hard == resource.RLIM_INFINITY or hard >= needed:
        wanted = 2 * needed if hard == resource.RLIM_INFINITY else min(hard, 2 * needed)
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
            return None
    return soft if hard == resource.RLIM_INFINITY else max(soft, hard)
