"""`new_folder`: a default output folder named from the time, made at once and exclusively.

Two runs (or campaigns, or comparisons) started in the same second, by a batch script's ``&``
or from two threads, named one folder: the first took it and the second stopped as "in use".
The name is now claimed by making the folder (``mkdir`` fails where it exists, atomically),
and the later one gets ``-2``, ``-3``, ...; `gone_if_empty` removes the folder again where
the work that claimed it stopped before writing anything.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

__all__ = ["free_path", "gone_if_empty", "new_folder"]

#: Tries before giving up: a thousand folders of one name made within one second is a loop.
MAX_TRIES = 1000


def _candidates(parent: Path, name: str) -> Iterator[Path]:
    yield parent / name
    for n in range(2, MAX_TRIES + 1):
        yield parent / f"{name}-{n}"


def free_path(parent: Path, name: str) -> Path:
    """The first of ``parent/name``, ``parent/name-2``, ... that is not there now (named,
    not made: for a name shown before its folder is made).

    Args:
        parent: The folder to name it in.
        name: The name, e.g. ``coevolve_flat-20261128-105112-s1``.

    Returns:
        The path; `FileExistsError` when `MAX_TRIES` are taken.
    """
    for path in _candidates(parent, name):
        if not path.is_symlink() and not path.exists():
            return path
    raise FileExistsError(f"{str(parent / name)!r} and {MAX_TRIES - 1} numbered ones are taken")


def new_folder(parent: Path, name: str) -> Path:
    """``parent/name`` made now, or ``parent/name-2``, ... where that is taken (``parent``
    made first where missing).

    Args:
        parent: The folder to make it in.
        name: The name, e.g. ``coevolve_flat-20261128-105112-s1``.

    Returns:
        The new, empty folder: this call made it, no other; `FileExistsError` when
        `MAX_TRIES` are taken.
    """
    if (parent.exists() or parent.is_symlink()) and not parent.is_dir():
        raise FileExistsError(
            f"{str(parent)!r} is not a folder: new folders are made in it; move it away or "
            "give --out"
        )
    parent.mkdir(parents=True, exist_ok=True)
    for path in _candidates(parent, name):
        try:
            path.mkdir()
        except FileExistsError:
            continue
        return path
    raise FileExistsError(f"{str(parent / name)!r} and {MAX_TRIES - 1} numbered ones are taken")


@contextlib.contextmanager
def gone_if_empty(path: Path | None) -> Iterator[None]:
    """Remove the folder ``path`` (a `new_folder`) after the block if it is still empty: the
    work that claimed it refused or stopped before writing anything. None: nothing.

    Args:
        path: The folder, or None.

    Returns:
        A context manager (a ``with`` block).
    """
    try:
        yield
    finally:
        if path is not None:
            with contextlib.suppress(OSError):  # not empty (the work's records), or gone
                path.rmdir()
