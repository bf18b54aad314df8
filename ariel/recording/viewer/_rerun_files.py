"""Whether a file is a Rerun file fit to hand the viewer (`rerun_file_problem`), and a one-line
refusal naming it and what to do where it is not (`check_rerun_files`).

A damaged file (cut short, emptied, overwritten) otherwise crashes `write_view_recording`
with Rerun's traceback, or is served without a word and shows nothing. A file's own Rerun
header says little: a truncated ``.rrd`` starts as a whole one does (``RRF2``), so the file
is opened with `rerun.chunk.RrdReader`, which reads the footer's manifest of the stores (a
few kB whatever the size; a file without one, from an older rerun-sdk or cut short, is
scanned frame by frame, skipping payloads). An evaluation's recording, small, is decoded
whole as well: a file whose middle is overwritten has a sound footer.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable
from pathlib import Path

from rerun.chunk import Chunk, RrdReader

from ariel.errors import ViewError

__all__ = ["check_rerun_files", "recording_chunks", "recording_problem", "rerun_file_problem"]

#: Files whose recording id is not their stem (an evaluation's recording's is its eval id).
_NAMED_OTHERWISE = ("run.rrd", "evaluations.rrd", "campaign.rrd")


def _reason(exc: BaseException, path: Path) -> str:
    """Rerun's error as a short reason: its first line, without the path it repeats."""
    text = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    for prefix in (f"Failed to read RRD file at {path}: ", "Failed to decode frame: "):
        text = text.removeprefix(prefix)
    return text[:200]


def _read(
    path: Path, *, layout: bool, recording_id: str | None, decode: bool
) -> tuple[str | None, list[Chunk]]:
    """`rerun_file_problem`'s answer for ``path``, and its first store's chunks where
    ``decode`` read them (else none)."""
    try:
        with path.open("rb") as file:
            head = file.read(4)
    except OSError as exc:
        return f"cannot be read: {exc.strerror or type(exc).__name__}", []
    if not head.startswith(b"RRF"):
        return "is not a Rerun file (it does not start with Rerun's RRF header)", []
    chunks: list[Chunk] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            reader = RrdReader(path)
            stores = reader.blueprints() if layout else reader.recordings()
            if stores and decode:
                chunks = reader.stream(store=stores[0]).to_chunks()
        except Exception as exc:  # Rerun says RuntimeError; any failure to read is damage
            return f"is not a readable Rerun file ({_reason(exc, path)})", []
    if not stores:
        return f"holds no {'layout' if layout else 'recording'}", []
    found = stores[0].recording_id
    if recording_id is not None and found != recording_id:
        return f"holds recording {found!r} where {recording_id!r} belongs (another's file)", []
    return None, chunks


def rerun_file_problem(
    path: str | os.PathLike[str],
    *,
    layout: bool = False,
    recording_id: str | None = None,
    decode: bool = False,
) -> str | None:
    """What is wrong with the Rerun file at ``path`` (a recording; ``layout``: a blueprint),
    as a predicate ("is not a Rerun file (...)"); None when nothing is. ``recording_id``:
    the id its recording must have. ``decode``: read every chunk too (for small files).
    Rerun's warnings (a file without a footer) are kept quiet: what matters is said here.
    A file found sound is not read again while it stays as it was (`_SOUND`): a view checks
    the best evaluation's recording while choosing it and again before opening it."""
    path = Path(path)
    try:
        info = path.stat()
    except OSError:
        info = None
    key = None
    if info is not None:
        identity = (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns)
        key = (str(path.absolute()), *identity, layout, recording_id)
    if key is not None and key in _SOUND and (_SOUND[key] or not decode):
        return None
    problem = _read(path, layout=layout, recording_id=recording_id, decode=decode)[0]
    if problem is None and key is not None:
        if len(_SOUND) >= _SOUND_MAX:
            _SOUND.clear()
        _SOUND[key] = decode or _SOUND.get(key, False)
    return problem


#: Files found sound in this process, by path, identity, size, time and how they were read
#: (value: decoded whole); a changed file has another key and is read again.
_SOUND: dict[tuple[object, ...], bool] = {}
_SOUND_MAX = 4096


def recording_problem(path: str | os.PathLike[str]) -> str | None:
    """`rerun_file_problem` of an evaluation's recording: decoded whole, its recording id
    its eval id (the file's stem), as every writer of one names it."""
    return rerun_file_problem(path, recording_id=Path(path).stem, decode=True)


def recording_chunks(path: str | os.PathLike[str]) -> list[Chunk] | None:
    """The chunks of an evaluation's recording, decoded once; None where it is not sound
    (`recording_problem` says why)."""
    path = Path(path)
    problem, chunks = _read(path, layout=False, recording_id=path.stem, decode=True)
    return None if problem is not None else chunks


def _what_to_do(path: Path) -> str:
    """How to get past a damaged file, by what it is."""
    if path.suffix == ".rbl":
        return "remove it: the viewer then uses its default layout"
    if path.name == "campaign.rrd":
        return "remove it: ariel view writes it again from the runs' tables"
    if path.name == "evaluations.rrd":
        return "restore it from a copy, or open one evaluation (ariel view RUN EVAL_ID)"
    if path.parent.name == "replays":
        return "remove it: the 3D replay is re-simulated again"
    return "restore it from a copy of the folder"


def check_rerun_files(paths: Iterable[Path], root: Path) -> None:
    """Raise `ViewError`, one line naming the file (relative to ``root``) and what to do,
    for the first of ``paths`` that is not a sound Rerun file (`rerun_file_problem`)."""
    for path in paths:
        evaluation = path.suffix == ".rrd" and path.name not in _NAMED_OTHERWISE
        problem = (
            recording_problem(path)
            if evaluation
            else rerun_file_problem(path, layout=path.suffix == ".rbl")
        )
        if problem is not None:
            try:
                shown = str(path.relative_to(root))
            except ValueError:
                shown = str(path)
            raise ViewError(f"{shown!r} in {str(root)!r} {problem}; {_what_to_do(path)}")
