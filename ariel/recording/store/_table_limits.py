"""What a table file read from a run folder may hold, checked before it is decoded.

A table file comes from anywhere, and Parquet compresses well: 2,000,000 dictionary-encoded rows
fit in 1 MB, one row holding a list of 150,000,000 doubles in 30 KB. Before a file is decoded,
its footer alone is checked against what the run's config (run.json's) can make:

- its rows (`row_limit`, `rows_problem`): at most `ROW_MARGIN` x what a generation makes;
- its decoded size (`decoded_bytes`, `size_problem`): at most that many rows of `ROW_BYTES`
  each (a row of the evaluations table, its genotype and parameters, is a few KB), and never
  more than a quarter of the memory free here (`MEMORY_SHARE`; pandas takes more again): a
  config edited to allow a million bodies must not let a file fill the machine. Values
  repeated through a Parquet dictionary are counted as decoded (each row its own copy), from
  the dictionary's indices alone.

After decoding, the ``run_id`` column of the evaluations and bodies tables must be run.json's
(`run_id_problem`): the tables' ids reach replays and recordings; and every table's
``generation`` column must be its file's (`generation_problem`): a row is found by its file.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from functools import cache
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ariel.evaluation import FAILED_STATUSES
from ariel.evolution import ExperimentConfig, machine_memory
from ariel.recording.store._escape import short_ascii
from ariel.recording.store._ids import BODY_ID, EVAL_ID

__all__ = [
    "GEN_FILE",
    "GEN_NAME",
    "ID_PROBLEM_COLUMNS",
    "MEMORY_SHARE",
    "ROW_BYTES",
    "ROW_MARGIN",
    "MemoryProblem",
    "config_sections",
    "decoded_bytes",
    "generation_problem",
    "id_problem",
    "limits_problem",
    "row_limit",
    "rows_problem",
    "rows_problem_of",
    "run_id_problem",
    "section_problem",
    "size_problem",
]

#: A generation's name in a run folder (``gen-NNNNNN``, then ``.parquet``, ``.json`` or nothing
#: for a recordings folder): six ASCII digits (``\d`` would take other scripts' digits too, and
#: two names would then stand for one generation).
GEN_NAME = r"gen-([0-9]{6})"
#: A generation's table file.
GEN_FILE = re.compile(rf"^{GEN_NAME}\.parquet$")

#: The row counts `row_limit` works out are the most the writers make; a file is refused only
#: past this many times that, so a miscount here never refuses a run's own records.
ROW_MARGIN = 2

#: The most decoded bytes a row of each table may take. An evaluation holds its body's genotype
#: (JSON, a few KB) and its brain's parameters (a few per joint); a body its genotype and robot
#: graph (JSON, a few KB); a trajectory frame two lists of one value per joint. These are far
#: above what any body of a few hundred modules makes.
ROW_BYTES = {
    "evaluations": 1 << 20,
    "bodies": 1 << 20,
    "trajectories": 64 << 10,
    "archive": 64 << 10,
    "novelty": 64 << 10,
}

#: A table file may take at most this share of the memory free here, decoded (as Arrow data:
#: its pandas frame takes about as much again, its strings more).
MEMORY_SHARE = 0.25

_WIDTHS = {"BOOLEAN": 1, "INT32": 4, "FLOAT": 4, "INT64": 8, "DOUBLE": 8, "INT96": 12}
#: Bytes of each value of a string (or list) column besides its characters: its offset.
_OFFSET = 4


@cache
def _config_defaults() -> dict[str, dict[str, object]]:
    """Every config section's keys and default values (plain data)."""
    return ExperimentConfig().to_plain()


def config_sections() -> tuple[str, ...]:
    """The config's sections (tables): body, brain, world, task, record, executor."""
    return tuple(k for k, v in _config_defaults().items() if isinstance(v, dict))


def section_problem(config: Mapping[str, object], section: str) -> str | None:
    """What is wrong with ``section`` of a run's config (run.json's, plain data): there, but no
    table (``task = null``, crafted or edited); None when fine or missing (its defaults)."""
    part = config.get(section, {})
    if isinstance(part, Mapping):
        return None
    return f"has {section} {short_ascii(part, 40)} in its config, not a section (a table)"


def _config_number(config: Mapping[str, object], key: str, *, whole: bool) -> int | float:
    """``section.key`` of a run's config (run.json's, plain data), its default when missing;
    `ValueError` for a value no ariel writes (a count below 1, a duration or rate that is not a
    positive finite number)."""

    section, name = key.split(".")
    problem = section_problem(config, section)
    if problem is not None:
        raise ValueError(problem)
    part = config.get(section, {})
    assert isinstance(part, Mapping)  # `section_problem`
    value = part.get(name, _config_defaults()[section][name])
    kinds = (int,) if whole else (int, float)
    good = isinstance(value, kinds) and not isinstance(value, bool)
    if not good or not (value >= 1 if whole else math.isfinite(value) and value > 0):
        what = "a whole number >= 1" if whole else "a positive finite number"
        raise ValueError(f"has {key} {short_ascii(value, 40)} in its config, not {what}")
    return value


def row_limit(config: Mapping[str, object] | None, table: str, generation: int) -> int:
    """The most rows ``table``'s file of ``generation`` holds in a run of ``config`` (run.json's
    config, plain data; a missing key counts as its default), as the run driver makes them:

    - ``evaluations``: every body of the generation runs CMA-ES for ``brain.iterations``
      iterations of ``brain.popsize`` (a body that cannot be built or has no parameters: fewer),
      and a generation makes ``body.population`` (generation 0) or ``body.offspring`` bodies
      (a brain-only run: one);
    - ``bodies``, ``archive`` and ``novelty``: the bodies of the generation and the parents it
      keeps (the elites, the novelty archive's members), each once: at most every body made so
      far;
    - ``trajectories``: a frame every ``round(1 / (record.rate_hz x timestep))`` physics steps
      of ``task.duration``, plus the first and last (`ariel.evaluation._engine.frame_steps`):
      at most 3 x duration x rate_hz + 4 per evaluation, whatever the world's timestep.

    `ValueError` (``has KEY VALUE in its config, ...``) for a config value no ariel writes.
    """

    config = config if isinstance(config, Mapping) else {}
    bodies = max(
        _config_number(config, "body.population", whole=True),
        _config_number(config, "body.offspring", whole=True),
    )
    per_body = _config_number(config, "brain.popsize", whole=True) * _config_number(
        config, "brain.iterations", whole=True
    )
    evaluations = int(bodies * per_body)
    if table == "evaluations":
        return evaluations
    if table in ("bodies", "archive", "novelty"):
        return int(bodies) * (max(generation, 0) + 1)
    duration = _config_number(config, "task.duration", whole=False)
    rate = _config_number(config, "record.rate_hz", whole=False)
    return evaluations * (math.ceil(3 * duration * rate) + 4)


def _table_of(path: Path) -> tuple[str, int] | None:
    found = GEN_FILE.match(path.name)
    table = path.parent.name
    if found is None or table not in ROW_BYTES:  # a key per table
        return None
    return table, int(found.group(1))


def limits_problem(config: Mapping[str, object] | None) -> str | None:
    """What in a run's config (run.json's, plain data) keeps its tables' limits (`row_limit`)
    from being worked out: ``has KEY VALUE in its config, ...`` (said of run.json) for a value
    no ariel writes; None when fine. Checked once a run, before its tables' rows and sizes."""
    try:
        row_limit(config, "trajectories", 0)  # reads every key any table's limit reads
    except ValueError as exc:
        return f"{exc}: damaged or crafted, no table of it is loaded"
    return None


def rows_problem(
    config: Mapping[str, object] | None, path: Path, metadata: pq.FileMetaData
) -> str | None:
    """What is wrong with the row count of the table file ``path`` (``TABLE/gen-NNNNNN.parquet``,
    its Parquet footer ``metadata``) for a run of ``config``: ``has N rows; ...`` when it holds
    more than `ROW_MARGIN` x `row_limit`; None when it is fine, or the config is one no ariel
    writes (`limits_problem` says so). Reads the footer only: a crafted file of a few bytes a
    row (2,000,000 dictionary-encoded rows in 1 MB) is refused before gigabytes are decoded."""
    found = _table_of(path)
    if found is None:
        return None
    table, generation = found
    rows = max(
        metadata.num_rows,
        sum(metadata.row_group(i).num_rows for i in range(metadata.num_row_groups)),
    )
    try:
        most = row_limit(config, table, generation)
    except ValueError:
        return None  # `limits_problem` says so
    if rows <= ROW_MARGIN * most:
        return None
    return (
        f"has {rows} rows; generation {generation} of this run's config makes at most {most}: "
        "damaged or crafted, not loaded"
    )


def _wanted(path: str, columns: Iterable[str] | None) -> bool:
    return columns is None or path.split(".", 1)[0] in set(columns)


def decoded_bytes(
    metadata: pq.FileMetaData, columns: Iterable[str] | None = None
) -> tuple[int, list[str]]:
    """From a Parquet footer: about how many bytes the file's ``columns`` (None: all) take
    decoded, every value counted (a list's values, a dictionary's value once per row that
    holds it: its indices), and the column paths whose values are dictionary-encoded strings,
    whose size the footer cannot tell (they count here by their distinct values; see
    `_dictionary_bytes`). Fixed-width values: their count x their width; strings: their
    uncompressed bytes and an offset each."""
    columns = list(columns) if columns is not None else None
    total, dictionaries = 0, set()
    for group in range(metadata.num_row_groups):
        row_group = metadata.row_group(group)
        for index in range(row_group.num_columns):
            chunk = row_group.column(index)
            if not _wanted(chunk.path_in_schema, columns):
                continue
            kind, count = chunk.physical_type, max(chunk.num_values, 0)
            if kind in _WIDTHS:
                total += count * _WIDTHS[kind]
                continue
            if kind == "FIXED_LEN_BYTE_ARRAY":
                width = metadata.schema.column(index).length or 0
                total += count * max(width, 1)
                continue
            total += count * _OFFSET + max(chunk.total_uncompressed_size, 0)
            if chunk.has_dictionary_page:
                dictionaries.add(chunk.path_in_schema)
    return total, sorted(dictionaries)


def _dictionary_bytes(source: pa.NativeFile | str | Path, paths: list[str]) -> int:
    """The characters the dictionary-encoded string columns ``paths`` of the Parquet file
    ``source`` hold decoded (each row its own copy), read as dictionaries (indices and distinct
    values only), a row group at a time."""
    file = pq.ParquetFile(source, read_dictionary=paths)
    names = sorted({path.split(".", 1)[0] for path in paths})
    total = 0
    for group in range(file.num_row_groups):
        for column in file.read_row_group(group, columns=names).columns:
            for chunk in column.chunks:
                while not pa.types.is_dictionary(chunk.type):
                    if not hasattr(chunk, "flatten"):
                        break
                    chunk = chunk.flatten()
                if not pa.types.is_dictionary(chunk.type) or not len(chunk.dictionary):
                    continue
                lengths = pc.call_function("binary_length", [chunk.dictionary])
                lengths = lengths.to_numpy(zero_copy_only=False)
                indices = chunk.indices.fill_null(0).to_numpy(zero_copy_only=False)
                total += int(lengths[indices].sum())
    return total


def _gb(count: float) -> str:
    return f"{count / 1e9:.2f} GB" if count >= 1e8 else f"{count / 1e6:.1f} MB"


class MemoryProblem(str):
    """A `size_problem` of a file its run's config allows that is too big for the memory free
    on this machine: no damage (another machine may read it), so not said as damage."""


def size_problem(
    config: Mapping[str, object] | None,
    path: Path,
    metadata: pq.FileMetaData,
    source: pa.NativeFile | str | Path,
    columns: Iterable[str] | None = None,
    *,
    memory: bool = True,
) -> str | None:
    """What is wrong with the decoded size of the table file ``path`` (its footer ``metadata``,
    its bytes ``source``) for a run of ``config``, reading ``columns`` (None: all): ``would take
    ...`` when it is more than its rows can (`ROW_MARGIN` x `row_limit` x `ROW_BYTES`), or a
    `MemoryProblem` when more than `MEMORY_SHARE` of the memory free here (``memory``); None
    when fine (or no table's file, or a config `limits_problem` refuses). Only
    dictionary-encoded strings are read (their indices), and only when they could matter."""
    found = _table_of(path)
    if found is None:
        return None
    table, generation = found
    try:
        most = ROW_MARGIN * row_limit(config, table, generation) * ROW_BYTES[table]
    except ValueError:
        return None  # `limits_problem` says so
    free = machine_memory() if memory else None
    limit = most if free is None else min(most, int(free * MEMORY_SHARE))
    size, dictionaries = decoded_bytes(metadata, columns)
    if size <= limit and dictionaries:
        worst = sum(  # each row holding a copy of every distinct value
            chunk.num_values * chunk.total_uncompressed_size
            for group in range(metadata.num_row_groups)
            for chunk in map(metadata.row_group(group).column, range(metadata.num_columns))
            if chunk.path_in_schema in dictionaries
        )
        if size + worst > limit:
            size += _dictionary_bytes(source, dictionaries)
    if size <= limit:
        return None
    if size > most:
        rows = ROW_MARGIN * row_limit(config, table, generation)
        return (
            f"would take {_gb(size)} decoded; the {rows} rows this run's config allows take at "
            f"most {_gb(most)}: damaged or crafted, not loaded"
        )
    return MemoryProblem(
        f"would take {_gb(size)} decoded, more than {MEMORY_SHARE:.0%} of the {_gb(free or 0)} "
        "of memory free here: not loaded"
    )


def _others(part: pa.Table, column: str, expected: object) -> list[object]:
    """The values of ``column`` in ``part`` other than ``expected`` (none: no such column)."""
    if column not in part.column_names:
        return []
    return [value for value in part.column(column).unique().to_pylist() if value != expected]


def run_id_problem(part: pa.Table, run_id: object) -> str | None:
    """What is wrong with the ``run_id`` column of a decoded table ``part`` (the evaluations
    or bodies table; none: nothing) for a run whose run.json says ``run_id``."""
    others = _others(part, "run_id", run_id) if isinstance(run_id, str) else []
    if not others:
        return None
    return (
        f"has run_id {short_ascii(others[0])} in its rows, run.json {short_ascii(run_id)}: "
        "changed by hand or crafted, not loaded"
    )


def generation_problem(part: pa.Table, path: Path) -> str | None:
    """What is wrong with the ``generation`` column of a decoded table ``part`` read from the
    file ``path`` (``TABLE/gen-NNNNNN.parquet``; another file: nothing): a row of another
    generation would be shown as one of this file's, and looked for in vain in its own."""
    found = _table_of(path)
    others = _others(part, "generation", found[1]) if found is not None else []
    if not others or found is None:
        return None
    return (
        f"has generation {short_ascii(others[0])} in its rows, its name {found[1]}: changed by "
        "hand or crafted, not loaded"
    )


#: The shape each id column's values must have; ``best_eval_id`` is also "" (no best yet).
_ID_COLUMNS = {"eval_id": EVAL_ID, "body_id": BODY_ID, "best_eval_id": EVAL_ID}
#: The columns `id_problem` reads (`ariel verify` reads only these, with ``run_id``).
ID_PROBLEM_COLUMNS = (*_ID_COLUMNS, "parent_ids", "status")
#: What a row's ``status`` may be (records.md): an evaluation's, a body's ("ok" or "error").
_STATUSES = frozenset(("ok", *FAILED_STATUSES))


def id_problem(part: pa.Table) -> str | None:
    """What is wrong with the id and status columns of a decoded table ``part`` (none:
    nothing): an id that is not one (a crafted ``eval_id`` reached `report`'s lines and the
    lineage CSV; `export`, `replay` and `view` refuse it one by one) or a status no run writes
    (a CSV formula, control characters)."""
    for column, pattern in _ID_COLUMNS.items():
        if column not in part.column_names:
            continue
        for value in part.column(column).unique().to_pylist():
            if value is None or (value == "" and column == "best_eval_id"):
                continue  # null says nothing (no run writes it); "": no best evaluation yet
            if not (isinstance(value, str) and pattern.fullmatch(value)):
                return f"has {column} {short_ascii(value)}, not an id: changed by hand or crafted"
    if "parent_ids" in part.column_names:  # a list of body ids per row
        chunks = part.column("parent_ids").chunks
        parents = {value for chunk in chunks for value in chunk.flatten().unique().to_pylist()}
        for value in parents:
            if value is not None and not (isinstance(value, str) and BODY_ID.fullmatch(value)):
                return (
                    f"has parent_ids {short_ascii(value)}, not a body id: changed by hand or "
                    "crafted"
                )
    if "status" in part.column_names:
        for value in part.column("status").unique().to_pylist():
            if value is not None and value not in _STATUSES:
                return (
                    f"has status {short_ascii(value)}, not one a run writes "
                    f"({', '.join(sorted(_STATUSES))}): changed by hand or crafted"
                )
    return None


def rows_problem_of(part: pa.Table, path: Path, run_id: object) -> str | None:
    """What is wrong with the rows of a run's decoded table ``part`` read from ``path``: their
    run id (`run_id_problem`), generation (`generation_problem`), ids and statuses
    (`id_problem`); None: nothing."""
    return run_id_problem(part, run_id) or generation_problem(part, path) or id_problem(part)
