"""``ariel verify``: a run folder checked against its manifests (`verify_run`), and before a
resume (`adopt_manifests`).

Every file the manifests of the finished generations list is checked (size and SHA-256), every
manifest there is (a finished run's manifest, or table, of a later generation than run.json's
``generations_done`` is damage: run.json would hide it), and what never changes in run.json.
Whatever run.json says, the lines are bounded: a run.json claiming 100,000 generations is one
line for its count and one for the first missing manifest (with how many more), and at most
`MAX_LISTED` problems are listed (`VerifyResult.unlisted`: how many more).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow.parquet as pq

from ariel.recording.store._direction import direction_problem
from ariel.recording.store._escape import short_ascii
from ariel.recording.store._files import within
from ariel.recording.store._lock import in_use_error, lock_holder
from ariel.recording.store._manifest import (
    MANIFEST_FORMAT,
    after_the_last,
    manifest_entries,
    manifest_file,
    manifest_generations,
    manifests_expected,
    relative,
    sha256_file,
    write_manifest,
)
from ariel.recording.store._run_folder import (
    DamagedRunError,
    NotARunError,
    RunFolder,
    damaged,
    finished_generations,
)
from ariel.recording.store._table_limits import (
    GEN_FILE,
    ID_PROBLEM_COLUMNS,
    generation_problem,
    id_problem,
    limits_problem,
    rows_problem,
    run_id_problem,
    size_problem,
)
from ariel.recording.store._tables import TABLES, generation_file, table_generations
from ariel.utils import path_argument

__all__ = ["MAX_LISTED", "VerifyResult", "adopt_manifests", "verify_run"]

#: The most problems `verify_run` lists; the rest are counted (`VerifyResult.unlisted`).
MAX_LISTED = 50
#: Tables every finished generation has (a run made before manifests: checked without them).
_REQUIRED = ("evaluations", "bodies")


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
    unlisted: int = 0  # problems past `MAX_LISTED`, not in ``problems``
    run_json_refused: bool = False  # run.json holds what no run writes: nothing else was read
    manifested: int = 0  # a run made before manifests: generations checked against one it has

    @property
    def ok(self) -> bool:
        return not self.problems


def _check_readable(path: Path) -> str | None:
    try:
        pq.read_table(os.path.abspath(path))  # pyarrow would expand a leading "~"
    except Exception as exc:  # any decoding failure is damage; one line says which
        first = (str(exc).splitlines() or [""])[0]
        return f"is not a readable Parquet table ({type(exc).__name__}: {first})"
    return None


def verify_run(run_dir: str | Path, generations: int | None = None) -> VerifyResult:
    """Check every file the manifests list (size and SHA-256), every manifest there is, or for
    a run made before manifests, that the required tables are there and readable; and what
    never changes in run.json (`_check_run_json`).

    Args:
        run_dir: The run folder.
        generations: Check only the first this many generations; None (the default): the
            finished ones, run.json's ``generations_done`` (checked: a count no run writes is
            a problem, and then every manifest there is is checked).

    Returns:
        What was checked and found: ``ok`` is True when the folder is sound; ``problems``
        has one line per damaged file (``ariel verify`` prints them; at most `MAX_LISTED`,
        ``unlisted`` counts the rest), ``notes`` what could not be checked, and ``files`` /
        ``bytes`` what was read.

    Raises:
        NotARunError: For a folder that is not a run at all (no readable run.json). A run.json
            holding what no run writes (a crafted run id) is a problem, not an exception.
        RunInUseError: For a finished run whose folder a process holds: it is being replaced
            (``ariel run --overwrite``) or pruned, and its files read as damage meanwhile.

    Example:
        ```python
        from ariel.recording import list_runs, verify_run

        result = verify_run(list_runs()[-1]["path"])  # a run folder under data/runs
        print(result.ok, result.files, result.problems)
        ```
    """
    run_dir = path_argument("run_dir", run_dir, function="verify_run")
    if generations is not None and (
        not isinstance(generations, int) or isinstance(generations, bool) or generations < 0
    ):
        raise ValueError(
            f"verify_run: generations must be None or a whole number >= 0, not {generations!r}"
        )
    # Before run.json: a run that finishes between the two reads is then read as finished.
    holder = lock_holder(run_dir) if generations is None else None
    try:
        info = RunFolder(run_dir).read_info()
    except DamagedRunError as exc:  # a readable run.json holding what no run writes (its id)
        return VerifyResult(run_dir, 0, problems=[f"run.json: {exc}"], run_json_refused=True)
    if holder is not None and info.get("status") == "finished":  # being replaced (--overwrite)
        raise in_use_error(run_dir, holder)  # or pruned: what is read now is no state of it
    expected, problem = manifests_expected(run_dir, info)
    result = VerifyResult(run_dir, 0, checked=expected)
    if problem is not None:
        result.problems.append(f"{problem}; checked against the manifests all the same")
    done: int | None
    try:
        done = finished_generations(run_dir, info)
    except DamagedRunError as exc:
        result.problems.append(_problem(exc))
        done = None  # unknown: every manifest there is is checked
    if generations is not None:  # resume: the checkpoint's count (run.json may lag by one)
        done = generations
    held = manifest_generations(run_dir)
    gens = _generations(run_dir, done, held, expected, resume=generations is not None)
    running = _running(holder, info, done, result)
    if running:  # the generations from `done` on are being written: not checked, not strays
        gens = [g for g in gens if done is None or g < done]
    result.generations = done if done is not None else len(held)
    if done is not None:
        _check_missing(run_dir, done, [g for g in gens if g < done], expected, result)
    if not expected:  # a resume killed while it wrote them, or the keys of run.json lost
        result.manifested = len(set(gens) & set(held))
    listed: set[str] = set()
    for generation in gens:
        _check_generation(run_dir, generation, expected, info, result, listed)
    if generations is None and expected and not running:
        _check_strays(run_dir, info, done, held, listed, result)
    _check_run_json(run_dir, info, result)
    if len(result.problems) > MAX_LISTED:
        result.unlisted = len(result.problems) - MAX_LISTED
        del result.problems[MAX_LISTED:]
    return result


def _generations(
    run_dir: Path, done: int | None, held: list[int], expected: bool, *, resume: bool
) -> list[int]:
    """The generations whose files are checked: those before ``done`` with a manifest (or, a
    run made before manifests, a required table), and outside a resume every manifest there
    is (of any generation), ascending. Never ``range(done)``: run.json may claim 10**30."""
    found = set(held)
    if not expected:
        found.update(g for table in _REQUIRED for g in table_generations(run_dir, table))
    if done is None:
        return sorted(found)
    before = {g for g in found if g < done}
    return sorted(before if resume or not expected else before | set(held))


def _running(
    holder: str | None, info: Mapping[str, object], done: int | None, result: VerifyResult
) -> bool:
    """Whether a process runs the run now (``holder`` holds the folder's lock, read before
    run.json): its generations from run.json's ``done`` on are then being written (run.json
    is updated last), so files of them are no damage; a note says they were not checked."""
    if holder is None or info.get("status") == "finished":
        return False
    start = f"from generation {done} on" if done is not None else "after the finished ones"
    result.notes.append(
        f"the run is running ({holder}): its generations {start} are being written and "
        "were not checked; verify it again when it has stopped"
    )
    return True


def _more(count: int, what: str) -> str:
    return f"; {count:,} more {what}" if count > 0 else ""


def _check_missing(
    run_dir: Path, done: int, present: list[int], expected: bool, result: VerifyResult
) -> None:
    """One line for the finished generations (``done`` of them) without a manifest (a run
    made before manifests: without a required table), however many: the first, and a count."""
    missing = done - len(present)
    if missing <= 0:
        return
    have, first = set(present), 0
    while first in have:
        first += 1
    path = (
        manifest_file(run_dir, first)
        if expected
        else generation_file(run_dir, "evaluations", first)
    )
    what = "have no manifest either" if expected else "have no tables either"
    result.problems.append(
        f"{relative(run_dir, path)} is missing (generation {first} is finished)"
        f"{_more(missing - 1, f'finished generation(s) {what}')}"
    )


def _check_generation(
    run_dir: Path,
    generation: int,
    expected: bool,
    info: Mapping[str, object],
    result: VerifyResult,
    listed: set[str],
) -> None:
    """The files of ``generation``'s manifest (or its required tables): each a problem line
    when damaged; their names added to ``listed``."""
    try:
        entries = manifest_entries(run_dir, generation, expected)
    except DamagedRunError as exc:
        result.problems.append(_problem(exc))
        tables = (generation_file(run_dir, table, generation) for table in TABLES)
        listed.update(relative(run_dir, path) for path in tables)  # said: its manifest
        return
    listed.update(entries)
    for name, entry in entries.items():
        problem = _check_file(run_dir, name, entry, result, info.get("config"))
        if problem is not None:
            result.problems.append(f"{name} {problem}")
        elif name.startswith(("evaluations/", "bodies/")):
            _check_ids(run_dir, name, info, result)


def _check_strays(
    run_dir: Path,
    info: Mapping[str, object],
    done: int | None,
    held: list[int],
    listed: set[str],
    result: VerifyResult,
) -> None:
    """Manifests and tables no finished generation accounts for: of a generation after
    ``done`` (an unfinished run's generation ``done`` excepted: it was being written when the
    run stopped, and resume discards it), or a table its generation's manifest does not list.
    One line for each kind, with a count."""
    in_flight = done if info.get("status") != "finished" else None
    later = [
        relative(run_dir, manifest_file(run_dir, g))
        for g in held
        if done is not None and g >= done and g != in_flight
    ]
    unlisted = []
    for table in TABLES:
        for generation in table_generations(run_dir, table):
            name = relative(run_dir, generation_file(run_dir, table, generation))
            if name in listed or generation == in_flight:
                continue
            if generation in held:
                unlisted.append(name)
            elif done is not None and generation >= done:
                later.append(name)
    if later and done is not None:
        more = _more(len(later) - 1, "such file(s)")
        finished = in_flight is None
        result.problems.append(f"{later[0]} {after_the_last(done, finished=finished)}{more}")
    if unlisted:
        result.problems.append(
            f"{unlisted[0]} is in no manifest (its generation's manifest does not list it)"
            f"{_more(len(unlisted) - 1, 'such file(s)')}"
        )


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
    limits = limits_problem(config)
    if limits is not None:
        result.problems.append(f"run.json {limits}")
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
        direction = direction_problem(info, str(config.get("task", {}).get("fitness", "")))
        if direction is not None:
            result.problems.append(direction)
    folder = RunFolder(run_dir)
    if not os.path.lexists(folder.checkpoint):
        return
    name = relative(run_dir, folder.checkpoint)
    try:
        state = folder.load_checkpoint()
    except NotARunError as exc:
        result.problems.append(f"{name} {str(exc).removeprefix(f'{folder.checkpoint}: ')}")
        return
    if isinstance(state, dict) and state.get("config_hash") != recorded:
        result.problems.append(f"{name} has a config_hash that is not run.json's")


def _footer(path: Path) -> pq.FileMetaData | None:
    """The Parquet footer of the table file ``path``; None where it does not decode (a run made
    before manifests: `_check_readable` says so; else the reader does)."""
    try:
        return pq.read_metadata(os.path.abspath(path))  # pyarrow would expand a leading "~"
    except Exception:
        return None


def _check_rows(path: Path, metadata: pq.FileMetaData | None, config: object) -> str | None:
    """A sound table file's row count and decoded size against what the run's config makes
    (`rows_problem`, `size_problem`: its rows, not this machine's memory), from its footer
    ``metadata`` (and a dictionary's indices)."""
    if metadata is None:
        return None
    config = config if isinstance(config, dict) else None
    try:
        return rows_problem(config, path, metadata) or size_problem(
            config, path, metadata, os.path.abspath(path), memory=False
        )
    except Exception:  # not Parquet after all: a run made before manifests says so when read
        return None


def _check_ids(run_dir: Path, name: str, info: Mapping[str, object], result: VerifyResult) -> None:
    """The ids and statuses of a sound evaluations or bodies table's rows: the ``run_id``
    run.json's (`run_id_problem`), each id an id and each status one a run writes
    (`id_problem`), as `load_run` checks them."""
    wanted = ["run_id", *ID_PROBLEM_COLUMNS]
    try:  # not "~" expanded
        path = os.path.abspath(run_dir / name)
        present = [c for c in wanted if c in pq.read_schema(path).names]
        table = pq.read_table(path, columns=present)
    except Exception:  # a table that does not decode: `_check_file` says so
        return
    result.run_id_checked = True
    problem = run_id_problem(table, info.get("run_id")) or id_problem(table)
    if problem is not None:
        result.problems.append(f"{name} {problem}")


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
    if not within(path, run_dir):  # the file, or a folder on its way, a link elsewhere
        return "is a symbolic link out of the run folder"
    if path.is_symlink():
        return "is a symbolic link"
    if not path.is_file():
        return "is missing" if not os.path.lexists(path) else "is not a file"
    result.files += 1
    if entry is None:
        result.bytes += path.stat().st_size
        metadata = _footer(path)
        return (
            _check_rows(path, metadata, config)
            or _check_readable(path)
            or _check_generations(path, metadata)
        )
    try:
        size, digest = sha256_file(path)
    except OSError as exc:
        return f"is unreadable ({exc.strerror})"
    result.bytes += size
    if size != entry[0]:
        return f"has {size} bytes, not {entry[0]}"
    if digest != entry[1]:
        return "has other bytes than when it was written (SHA-256)"
    metadata = _footer(path)
    return _check_rows(path, metadata, config) or _check_generations(path, metadata)


def _check_generations(path: Path, metadata: pq.FileMetaData | None) -> str | None:
    """What is wrong with the ``generation`` column of the table file ``path`` (none where it
    does not decode: `_check_readable` or the reader says so). Read from the footer's
    statistics (``metadata``) where every row group has them (a min and max of the file's
    generation: nothing decoded), else from the column."""
    if metadata is None:
        return None
    try:
        if _one_generation_in_footer(metadata, path):
            return None
        part = pq.read_table(os.path.abspath(path), columns=["generation"])  # not "~" expanded
    except Exception:
        return None
    return generation_problem(part, path)


def _one_generation_in_footer(metadata: pq.FileMetaData, path: Path) -> bool:
    """Whether the footer's statistics say every row's ``generation`` is the one in the file's
    name (False: they do not, or cannot say: the column is then read)."""
    found = GEN_FILE.match(path.name)
    names = [metadata.schema.column(i).path for i in range(metadata.num_columns)]
    if found is None or "generation" not in names:
        return False
    column, generation = names.index("generation"), int(found.group(1))
    for group in range(metadata.num_row_groups):
        stats = metadata.row_group(group).column(column).statistics
        if stats is None or not stats.has_min_max or (stats.min, stats.max) != (generation,) * 2:
            return False
    return True


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
