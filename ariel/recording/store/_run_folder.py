"""One run = one folder: ``run.json``, Parquet tables per generation, checkpoints.

``run.json`` holds the resolved config, its hash, the seed, versions, the git commit,
plugin provenance, status and times; it never holds an absolute path of this machine, so a
run folder copied elsewhere still loads. The checkpoint (``checkpoints/state.json``) holds
exactly what resume needs, as plain JSON data (never a pickle: loading a run folder runs no
code from it); it is replaced atomically after every generation's tables.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TypeAlias

from ariel.errors import DamagedRunError, NotARunError, RunStorageError
from ariel.plugins import REGISTRIES, script_plugins
from ariel.recording.store._escape import short_ascii
from ariel.recording.store._files import (
    atomic_write_bytes,
    atomic_write_json,
    check_path_names,
    damaged,
    format_problem,
    read_regular_file,
    remove_temporaries,
    within,
    written_path,
)
from ariel.recording.store._ids import check_run_id
from ariel.recording.store._lock import CAMPAIGN_JSON, LOCK_NAME, in_use_error, lock_holder
from ariel.recording.store._provenance import software_segment
from ariel.recording.store._tables import (
    MANIFEST_DIR,
    TABLES,
    generation_file,
    generation_recording_path,
    manifest_file,
    manifest_generations,
    recording_generations,
    table_generations,
)
from ariel.utils import ariel_line, nests_deeper_than

__all__ = [
    "CHECKPOINT_FORMAT",
    "MAX_CHECKPOINT_BYTES",
    "MAX_JSON_BYTES",
    "RUN_FORMAT",
    "DamagedRunError",
    "JsonObject",
    "NotARunError",
    "RunFolder",
    "RunStorageError",
    "damaged",
    "finished_generations",
    "json_data",
    "json_file",
    "resume_line",
    "storage_errors",
]

RUN_FORMAT = 1
CHECKPOINT_FORMAT = 2  # 1: a pickle (no longer loaded)
#: How deep the JSON of a folder's file may nest (run.json, a manifest, the checkpoint,
#: campaign.json): what ariel writes nests a few levels; no reader then recurses out of stack.
MAX_JSON_DEPTH = 100
#: The most bytes a folder's JSON file may have (`json_file`): run.json and a manifest are a few
#: KB (run.json a CVT's centroids too: 10,000 cells of 3 measures, about 0.6 MB), campaign.json
#: a run's config (about 3 KB) for each of at most 10,000 runs: about 30 MB.
MAX_JSON_BYTES = 64 << 20
#: The checkpoint holds the population: a MAP-Elites run's every elite, about 6 KB a body (its
#: NDE genotype), so 256 MiB holds an archive of about 40,000 elites.
MAX_CHECKPOINT_BYTES = 256 << 20
#: What ariel writes has one object or list per 100 to 200 bytes (a genotype is a list of
#: numbers); one per `BYTES_PER_CONTAINER` at most (beyond `FEW_CONTAINERS`), else 21 million
#: ``{}`` in a 63 MB file would take 3 GB to parse.
BYTES_PER_CONTAINER = 48
FEW_CONTAINERS = 100_000
#: A JSON object read back from a folder's file (run.json, the checkpoint's state, a manifest,
#: campaign.json): string keys, and values that are whatever the file holds (no type is
#: promised for them: each is checked where it is read).
JsonObject: TypeAlias = dict[str, Any]


def json_data(raw: str | bytes) -> object:
    """The data of a folder's JSON file (``raw``: its text or bytes); `ValueError` (one line)
    for one that is not JSON, or that nests deeper than `MAX_JSON_DEPTH` (``[[[[...]]]]``
    100,000 deep would be a `RecursionError` here, or in whatever walks it later)."""
    try:
        data = json.loads(raw)
    except RecursionError:
        raise ValueError(f"JSON nested more than {MAX_JSON_DEPTH} deep") from None
    if nests_deeper_than(data, MAX_JSON_DEPTH):
        raise ValueError(f"JSON nested more than {MAX_JSON_DEPTH} deep")
    return data


def json_file(path: str | os.PathLike[str], limit: int = MAX_JSON_BYTES) -> object:
    """The data of a folder's JSON file ``path`` (`json_data`), read as a regular file of at most
    ``limit`` bytes (`read_regular_file`: a FIFO, a device or a larger file is a one-line
    `ValueError`, never a reader blocked or out of memory). `OSError` when it cannot be opened.
    Every JSON file of a run or campaign folder is read here. A file of far more objects and
    lists for its size than ariel writes (`BYTES_PER_CONTAINER`) is refused before parsing."""
    raw = read_regular_file(path, limit)
    containers = raw.count(b"{") + raw.count(b"[")
    if containers > max(FEW_CONTAINERS, len(raw) // BYTES_PER_CONTAINER):
        raise ValueError(
            f"{containers:,} objects and lists in {len(raw):,} bytes: far more than ariel writes "
            f"(one per {BYTES_PER_CONTAINER} bytes at most)"
        )
    return json_data(raw)


def finished_generations(run_dir: str | Path, info: Mapping[str, object]) -> int:
    """run.json's ``generations_done`` (``info``: run.json of ``run_dir``), checked: a whole
    number (not a bool, a float or a string) from 0 to its config's ``generations``; else a
    one-line `DamagedRunError`. Readers go by it (which tables to read, which manifests must be
    there), so a count no run writes is damage, never 0 or a billion generations."""
    done = info.get("generations_done", 0)
    config = info.get("config")
    total = config.get("generations") if isinstance(config, Mapping) else None
    total = total if type(total) is int and total >= 1 else None  # else its own damage
    if type(done) is int and done >= 0 and (total is None or done <= total):
        return done
    most = f"to {total} (its config's generations)" if total is not None else "up"
    problem = f"has generations_done {short_ascii(done)}, not a whole number from 0 {most}"
    raise damaged(run_dir, "run.json", problem)


def _is_temporary(path: Path) -> bool:
    return path.is_file() and written_path(path) is not None


def _is_leftover(path: Path) -> bool:
    """A killed writer's temporary, or the (free) lock file of a killed run."""
    return _is_temporary(path) or (path.name == LOCK_NAME and path.is_file())


# Problems of the storage itself, not of the run: these become a `RunStorageError`.
_STORAGE_ERRNOS = {
    errno.ENOSPC,
    errno.EDQUOT,
    errno.EFBIG,
    errno.EROFS,
    errno.EACCES,
    errno.EPERM,
    errno.ENOTDIR,
    errno.EIO,
}
_SPACE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}


def _within(name: str, run_dir: Path) -> bool:
    """``name`` lies in ``run_dir`` (or is it, or one of the folders it is made in)."""
    path, run_dir = Path(os.path.abspath(name)), Path(os.path.abspath(run_dir))
    return path == run_dir or run_dir in path.parents or path in run_dir.parents


def _storage_message(exc: OSError, run_dir: Path, campaign: bool = False) -> str | None:
    if exc.errno not in _STORAGE_ERRNOS:
        return None
    name = exc.filename
    if name is None and exc.errno not in _SPACE_ERRNOS:
        return None  # a permission error from elsewhere (a plugin, a socket) is not ours
    if name is not None and not _within(os.fsdecode(name), run_dir):
        return None
    shown = Path(os.fsdecode(name)) if name is not None else run_dir
    shown = written_path(shown) or shown  # a temporary's name: say the real file
    problem = f"cannot write {str(shown)!r}: {os.strerror(exc.errno)}"
    if campaign:  # run_dir is a campaign's folder
        if not (run_dir / CAMPAIGN_JSON).is_file():
            return f"{problem}; the campaign did not start"
        return (
            f"{problem}; the campaign stopped, the finished generations of its runs are kept: "
            "make room (or fix the folder), then continue with: "
            f"{ariel_line('campaign', 'resume', run_dir)}"
        )
    try:
        info = RunFolder(run_dir).read_info()
    except NotARunError:
        return f"{problem}; the run did not start"
    try:
        done = finished_generations(run_dir, info)
    except DamagedRunError as bad:
        return f"{problem}; {bad}"
    return (
        f"{problem}; the run stopped, its {done} finished generation(s) are kept: "
        f"make room (or fix the folder), then continue with: {resume_line(run_dir, info)}"
    )


@contextlib.contextmanager
def storage_errors(run_dir: str | Path, *, campaign: bool = False) -> Iterator[None]:
    """Turn a failed write in ``run_dir`` (disk full, read-only, ...) into `RunStorageError`:
    one line saying how far it got and how to continue (``campaign``: ``run_dir`` is a
    campaign's folder, continued by ``ariel campaign resume``).

    Other errors pass unchanged.
    """
    try:
        yield
    except OSError as exc:
        message = _storage_message(exc, Path(run_dir), campaign)
        if message is None:
            raise
        raise RunStorageError(message) from exc


def _instead(path: Path) -> str:
    """What to do about an existing folder at ``path``: replace or continue a run, or choose
    another folder (the command to paste where there is one)."""
    try:
        info = RunFolder(path).read_info()
    except NotARunError:
        return "choose another --out (it is not an ariel run folder: --overwrite leaves it alone)"
    if info.get("status") == "finished":
        return (
            "pass --overwrite (from Python: overwrite=True) to replace it, or choose another --out"
        )
    return (
        "pass --overwrite (from Python: overwrite=True) to replace it, or continue it with: "
        f"{resume_line(path, info)}"
    )


def resume_line(run_dir: Path, info: Mapping[str, object]) -> str:
    """How to continue the run at ``run_dir`` (run.json ``info``), to paste: ``ariel resume
    RUN``; where a plugin of the run was registered by a script or notebook, which the ariel
    command does not know (`script_plugins`), ``resume_experiment`` from that script."""
    found = script_plugins(info.get("plugins"))
    if not found:
        return ariel_line("resume", run_dir)
    kind, name = found[0]
    return (
        f"resume_experiment({str(run_dir)!r}) in the script that registers its "
        f"{REGISTRIES[kind].label} {name[:60]!r} (the ariel command does not know it)"
    )


class RunFolder:
    """Reads and writes one run folder.

    Making one reads nothing: ``read_info`` reads run.json (`NotARunError` when the folder is
    not a run), ``create`` makes a new run folder.

    Args:
        path: The run folder (it need not exist yet).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    # -- paths ---------------------------------------------------------------------------------

    @property
    def run_json(self) -> Path:
        return self.path / "run.json"

    @property
    def checkpoint(self) -> Path:
        return self.path / "checkpoints" / "state.json"

    # -- creation ------------------------------------------------------------------------------

    @staticmethod
    def check_new(path: str | Path, *, overwrite: bool, locked: bool = False) -> None:
        """Raise `FileExistsError` unless ``path`` may become a new run folder.

        A symbolic link is refused, whatever it leads to (never followed: replacing the run
        it names would delete that run through the link). An existing
        non-empty folder needs ``overwrite``, and is only ever replaced when it is a run folder
        (never an arbitrary directory). A folder that another process runs in raises
        `RunInUseError` (``locked``: this process holds its lock).
        """
        path = Path(path)
        check_path_names(path)
        if path.is_symlink():  # never made or replaced through: it leads elsewhere
            target = "a missing target" if not path.exists() else "a folder"
            raise FileExistsError(
                f"output {str(path)!r} is a symbolic link to {target} ({os.readlink(path)!r}); "
                "a run folder is never made or replaced through a link: give the folder itself "
                "or choose another --out"
            )
        if path.exists() and not path.is_dir():
            raise FileExistsError(f"output {str(path)!r} exists and is not a folder")
        holder = None if locked or not path.is_dir() else lock_holder(path)
        if holder is not None:
            raise in_use_error(path, holder)
        # A folder holding only a killed writer's temporaries (killed while being created)
        # counts as empty.
        if not path.is_dir() or all(_is_leftover(p) for p in path.iterdir()):
            return
        if not overwrite:
            raise FileExistsError(f"output folder {str(path)!r} already exists; {_instead(path)}")
        if not (path / "run.json").is_file():
            raise FileExistsError(
                f"refusing to overwrite {str(path)!r}: it is not an ariel run folder (no run.json)"
            )

    @classmethod
    def create(
        cls, path: str | Path, info: Mapping[str, object], *, overwrite: bool, locked: bool = False
    ) -> RunFolder:
        cls.check_new(path, overwrite=overwrite, locked=locked)
        path = Path(path)
        if path.is_dir():  # a run folder (check_new refuses anything else) or leftovers
            for child in path.iterdir():
                if child.name == LOCK_NAME and locked:
                    continue  # the lock this process holds
                if child.is_dir() and not child.is_symlink():
                    shutil.rmtree(child)
                else:
                    child.unlink()
        path.mkdir(parents=True, exist_ok=True)
        folder = cls(path)
        folder.write_info({"format": RUN_FORMAT, **info})
        return folder

    # -- run.json ------------------------------------------------------------------------------

    def read_info(self) -> JsonObject:
        if not within(self.run_json, self.path):  # a link to another run's (or any) file
            raise NotARunError(
                f"{self.run_json}: unreadable run.json (a symbolic link out of the run folder)"
            )
        try:
            info = json_file(self.run_json)
        except (FileNotFoundError, NotADirectoryError):
            why = "no run.json" if self.path.is_dir() else "no such folder"
            if self.path.exists() and not self.path.is_dir():
                why = "a file, not a folder"
            elif (self.path / CAMPAIGN_JSON).is_file():  # the campaign's, not one of its runs
                why = (
                    "a campaign folder: its runs are under runs/condition=*/seed=*; "
                    f"{ariel_line('campaign', 'status', self.path)} lists them, "
                    f"{ariel_line('compare', self.path)} compares them"
                )
            raise NotARunError(f"{str(self.path)!r} is not an ariel run folder ({why})") from None
        except (OSError, ValueError) as exc:
            raise NotARunError(f"{self.run_json}: unreadable run.json ({exc})") from None
        problem = format_problem("run.json", info, RUN_FORMAT)
        if problem is not None or not isinstance(info, dict):
            raise NotARunError(f"{self.run_json}: {problem}")
        if "run_id" in info:  # shown, written into exports and recordings: never a crafted one
            check_run_id(info["run_id"], self.path)
        return info

    def write_info(self, info: Mapping[str, object]) -> None:
        atomic_write_json(self.run_json, info, root=self.path)

    def start_segment(self, kind: str) -> JsonObject:
        """Record in run.json the software of this process, which now runs the run: ``kind``
        "run" (the first segment) or "resume" (each resume adds one). Versions and commit are
        read here, never carried over from run.json (which anyone may have edited)."""
        info = self.read_info()
        segments = info.get("segments")
        segments = list(segments) if isinstance(segments, list) else []
        segments.append(software_segment(kind, generation=info.get("generations_done", 0)))
        info["segments"] = segments
        self.write_info(info)
        return info

    def update_info(self, **changes: object) -> JsonObject:
        info = self.read_info()
        info.update(changes)
        self.write_info(info)
        return info

    # -- checkpoints ---------------------------------------------------------------------------

    def save_checkpoint(self, state: Mapping[str, object]) -> None:
        """Replace the checkpoint with ``state`` (JSON-able plain data, no NaN)."""
        payload = {"format": CHECKPOINT_FORMAT, "state": state}
        text = json.dumps(payload, allow_nan=False, separators=(",", ":"))
        atomic_write_bytes(self.checkpoint, text.encode(), root=self.path)

    def load_checkpoint(self) -> JsonObject | None:
        """The last saved state (plain data), or None when no generation finished yet."""
        legacy = self.checkpoint.with_name("state.pkl")
        there = os.path.lexists(self.checkpoint)  # a FIFO or a folder there is no "none yet"
        if not there and os.path.lexists(legacy):
            raise NotARunError(
                f"{legacy}: a pickle checkpoint of an older ariel, not loaded (unpickling runs "
                "code from the file); the run's tables load, but it cannot be resumed"
            )
        if not there:
            return None
        try:
            if not within(self.checkpoint, self.path):  # checkpoints/ or state.json a link
                raise ValueError("a symbolic link out of the run folder")
            payload = json_file(self.checkpoint, MAX_CHECKPOINT_BYTES)
        except (OSError, ValueError) as exc:  # written atomically: only outside damage
            first = (str(exc).splitlines() or [""])[0]
            raise NotARunError(
                f"{self.checkpoint}: unreadable checkpoint ({type(exc).__name__}: {first})"
            ) from None
        problem = format_problem("checkpoint", payload, CHECKPOINT_FORMAT)
        if problem is not None or not isinstance(payload, dict):
            raise NotARunError(f"{self.checkpoint}: {problem}")
        return payload["state"]

    # -- tables --------------------------------------------------------------------------------

    def generations_on_disk(self, table: str = "evaluations") -> list[int]:
        return table_generations(self.path, table)

    def discard_after(self, generation: int) -> list[Path]:
        """Delete table files, manifests and Rerun recordings of generations after
        ``generation``, and temporaries (resume)."""

        removed = list(remove_temporaries(self.path))
        if not (self.path / MANIFEST_DIR).is_symlink():
            for gen in manifest_generations(self.path):
                if gen > generation:
                    path = manifest_file(self.path, gen)
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
                    removed.append(path)
        for table in TABLES:
            if (self.path / table).is_symlink():  # deleting through it would delete elsewhere
                continue
            for gen in table_generations(self.path, table):
                if gen > generation:
                    path = generation_file(self.path, table, gen)
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
                    removed.append(path)
        if (self.path / "recordings").is_symlink():  # a link may lead elsewhere
            return removed
        for gen in recording_generations(self.path):
            folder = generation_recording_path(self.path, gen).parent
            if gen > generation and folder.is_symlink():
                folder.unlink()
                removed.append(folder)
            elif gen > generation and folder.is_dir():
                shutil.rmtree(folder, ignore_errors=True)
                removed.append(folder)
        return removed
