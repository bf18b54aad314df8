"""Crash-safe file writing: whole files under a temporary name, fsynced, then renamed.

A reader (or a resumed run) therefore sees either the previous file or the complete new one,
never a half-written file, whenever the writing process is killed.

Nothing is written through a symbolic link: a run folder comes from anywhere (copied, mailed,
unpacked), and a link planted in it (``report -> ~``, ``run.json -> ~/.bashrc``) must not
make the workbench write outside it. The temporary is created fresh (``O_EXCL | O_NOFOLLOW``,
after removing whatever had its name) and renamed over the final name, which replaces a link
rather than following it; a folder on the way that is a link is refused (`UnsafePathError`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import stat
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from ariel.errors import DamagedRunError, UnsafePathError
from ariel.utils import ariel_line, file_kind, replace_non_finite

__all__ = [
    "STALE_S",
    "UnsafePathError",
    "atomic_write",
    "atomic_write_bytes",
    "atomic_write_json",
    "cannot_write",
    "check_path_names",
    "damaged",
    "format_problem",
    "fsync_folder",
    "json_text",
    "output_file_problem",
    "read_regular_file",
    "records_folder_of",
    "refuse_symlinks",
    "remove_temporaries",
    "user_file",
    "within",
    "written_path",
]

TEMP_SUFFIX = ".tmp"
#: A temporary last written longer ago than this is a killed writer's (a writer holds its
#: own for seconds): removed where another process may be writing beside it.
STALE_S = 600.0
#: A temporary's own part, between the file's name and `TEMP_SUFFIX`: random, so that two
#: processes writing one file (two ``ariel report`` of a run) never share a temporary.
_TOKEN = re.compile(r"\.[0-9a-f]{8}$")
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
#: Added to a temporary's name where earlier versions had Rerun write a blueprint (Rerun
#: writes blueprints only to names ending in ``.rbl``); ariel now writes its bytes itself.
_LEGACY_BLUEPRINT_SUFFIX = ".rbl"


def within(path: str | os.PathLike[str], root: str | os.PathLike[str]) -> bool:
    """``path``, with every link resolved, lies in ``root`` (also resolved), or is it."""
    path, root = Path(os.path.realpath(path)), Path(os.path.realpath(root))
    return path == root or root in path.parents


#: What marks a folder as records (a run's, a campaign's): a file the user names is never
#: written inside one (`output_file_problem`).
_RECORD_MARKS = ("run.json", "campaign.json")


def records_folder_of(path: str | os.PathLike[str]) -> Path | None:
    """The run or campaign folder ``path`` lies in (links resolved), or None."""
    resolved = Path(os.path.realpath(path))
    for folder in (resolved, *resolved.parents):
        if any(os.path.lexists(folder / mark) for mark in _RECORD_MARKS):
            return folder
    return None


def output_file_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path``, a file the user names for a command to write (``--rrd``, ``--video``,
    ``--screenshot``), cannot take it, or None: an empty name or one ending in ``/``, a
    folder, anything but a regular file there (a regular one is replaced: /dev/null was,
    run as root), or a place inside a run or campaign folder, whose records no command
    writes over (run.json replaced by an MP4 is a run lost)."""
    text = os.fspath(path)
    if not text or text.endswith(os.sep):
        return "an empty file name; give a FILE" if not text else f"{text!r} names a folder"
    if os.path.isdir(text):
        return f"{text!r} is a folder; give a FILE (the folder may hold it: DIR/NAME)"
    longest = NAME_MAX - len(_temporary(Path("x")).name) + 1  # its temporary's name, beside it
    size = len(os.fsencode(os.path.basename(text)))
    if size > longest:
        return (
            f"the file name of {text[:60]!r}... has {size} "
            f"bytes; at most {longest} (it is written whole beside itself first, under a name "
            f"{NAME_MAX - longest} bytes longer)"
        )
    try:
        mode = os.stat(text).st_mode
    except OSError:  # not there yet (or a link to nothing): the file is made
        mode = stat.S_IFREG
    if not stat.S_ISREG(mode):
        return f"{text!r} is {file_kind(mode)}, which is never replaced; give a FILE"
    records = records_folder_of(text)
    if records is not None:
        return (
            f"{text!r} is inside the run or campaign folder {str(records)!r}, whose records "
            "are never written over: give a FILE outside it"
        )
    return None


def user_file(path: str | os.PathLike[str]) -> Path:
    """A file the user named outside any run folder (``--lineage FILE``, ``--rrd FILE``,
    ``--screenshot FILE``): its folder with every link resolved (the links on the way are
    theirs: on macOS ``/tmp`` is one), its own name kept (a link there is replaced, never
    written through). Writers check the folder a file goes in for links (`refuse_symlinks`):
    that guards run folders, and refused these."""
    path = Path(path)
    return Path(os.path.realpath(path.parent)) / path.name


def refuse_symlinks(path: str | os.PathLike[str], root: str | os.PathLike[str] | None) -> None:
    """Raise `UnsafePathError` when a folder between ``root`` (itself may be a link: the user
    named it) and ``path`` is a symbolic link; without ``root``, only ``path``'s own folder is
    checked. Folders that do not exist yet are made as real folders by the writer."""
    path = Path(path)
    if root is None:
        parents = [path.parent]
    else:
        root = Path(root)
        try:
            inner = path.parent.relative_to(root)
        except ValueError:
            parents = [path.parent]
        else:
            parents = [root.joinpath(*inner.parts[: i + 1]) for i in range(len(inner.parts))]
    for folder in parents:
        if folder.is_symlink():
            raise UnsafePathError(
                f"refusing to write {str(path)!r}: {str(folder)!r} is a symbolic link (to "
                f"{os.readlink(folder)!r}); a run folder's files are written only inside it: "
                "remove the link"
            )


#: The longest file or folder name (bytes) the usual file systems take (NAME_MAX).
NAME_MAX = 255


#: The longest path a run writes inside its folder (a replay's temporary, numbers at their
#: widest): a folder whose path leaves no room for it is refused before anything is made.
DEEPEST_IN_RUN = (
    "recordings/gen-000000/replays/.b000000000000-i000000000000-c000000000000.rrd.0123abcd.tmp"
)
#: Linux's PATH_MAX, the terminating NUL included.
PATH_MAX = 4096


def check_path_names(path: str | os.PathLike[str]) -> None:
    """Raise ``OSError(ENAMETOOLONG)`` when a name in ``path`` is longer than `NAME_MAX`
    bytes, or when the run folder ``path`` leaves no room within `PATH_MAX` for the deepest
    file a run writes in it (`DEEPEST_IN_RUN`: a path of 4,060 bytes left a half-made run), and
    ``OSError(EILSEQ)`` when ``path`` is not UTF-8 (bytes a file system takes, but Rerun
    writes its recordings only to UTF-8 paths: the run died in its first generation): before
    a new folder's parents are made, so that a refused name leaves none."""
    if any(len(os.fsencode(part)) > NAME_MAX for part in Path(path).parts):
        raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG), os.fspath(path))
    whole = os.fspath(Path(path).absolute())  # the current folder's name counts too
    deepest = os.path.join(whole, DEEPEST_IN_RUN)
    if len(os.fsencode(deepest)) >= PATH_MAX:
        raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG), deepest)
    try:
        whole.encode("utf-8")
    except UnicodeEncodeError:
        raise OSError(
            errno.EILSEQ,
            "not UTF-8 (Rerun writes recordings only to UTF-8 paths): choose a UTF-8 name",
            whole,
        ) from None


_OS_ERROR = re.compile(r"\(os error (\d+)\)")


def _temporary(path: Path) -> Path:
    # Hidden ("." prefix): Parquet dataset readers and globs for gen-*.parquet skip it.
    return path.with_name(f".{path.name}.{secrets.token_hex(4)}{TEMP_SUFFIX}")


def written_path(path: Path) -> Path | None:
    """The file a temporary stands for (`_temporary`'s inverse); None for any other name.

    ``.NAME.TOKEN.tmp`` stands for ``NAME``, and so does ``.NAME.tmp`` (the temporaries of
    versions before the token, left by a killed writer), and ``.NAME.TOKEN.tmp.rbl`` (where
    earlier versions had Rerun write a blueprint, left by a killed or stuck writer)."""
    name = path.name.removesuffix(_LEGACY_BLUEPRINT_SUFFIX)
    if name.startswith(".") and name.endswith(TEMP_SUFFIX) and len(name) > 1 + len(TEMP_SUFFIX):
        written = name[1 : -len(TEMP_SUFFIX)]
        return path.with_name(_TOKEN.sub("", written) if _TOKEN.search(written[1:]) else written)
    return None


def fsync_folder(folder: Path) -> None:
    """Make a rename (or a new file) in ``folder`` last a power cut: fsync the folder."""
    with contextlib.suppress(OSError):  # not every file system lets a directory be opened
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _fresh(temporary: Path) -> None:
    """Create ``temporary`` empty and new: whatever had its name (a killed writer's leftover, or
    a planted link) is removed, not followed, so ``write`` writes into a file of ours."""
    with contextlib.suppress(FileNotFoundError):
        temporary.unlink()
    fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o644)
    os.close(fd)


def atomic_write(
    path: Path,
    write: Callable[[Path], object],
    *,
    fsync: bool = True,
    root: str | os.PathLike[str] | None = None,
) -> None:
    """Call ``write(temporary_path)``, fsync the result and rename it to ``path``.

    ``fsync=False`` skips both fsyncs (the rename still makes the file appear whole to any
    reader and to a killed writer's resume; durability across a power cut is then the
    caller's business, e.g. one ``os.sync()`` for many files). ``root``: the run folder
    ``path`` lies in; a folder between the two that is a symbolic link is refused
    (`UnsafePathError`), as is ``path``'s own folder without ``root``.
    """
    path = Path(path)
    refuse_symlinks(path, root)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = _temporary(path)
    try:
        _fresh(temporary)
        # Absolute: pyarrow and pandas expand a leading "~" (a folder named "~" is not $HOME).
        write(Path(os.path.abspath(temporary)))
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
        fsync_folder(path.parent)


def cannot_write(exc: OSError, path: str | os.PathLike[str] | None = None) -> str:
    """``cannot write 'FILE': REASON``, one line, for a write that failed with ``exc`` (disk
    full, read-only file system, no permission, ...): the file the error names (for a
    temporary, the file it stands for), else ``path``; the reason from its errno."""
    name = exc.filename if exc.filename is not None else path
    if name is None:
        return f"cannot write: {exc.strerror or exc}"
    shown = Path(os.fsdecode(name))
    shown = written_path(shown) or shown
    reason = os.strerror(exc.errno) if exc.errno else (exc.strerror or type(exc).__name__)
    return f"cannot write {str(shown)!r}: {reason}"


def atomic_write_bytes(
    path: Path, data: bytes, *, root: str | os.PathLike[str] | None = None
) -> None:
    atomic_write(path, lambda temporary: temporary.write_bytes(data), root=root)


def json_text(data: object) -> str:
    """Strict JSON of ``data`` (non-finite floats as null: Python's ``NaN`` / ``Infinity``
    tokens are not JSON, and other readers refuse them), indented, ending in a newline."""
    plain = replace_non_finite(data, lambda x: None)
    return json.dumps(plain, indent=2, sort_keys=False, allow_nan=False) + "\n"


def atomic_write_json(
    path: Path, data: object, *, root: str | os.PathLike[str] | None = None
) -> None:
    atomic_write_bytes(path, json_text(data).encode(), root=root)


def remove_temporaries(
    folder: Path, *, older_than_s: float = 0.0, deep: bool = True
) -> Iterator[Path]:
    """Delete leftover temporary files under ``folder`` (a killed writer's); yields each.

    Walks real folders only: a linked folder may lead out of the run folder. ``older_than_s``:
    only those last written longer ago than that (where another process may be writing one:
    a writer holds its temporary for seconds); ``deep`` False: only ``folder``'s own."""
    cutoff = time.time() - older_than_s
    for parent, folders, files in os.walk(folder, followlinks=False):
        folders[:] = (
            []
            if not deep
            else [name for name in folders if not os.path.islink(os.path.join(parent, name))]
        )
        for name in files:
            temporary = Path(parent, name)
            if written_path(temporary) is None:
                continue
            with contextlib.suppress(OSError):
                if older_than_s and temporary.lstat().st_mtime > cutoff:
                    continue
                temporary.unlink()
                yield temporary


def _size(count: int) -> str:
    return f"{count / 2**20:,.0f} MiB" if count % 2**20 == 0 else f"{count:,} bytes"


def read_regular_file(path: str | os.PathLike[str], limit: int) -> bytes:
    """The bytes of the regular file ``path`` (a link to one is followed), at most ``limit``.

    A folder's file comes from anywhere: a FIFO would block a reader for ever, ``/dev/zero``
    (through a link) or a sparse 4 GB file would fill memory. So the file is opened without
    blocking (``O_NONBLOCK``: a FIFO opens at once), and anything but a regular file (``fstat``)
    or a file of more than ``limit`` bytes is a `ValueError` (one line: ``a FIFO, not a
    regular file``, ``N MiB, more than the M MiB ...``). Missing or unreadable: `OSError`, as
    `open` raises it."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise ValueError(f"{file_kind(info.st_mode)}, not a regular file")
    with os.fdopen(fd, "rb") as file:
        data = b"" if info.st_size > limit else file.read(limit + 1)  # it may grow meanwhile
    if info.st_size > limit or len(data) > limit:
        size = max(info.st_size, len(data))
        raise ValueError(f"{size:,} bytes, more than the {_size(limit)} such a file may have")
    return data


def format_problem(what: str, data: object, expected: int) -> str | None:
    """None where ``data``, a folder's JSON file ``what`` (``run.json``, ``checkpoint``) as
    read, is an object whose ``format`` is ``expected`` (a whole number: ``true``, which Python
    takes for 1, is none); else what is wrong: a whole number above it was written by a newer
    ariel (upgrade to open it), anything else is no file of ours."""
    found = data.get("format") if isinstance(data, dict) else None
    if type(found) is int and found == expected:
        return None
    if type(found) is int and found > expected:
        return (
            f"a {what} of format {found}, written by a newer ariel (this one reads format "
            f"{expected}): upgrade ariel to open it"
        )
    return f"not a {what} of format {expected}"


def damaged(run_dir: str | Path, name: str, problem: str) -> DamagedRunError:
    """The one line for a damaged file ``name`` (relative to ``run_dir``) of a run."""
    return DamagedRunError(
        f"run folder {str(run_dir)!r} is damaged: {name} {problem}; restore the folder from a "
        f"copy ({ariel_line('verify', run_dir)} lists every damaged file)"
    )
