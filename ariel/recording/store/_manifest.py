"""The manifest of a run folder: per finished generation, its table files with size and SHA-256.

``manifests/gen-NNNNNN.json`` is written after the generation's tables and before the
checkpoint that makes the generation count as finished, so every finished generation has one.
Readers (`load_run`, `ariel report`, `ariel replay`, `ariel resume`) check it: a table that is
missing, has another size, or other bytes (a single flipped bit included) makes the run
`DamagedRunError`, one line naming the file. `verify_run` (``ariel verify``) checks every file.

The manifest covers the Parquet tables, the canonical record. Rerun recordings are not in it:
they are views, not fsynced one by one, and may be empty after a power cut (docs/records.md).

A run folder made before manifests existed has no ``"manifests"`` key in ``run.json``: its
readers check that every finished generation's evaluations and bodies tables are there and
readable (and a generation that has a manifest all the same, against it); ``ariel resume`` of
such a run writes the manifests of the generations it keeps (after that check), so from then on
it is checked like any other.

run.json is in no manifest (it changes while the run goes on), so its ``"manifests"`` alone
never switches the check off: a value no ariel writes (``0``: one flipped bit of ``1``) or no
``"manifests"`` in a run.json with keys that came with manifests (``segments``, ``maximise``,
``brain_only``) is damage, and the tables are checked against the manifests all the same
(`manifests_expected`). What never changes in run.json is checked by `verify_run`: the config
against its ``config_hash`` and seed, the checkpoint's ``config_hash``, the tables' ``run_id``.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypedDict

from ariel.recording.store._files import atomic_write_json, within
from ariel.recording.store._run_folder import damaged, finished_generations, json_file
from ariel.recording.store._tables import (
    MANIFEST_DIR,
    TABLES,
    generation_file,
    manifest_file,
    manifest_generations,
)

__all__ = [
    "MANIFEST_DIR",
    "MANIFEST_FORMAT",
    "Manifest",
    "after_the_last",
    "manifest_entries",
    "manifest_file",
    "manifest_generations",
    "manifests_expected",
    "relative",
    "sha256_file",
    "write_manifest",
]

MANIFEST_FORMAT = 1
#: Tables every finished generation has (trajectories only with ``record.trajectories``).
_REQUIRED = ("evaluations", "bodies")
_CHUNK = 1 << 20
#: Keys of run.json that came with manifests: only an ariel that writes a manifest for every
#: finished generation (and ``"manifests": 1``) writes them.
# Not "plugins": run.json has named its plugins since the first run loop, long before manifests
# (a genuine pre-manifest folder has it).
_MANIFEST_ERA = ("segments", "maximise", "brain_only", "results_version")


class _Entry(TypedDict):
    """A table file as its generation's manifest lists it."""

    bytes: int
    sha256: str


def relative(run_dir: Path, path: Path) -> str:
    return path.relative_to(run_dir).as_posix()


def sha256_file(path: Path) -> tuple[int, str]:
    digest, size = hashlib.sha256(), 0
    with open(path, "rb") as file:
        while chunk := file.read(_CHUNK):
            digest.update(chunk)
            size += len(chunk)
    return size, digest.hexdigest()


def write_manifest(run_dir: str | Path, generation: int) -> Path:
    """List ``generation``'s table files (size, SHA-256) in its manifest; returns its path."""
    run_dir = Path(run_dir)
    files: dict[str, _Entry] = {}
    for table in TABLES:
        path = generation_file(run_dir, table, generation)
        if path.is_file() and not path.is_symlink():
            size, digest = sha256_file(path)
            files[relative(run_dir, path)] = {"bytes": size, "sha256": digest}
    path = manifest_file(run_dir, generation)
    atomic_write_json(
        path,
        {"format": MANIFEST_FORMAT, "generation": int(generation), "files": files},
        root=run_dir,
    )
    return path


def _read_manifest(run_dir: Path, generation: int) -> dict[str, _Entry]:
    """The ``files`` of one generation's manifest; `DamagedRunError` when missing or bad."""
    path = manifest_file(run_dir, generation)
    name = relative(run_dir, path)
    if path.is_symlink() or not within(path, run_dir):  # manifests/ may be the link
        raise damaged(run_dir, name, "is a symbolic link")
    try:
        data = json_file(path)
    except FileNotFoundError:
        raise damaged(run_dir, name, f"is missing (generation {generation} is finished)") from None
    except OSError as exc:
        raise damaged(run_dir, name, f"is unreadable ({type(exc).__name__})") from None
    except ValueError as exc:  # not JSON, not UTF-8, or nested too deep
        first = (str(exc).splitlines() or [""])[0]
        raise damaged(run_dir, name, f"is unreadable ({type(exc).__name__}: {first})") from None
    read = data if isinstance(data, dict) else {}  # not an object: no "files", damaged below
    files = read.get("files")
    ok = (
        isinstance(files, dict)
        and read.get("format") == MANIFEST_FORMAT
        and read.get("generation") == generation
        and all(
            isinstance(v, dict)
            and isinstance(v.get("bytes"), int)
            and isinstance(v.get("sha256"), str)
            for v in files.values()
        )
    )
    if not ok or not isinstance(files, dict):  # (the second for the type checker)
        raise damaged(run_dir, name, "is not a manifest of this generation")
    for listed in files:
        expected = {relative(run_dir, generation_file(run_dir, t, generation)) for t in TABLES}
        if listed not in expected:
            raise damaged(run_dir, name, f"lists a file it may not list ({listed!r})")
    for table in _REQUIRED:
        listed = relative(run_dir, generation_file(run_dir, table, generation))
        if listed not in files:
            raise damaged(run_dir, name, f"does not list {listed}")
    return files


def manifests_expected(run_dir: str | Path, info: Mapping[str, object]) -> tuple[bool, str | None]:
    """Whether every finished generation of the run (``info``: its run.json) has a manifest,
    and where run.json's ``"manifests"`` contradicts that, the problem (one line, ``run.json
    ...``). Only a run.json of a run made before manifests (no ``"manifests"``, none of the keys
    that came with them) has its tables checked without them."""
    flag = info.get("manifests")
    if type(flag) is int and flag == 1:  # what a run writes ("yes", 2 or true: crafted)
        return True, None
    era = [key for key in _MANIFEST_ERA if key in info]
    if "manifests" not in info and not era:
        return False, None
    held = len(manifest_generations(run_dir))
    on_disk = f"; {MANIFEST_DIR}/ holds {held} manifest(s)" if held else ""
    if "manifests" in info:
        why = f"has 'manifests': {json.dumps(flag)}, a value no ariel writes (1: every "
        why += "finished generation has a manifest)"
    else:
        why = f"has no 'manifests' but has {era[0]!r}, which only an ariel writing manifests writes"
    return True, f"run.json {why}{on_disk}"


def after_the_last(done: int, *, finished: bool = True) -> str:
    """The problem of a file of a generation past run.json's ``done``: of any such generation
    in a ``finished`` run, of one after the generation in flight in a stopped one."""
    why = "the run is finished" if finished else f"only generation {done} was in flight"
    return (
        f"is of a generation after the run's {done} finished one(s) (run.json's "
        f"generations_done; {why})"
    )


def manifest_entries(
    run_dir: Path, generation: int, expected: bool
) -> dict[str, tuple[int, str] | None]:
    """What one finished generation's tables must be: its manifest's files, each with its size
    and SHA-256 (``expected``: every generation has one; else, a run made before manifests, the
    manifest where there is one all the same), or the required tables, their bytes unknown.
    `DamagedRunError` for a manifest that is missing (where expected) or bad."""
    if expected or os.path.lexists(manifest_file(run_dir, generation)):
        listed = _read_manifest(run_dir, generation)
        return {name: (entry["bytes"], entry["sha256"]) for name, entry in listed.items()}
    return {relative(run_dir, generation_file(run_dir, t, generation)): None for t in _REQUIRED}


@dataclass
class Manifest:
    """What a run's finished generations hold: table file -> (bytes, SHA-256).

    ``checked`` is False for a run made before manifests existed: then only the presence of the
    required tables is known (``files`` maps them to None). ``config``: run.json's config, which
    bounds the rows and decoded size of a table file (`ariel.recording.store._table_limits`);
    ``run_id``: run.json's, which the tables' ``run_id`` column must hold.
    """

    run_dir: Path
    generations: int
    checked: bool
    files: dict[str, tuple[int, str] | None] = field(default_factory=dict)
    config: Mapping[str, object] | None = None
    run_id: str | None = None

    @classmethod
    def load(cls, run_dir: str | Path, info: Mapping[str, object]) -> Manifest:
        """The manifest of the run's finished generations (``info``: its run.json), checking
        that each listed file is there with its size; `DamagedRunError` else, and for a
        ``generations_done`` no run writes (`finished_generations`) or a finished run with a
        manifest of a later generation (run.json would hide it)."""
        run_dir = Path(run_dir)
        done = finished_generations(run_dir, info)
        expected, problem = manifests_expected(run_dir, info)
        if problem is not None:
            raise damaged(run_dir, *problem.split(" ", 1))
        config, run_id = info.get("config"), info.get("run_id")
        manifest = cls(run_dir, done, checked=expected)
        manifest.config = config if isinstance(config, dict) else None
        manifest.run_id = run_id if isinstance(run_id, str) else None
        later = [g for g in manifest_generations(run_dir) if g >= done]
        if later and info.get("status") == "finished":
            name = relative(run_dir, manifest_file(run_dir, later[0]))
            raise damaged(run_dir, name, after_the_last(done))
        for generation in range(done):  # ends at the first generation missing (a huge count)
            entries = manifest_entries(run_dir, generation, expected)
            for name, entry in entries.items():
                manifest.check_present(name, entry)
            manifest.files.update(entries)
        return manifest

    def check_present(self, name: str, entry: tuple[int, str] | None) -> None:
        path = self.run_dir / name
        if not within(path, self.run_dir):  # the file, or a folder on its way, a link elsewhere
            raise damaged(self.run_dir, name, "is a symbolic link out of the run folder")
        try:
            size = path.stat().st_size
        except FileNotFoundError:
            raise damaged(self.run_dir, name, "is missing") from None
        except OSError as exc:
            raise damaged(self.run_dir, name, f"is unreadable ({exc.strerror})") from None
        if entry is not None and size != entry[0]:
            raise damaged(self.run_dir, name, f"has {size} bytes, not {entry[0]}")

    def table_files(self, table: str, up_to: int | None = None) -> list[tuple[int, Path]]:
        """``(generation, path)`` of ``table``'s files of the finished generations."""
        last = self.generations - 1 if up_to is None else min(up_to, self.generations - 1)
        found = []
        for generation in range(last + 1):
            path = generation_file(self.run_dir, table, generation)
            if relative(self.run_dir, path) in self.files or (not self.checked and path.is_file()):
                found.append((generation, path))
        return found

    def check_bytes(self, path: Path, data: bytes) -> None:
        """``data``, read from ``path``, is what the manifest lists; `DamagedRunError` else."""
        name = relative(self.run_dir, path)
        entry = self.files.get(name)
        if entry is None:
            return
        if len(data) != entry[0]:
            raise damaged(self.run_dir, name, f"has {len(data)} bytes, not {entry[0]}")
        if hashlib.sha256(data).hexdigest() != entry[1]:
            raise damaged(self.run_dir, name, "has other bytes than when it was written (SHA-256)")
