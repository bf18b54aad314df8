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
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypedDict

import pyarrow.parquet as pq

from ariel.recording.store._escape import short_ascii
from ariel.recording.store._files import atomic_write_json, within
from ariel.recording.store._run_folder import (
    DamagedRunError,
    NotARunError,
    RunFolder,
    damaged,
    json_data,
)
from ariel.recording.store._tables import MANIFEST_DIR, TABLES, generation_file, rows_problem

__all__ = [
    "MANIFEST_DIR",
    "MANIFEST_FORMAT",
    "Manifest",
    "VerifyResult",
    "adopt_manifests",
    "manifest_file",
    "manifests_expected",
    "verify_run",
    "write_manifest",
]

MANIFEST_FORMAT = 1
#: Tables every finished generation has (trajectories only with ``record.trajectories``).
_REQUIRED = ("evaluations", "bodies")
_CHUNK = 1 << 20
#: Keys of run.json that came with manifests: only an ariel that writes a manifest for every
#: finished generation (and ``"manifests": 1``) writes them.
_MANIFEST_ERA = ("segments", "maximise", "brain_only")
_MANIFEST_NAME = re.compile(r"gen-\d{6}\.json")


class _Entry(TypedDict):
    """A table file as its generation's manifest lists it."""

    bytes: int
    sha256: str


def manifest_file(run_dir: str | Path, generation: int) -> Path:
    return Path(run_dir) / MANIFEST_DIR / f"gen-{int(generation):06d}.json"


def _relative(run_dir: Path, path: Path) -> str:
    return path.relative_to(run_dir).as_posix()


def _sha256_file(path: Path) -> tuple[int, str]:
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
            size, digest = _sha256_file(path)
            files[_relative(run_dir, path)] = {"bytes": size, "sha256": digest}
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
    name = _relative(run_dir, path)
    if path.is_symlink():
        raise damaged(run_dir, name, "is a symbolic link")
    try:
        data = json_data(path.read_text(encoding="utf-8"))
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
        expected = {_relative(run_dir, generation_file(run_dir, t, generation)) for t in TABLES}
        if listed not in expected:
            raise damaged(run_dir, name, f"lists a file it may not list ({listed!r})")
    for table in _REQUIRED:
        listed = _relative(run_dir, generation_file(run_dir, table, generation))
        if listed not in files:
            raise damaged(run_dir, name, f"does not list {listed}")
    return files


def _manifests_held(run_dir: Path) -> int:
    """How many ``gen-NNNNNN.json`` manifests/ holds."""
    try:
        return sum(
            bool(_MANIFEST_NAME.fullmatch(p.name)) for p in (run_dir / MANIFEST_DIR).iterdir()
        )
    except OSError:
        return 0


def manifests_expected(run_dir: str | Path, info: Mapping[str, object]) -> tuple[bool, str | None]:
    """Whether every finished generation of the run (``info``: its run.json) has a manifest,
    and where run.json's ``"manifests"`` contradicts that, the problem (one line, ``run.json
    ...``). Only a run.json of a run made before manifests (no ``"manifests"``, none of the keys
    that came with them) has its tables checked without them."""
    flag = info.get("manifests")
    if flag:
        return True, None
    era = [key for key in _MANIFEST_ERA if key in info]
    if "manifests" not in info and not era:
        return False, None
    held = _manifests_held(Path(run_dir))
    on_disk = f"; {MANIFEST_DIR}/ holds {held} manifest(s)" if held else ""
    if "manifests" in info:
        why = f"has 'manifests': {json.dumps(flag)}, a value no ariel writes (1: every "
        why += "finished generation has a manifest)"
    else:
        why = f"has no 'manifests' but has {era[0]!r}, which only an ariel writing manifests writes"
    return True, f"run.json {why}{on_disk}"


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
    return {_relative(run_dir, generation_file(run_dir, t, generation)): None for t in _REQUIRED}


@dataclass
class Manifest:
    """What a run's finished generations hold: table file -> (bytes, SHA-256).

    ``checked`` is False for a run made before manifests existed: then only the presence of the
    required tables is known (``files`` maps them to None). ``config``: run.json's config, which
    bounds the rows a table file may hold (`ariel.recording.store._tables.row_limit`).
    """

    run_dir: Path
    generations: int
    checked: bool
    files: dict[str, tuple[int, str] | None] = field(default_factory=dict)
    config: Mapping[str, object] | None = None

    @classmethod
    def load(cls, run_dir: str | Path, info: Mapping[str, object]) -> Manifest:
        """The manifest of the run's finished generations (``info``: its run.json), checking
        that each listed file is there with its size; `DamagedRunError` else."""
        run_dir = Path(run_dir)
        done = info.get("generations_done", 0)
        done = done if isinstance(done, int) and done >= 0 else 0
        expected, problem = manifests_expected(run_dir, info)
        if problem is not None:
            raise damaged(run_dir, *problem.split(" ", 1))
        config = info.get("config")
        manifest = cls(run_dir, done, checked=expected)
        manifest.config = config if isinstance(config, dict) else None
        for generation in range(done):
            manifest.files.update(manifest_entries(run_dir, generation, expected))
        for name, entry in manifest.files.items():
            manifest.check_present(name, entry)
        return manifest

    def check_present(self, name: str, entry: tuple[int, str] | None) -> None:
        path = self.run_dir / name
        if path.is_symlink() and not within(path, self.run_dir):
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
            if _relative(self.run_dir, path) in self.files or (not self.checked and path.is_file()):
                found.append((generation, path))
        return found

    def check_bytes(self, path: Path, data: bytes) -> None:
        """``data``, read from ``path``, is what the manifest lists; `DamagedRunError` else."""
        name = _relative(self.run_dir, path)
        entry = self.files.get(name)
        if entry is None:
            return
        if len(data) != entry[0]:
            raise damaged(self.run_dir, name, f"has {len(data)} bytes, not {entry[0]}")
        if hashlib.sha256(data).hexdigest() != entry[1]:
            raise damaged(self.run_dir, name, "has other bytes than when it was written (SHA-256)")


# --------------------------------------------------------------------------------------------
# ariel verify, and resume
# --------------------------------------------------------------------------------------------


@dataclass
class VerifyResult:
    """What `verify_run` checked and found: ``problems`` empty means the folder is sound."""

    run_dir: Path
    generations: int
    files: int = 0
    bytes: int = 0
    checked: bool = True  # False: a run made before manifests (presence and readability only)
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what could not be checked, and why
    run_id_checked: bool = False  # run.json's run_id against a table's rows

    @property
    def ok(self) -> bool:
        return not self.problems


def _check_readable(path: Path) -> str | None:
    try:
        pq.read_table(path)
    except Exception as exc:  # any decoding failure is damage; one line says which
        first = (str(exc).splitlines() or [""])[0]
        return f"is not a readable Parquet table ({type(exc).__name__}: {first})"
    return None


def verify_run(run_dir: str | Path, generations: int | None = None) -> VerifyResult:
    """Check every file the manifests list (size and SHA-256), or for a run made before
    manifests, that the required tables are there and readable; and what never changes in
    run.json (`_check_run_json`).

    Args:
        run_dir: The run folder.
        generations: Check only the first this many generations; None (the default): the
            finished ones, run.json's ``generations_done``.

    Returns:
        What was checked and found: ``ok`` is True when the folder is sound; ``problems``
        has one line per damaged file (``ariel verify`` prints them), ``notes`` what could
        not be checked, and ``files`` / ``bytes`` what was read.

    Raises:
        NotARunError: For a folder that is not a run at all (no readable run.json).

    Example:
        ```python
        from ariel.recording import list_runs, verify_run

        result = verify_run(list_runs()[-1]["path"])  # a run folder under data/runs
        print(result.ok, result.files, result.problems)
        ```
    """
    run_dir = Path(run_dir)
    info = RunFolder(run_dir).read_info()
    done = info.get("generations_done", 0)
    if not isinstance(done, int) or done < 0:
        done = 0
    if generations is not None:  # resume: the checkpoint's count (run.json may lag by one)
        done = generations
    expected, problem = manifests_expected(run_dir, info)
    result = VerifyResult(run_dir, done, checked=expected)
    if problem is not None:
        result.problems.append(f"{problem}; checked against the manifests all the same")
    for generation in range(done):
        try:
            entries = manifest_entries(run_dir, generation, expected)
        except DamagedRunError as exc:
            result.problems.append(_problem(exc))
            continue
        for name, entry in entries.items():
            problem = _check_file(run_dir, name, entry, result, info.get("config"))
            if problem is not None and problem.startswith("run.json "):  # its config: once
                if problem not in result.problems:
                    result.problems.append(problem)
            elif problem is not None:
                result.problems.append(f"{name} {problem}")
            elif name.startswith("evaluations/") and not result.run_id_checked:
                _check_run_id(run_dir / name, info, result)
    _check_run_json(run_dir, info, result)
    return result


def _check_run_json(run_dir: Path, info: Mapping[str, object], result: VerifyResult) -> None:
    """What never changes in run.json (it is in no manifest): its config against its
    ``config_hash`` and its ``seed``, and the checkpoint's ``config_hash`` against run.json's.
    A config this ariel cannot read (a newer ariel's, say) is a note, not damage."""
    # lazy: slow (~0.2 s: pydantic, the executors), and `load_run` imports this module
    from ariel.evolution import ConfigError, ExperimentConfig, config_hash

    config, recorded = info.get("config"), info.get("config_hash")
    if not isinstance(config, dict):
        result.problems.append(f"run.json has no config (its 'config' is {short_ascii(config)})")
        return
    if info.get("seed") != config.get("seed"):
        result.problems.append(
            f"run.json has seed {short_ascii(info.get('seed'))}, its config "
            f"{short_ascii(config.get('seed'))}"
        )
    try:
        digest = config_hash(ExperimentConfig.from_plain(config))
    except (ConfigError, TypeError, ValueError) as exc:
        first = (str(exc).splitlines() or [""])[0]
        result.notes.append(
            f"run.json's config is not one this ariel reads ({first}): its config_hash was not "
            "checked"
        )
    else:
        if digest != recorded:
            result.problems.append(
                "run.json has a config_hash that is not its config's (SHA-256): the config or "
                "the hash changed after the run started"
            )
    folder = RunFolder(run_dir)
    if not os.path.lexists(folder.checkpoint):
        return
    name = _relative(run_dir, folder.checkpoint)
    try:
        state = folder.load_checkpoint()
    except NotARunError as exc:
        result.problems.append(f"{name} {str(exc).removeprefix(f'{folder.checkpoint}: ')}")
        return
    if isinstance(state, dict) and state.get("config_hash") != recorded:
        result.problems.append(f"{name} has a config_hash that is not run.json's")


def _check_rows(path: Path, config: object) -> str | None:
    """A sound table file's row count against what the run's config makes (`rows_problem`),
    from its footer alone; a footer that does not decode is `_check_file`'s to say."""
    try:
        metadata = pq.read_metadata(path)
    except Exception:  # not Parquet: a run made before manifests says so when it is read
        return None
    return rows_problem(config if isinstance(config, dict) else None, path, metadata)


def _check_run_id(path: Path, info: Mapping[str, object], result: VerifyResult) -> None:
    """The ``run_id`` of a sound evaluations table's rows is run.json's."""
    try:
        ids = set(pq.read_table(path, columns=["run_id"]).column("run_id").to_pylist())
    except Exception:  # a table that does not decode: `_check_file` says so
        return
    result.run_id_checked = True
    others = sorted(str(i) for i in ids if i != info.get("run_id"))
    if others:
        result.problems.append(
            f"run.json has run_id {short_ascii(info.get('run_id'))}, its tables "
            f"{short_ascii(others[0])}"
        )


def _problem(exc: DamagedRunError) -> str:
    """``NAME PROBLEM`` of `damaged`'s line."""
    return str(exc).split(" is damaged: ", 1)[-1].rsplit("; restore", 1)[0]


def _check_file(
    run_dir: Path,
    name: str,
    entry: tuple[int, str] | None,
    result: VerifyResult,
    config: object = None,
) -> str | None:
    path = run_dir / name
    if path.is_symlink():
        return "is a symbolic link" + ("" if within(path, run_dir) else " out of the run folder")
    if not path.is_file():
        return "is missing" if not os.path.lexists(path) else "is not a file"
    result.files += 1
    if entry is None:
        result.bytes += path.stat().st_size
        return _check_rows(path, config) or _check_readable(path)
    try:
        size, digest = _sha256_file(path)
    except OSError as exc:
        return f"is unreadable ({exc.strerror})"
    result.bytes += size
    if size != entry[0]:
        return f"has {size} bytes, not {entry[0]}"
    if digest != entry[1]:
        return "has other bytes than when it was written (SHA-256)"
    return _check_rows(path, config)


def adopt_manifests(folder: RunFolder, generations: int) -> None:
    """Before a run continues: refuse it when damaged (`DamagedRunError`, the first problem);
    a run made before manifests gets them for its ``generations`` finished generations."""
    result = verify_run(folder.path, generations)
    if result.problems:
        raise damaged(folder.path, *result.problems[0].split(" ", 1))
    if result.checked:
        return
    for generation in range(generations):
        write_manifest(folder.path, generation)
    folder.update_info(manifests=MANIFEST_FORMAT)
