"""Crash-safe file writing: whole files under a temporary name, fsynced, then renamed.

A reader (or a resumed run) therefore sees either the previous file or the complete new one,
never a half-written file, whenever the writing process is killed.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "atomic_write",
    "atomic_write_bytes",
    "atomic_write_json",
    "remove_temporaries",
    "require_free_space",
    "written_path",
]

TEMP_SUFFIX = ".tmp"
_OS_ERROR = re.compile(r"\(os error (\d+)\)")


def _temporary(path: Path) -> Path:
    # Hidden ("." prefix): Parquet dataset readers and globs for gen-*.parquet skip it.
    return path.with_name(f".{path.name}{TEMP_SUFFIX}")


def written_path(path: Path) -> Path | None:
    """The file a temporary stands for (`_temporary`'s inverse); None for any other name."""
    name = path.name
    if name.startswith(".") and name.endswith(TEMP_SUFFIX) and len(name) > 1 + len(TEMP_SUFFIX):
        return path.with_name(name[1 : -len(TEMP_SUFFIX)])
    return None


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system lets a directory be opened
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def atomic_write(path: Path, write: Callable[[Path], Any], *, fsync: bool = True) -> None:
    """Call ``write(temporary_path)``, fsync the result and rename it to ``path``.

    ``fsync=False`` skips both fsyncs (the rename still makes the file appear whole to any
    reader and to a killed writer's resume; durability across a power cut is then the
    caller's business, e.g. one ``os.sync()`` for many files).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = _temporary(path)
    try:
        write(temporary)
        if fsync:
            with open(temporary, "rb+") as file:
                os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            temporary.unlink()
        if isinstance(exc, OSError) and exc.filename is None:
            exc.filename = str(path)  # e.g. pyarrow's errors name no file: say which one
        found = _OS_ERROR.search(str(exc)) if isinstance(exc, RuntimeError) else None
        if found:  # Rerun's writers report a failed write as RuntimeError("... (os error 28)")
            number = int(found.group(1))
            raise OSError(number, os.strerror(number), str(path)) from exc
        raise
    if fsync:
        _fsync_dir(path.parent)


def require_free_space(folder: Path, needed: int) -> None:
    """Raise ``OSError(ENOSPC)`` when ``folder``'s file system has less than ``needed`` bytes
    free, for writers that report a full disk only in a log (Rerun's blueprint writer)."""
    try:
        stats = os.statvfs(folder)
    except (OSError, AttributeError):  # unknown: let the write itself find out
        return
    if stats.f_bavail * stats.f_frsize < needed:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(folder))


def atomic_write_bytes(path: Path, data: bytes) -> None:
    atomic_write(path, lambda temporary: temporary.write_bytes(data))


def atomic_write_json(path: Path, data: Any) -> None:
    text = json.dumps(data, indent=2, sort_keys=False, allow_nan=True) + "\n"
    atomic_write_bytes(path, text.encode())


def remove_temporaries(folder: Path) -> Iterator[Path]:
    """Delete leftover temporary files under ``folder`` (a killed writer's); yields each."""
    for temporary in Path(folder).rglob(f".*{TEMP_SUFFIX}"):
        with contextlib.suppress(OSError):
            temporary.unlink()
            yield temporary
