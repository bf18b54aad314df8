"""The run's Parquet tables: one file per table per generation, written whole.

``evaluations/gen-NNNNNN.parquet``: one row per evaluation. ``bodies/gen-NNNNNN.parquet``: one
row per body taking part in the generation (its parents and its offspring).
``trajectories/gen-NNNNNN.parquet``: one row per recorded frame of every evaluation.
``archive/gen-NNNNNN.parquet`` (MAP-Elites runs only): one row per filled cell of the archive
after the generation. Each table's columns are declared once, by its row's class in
`_row_types`; the schemas here are derived from them.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ariel.errors import DamagedRunError
from ariel.recording.store._escape import one_line
from ariel.recording.store._files import atomic_write, damaged, within
from ariel.recording.store._row_types import (
    COUNT_DESCRIPTORS,
    ArchiveRow,
    BodyRow,
    EvaluationRow,
    NoveltyRow,
    TrajectoryRow,
    check_columns,
    row_schema,
)
from ariel.recording.store._table_limits import (
    GEN_NAME,
    ROW_MARGIN,
    MemoryProblem,
    limits_problem,
    row_limit,
    rows_problem,
    rows_problem_of,
    size_problem,
)

if TYPE_CHECKING:
    import pandas as pd

    from ariel.evaluation import EvaluationResult
    from ariel.recording.store._load import Run
    from ariel.recording.store._manifest import Manifest

__all__ = [
    "COUNT_DESCRIPTORS",
    "GENERATION_BLUEPRINT",
    "GENERATION_RECORDING",
    "ROW_MARGIN",
    "TABLES",
    "archive_schema",
    "body_schema",
    "evaluation_schema",
    "evaluation_trajectory",
    "generation_file",
    "generation_recording_path",
    "manifest_file",
    "manifest_generations",
    "read_file",
    "read_table",
    "recording_generations",
    "recording_path",
    "row_limit",
    "rows_problem",
    "table_generations",
    "table_schema",
    "to_pandas",
    "trajectory_columns",
    "trajectory_schema",
    "write_table",
]

#: Table name -> folder in the run folder.
TABLES: tuple[str, ...] = ("evaluations", "bodies", "trajectories", "archive", "novelty")
#: Where each finished generation's manifest (its tables' sizes and SHA-256) lives.
MANIFEST_DIR = "manifests"


def evaluation_schema() -> pa.Schema:
    return row_schema(EvaluationRow)


#: Columns added after runs were recorded, and what an older file's rows read as.
_ADDED_COLUMNS: dict[str, dict[str, object]] = {
    "evaluations": {"backend": "mujoco", "settle_seconds": 0.0}
}

#: Columns no writer leaves null in any row (ids, the generation, flags, a frame's time): a
#: null in one is a crafted or damaged file, refused rather than read as something else.
_NEVER_NULL: dict[str, tuple[str, ...]] = {
    "evaluations": ("run_id", "generation", "body_id", "eval_id", "status"),
    "bodies": ("run_id", "generation", "body_id", "is_new", "selected"),
    "trajectories": ("generation", "eval_id", "t"),
    "archive": ("generation", "cell", "body_id"),
    "novelty": ("generation", "body_id", "in_archive"),
}


def body_schema() -> pa.Schema:
    return row_schema(BodyRow)


def trajectory_schema() -> pa.Schema:
    return row_schema(TrajectoryRow)


def archive_schema() -> pa.Schema:
    """A MAP-Elites archive after a generation: one row per filled cell."""
    return row_schema(ArchiveRow)


def novelty_schema() -> pa.Schema:
    """Novelty search after a generation: one row per body of its population or archive."""
    return row_schema(NoveltyRow)


def trajectory_columns(
    generation: int, frames: Sequence[tuple[str, EvaluationResult]]
) -> dict[str, pa.Array]:
    """The ``trajectories`` columns of one generation, from ``(eval_id, result)`` pairs.

    Arrow arrays made from the results' numpy arrays directly: as Python lists (an object per
    number, about a million a generation) they left the driver's heap larger after every
    generation (soak benchmark).
    """
    counts = [int(result.time.size) for _, result in frames]
    rows = np.repeat(np.arange(len(frames), dtype=np.int64), counts)

    def numbers(values: Sequence[np.ndarray]) -> pa.Array:
        flat = [np.asarray(v, dtype=np.float64).ravel() for v in values]
        return pa.array(np.concatenate(flat) if flat else np.zeros(0), pa.float64())

    def lists(name: str) -> pa.Array:
        blocks = [np.asarray(getattr(result, name), dtype=np.float64) for _, result in frames]
        sizes = {block.shape[1] for block in blocks}
        if len(sizes) == 1 and 0 not in sizes:  # every row as wide: a fixed-size list column
            return pa.FixedSizeListArray.from_arrays(numbers(blocks), sizes.pop())
        widths = np.repeat([block.shape[1] for block in blocks], counts).astype(np.int64)
        offsets = pa.array(np.concatenate([[0], np.cumsum(widths)]).astype(np.int32))
        return pa.ListArray.from_arrays(offsets, numbers(blocks))

    columns = {
        "generation": pa.array(np.full(rows.size, generation, dtype=np.int32)),
        "eval_id": pa.array([eval_id for eval_id, _ in frames], pa.string()).take(rows),
        "t": numbers([result.time for _, result in frames]),
    }
    for axis, name in enumerate(("core_x", "core_y", "core_z")):
        columns[name] = numbers([np.asarray(result.core_pos)[:, axis] for _, result in frames])
    columns["joint_target"] = lists("joint_target")
    columns["joint_angle"] = lists("joint_angle")
    return columns


_SCHEMAS = {
    "evaluations": evaluation_schema,
    "bodies": body_schema,
    "trajectories": trajectory_schema,
    "archive": archive_schema,
    "novelty": novelty_schema,
}


def table_schema(table: str) -> pa.Schema:
    """The Arrow schema of one of a run's tables, as `load_run` reads it.

    A whole table folder reads as one dataset with it where pandas or pyarrow would refuse
    the folder: a ``trajectories`` folder's files may hold the joint lists as fixed-size lists
    in one generation and variable lists in another
    (``pandas.read_parquet("RUN/trajectories", schema=table_schema("trajectories"))``).

    Args:
        table: One of ``evaluations``, ``bodies``, ``trajectories``, ``archive``,
            ``novelty``.

    Returns:
        The table's columns and their types (joint lists as variable lists).

    Raises:
        ValueError: For another name.
    """
    if table not in _SCHEMAS:
        raise ValueError(f"no table {str(table)[:40]!r}; the tables: {', '.join(TABLES)}")
    return _SCHEMAS[table]()


def recording_path(run_dir: str | Path, generation: int, eval_id: str) -> Path:
    """Where an evaluation's Rerun recording lives: ``recordings/gen-NNNNNN/<eval_id>.rrd``."""
    return Path(run_dir) / "recordings" / f"gen-{int(generation):06d}" / f"{eval_id}.rrd"


#: A generation's recording of all its evaluations (`write_generation_recording`); no eval id
#: can clash with it (ids look like b000012-i003-c005).
GENERATION_RECORDING = "evaluations.rrd"
#: The layout of the generations' recordings (application id ``ariel-generation``), in the
#: run folder beside ``blueprint.rbl``.
GENERATION_BLUEPRINT = "generation.rbl"


def generation_recording_path(run_dir: str | Path, generation: int) -> Path:
    """``recordings/gen-NNNNNN/evaluations.rrd``: every evaluation of the generation."""
    return recording_path(run_dir, generation, GENERATION_RECORDING[: -len(".rrd")])


def generation_file(run_dir: Path, table: str, generation: int) -> Path:
    return Path(run_dir) / table / f"gen-{generation:06d}.parquet"


def manifest_file(run_dir: str | Path, generation: int) -> Path:
    return Path(run_dir) / MANIFEST_DIR / f"gen-{int(generation):06d}.json"


def _numbered(folder: Path, suffix: str) -> list[int]:
    """The generations ``folder`` holds a ``gen-NNNNNN<suffix>`` of, ascending (none: no
    such folder)."""
    try:
        names = [path.name for path in folder.iterdir()]
    except OSError:
        return []
    pattern = re.compile(rf"{GEN_NAME}{re.escape(suffix)}")
    return sorted(int(m.group(1)) for m in map(pattern.fullmatch, names) if m)


def manifest_generations(run_dir: str | Path) -> list[int]:
    """The generations that manifests/ holds a ``gen-NNNNNN.json`` of, ascending."""
    return _numbered(Path(run_dir) / MANIFEST_DIR, ".json")


def recording_generations(run_dir: str | Path) -> list[int]:
    """The generations that recordings/ holds a ``gen-NNNNNN`` folder (or link) of, ascending."""
    return _numbered(Path(run_dir) / "recordings", "")


def write_table(
    run_dir: Path, table: str, generation: int, columns: Mapping[str, Sequence[object] | pa.Array]
) -> Path:
    """Write one generation's rows (as columns) of ``table``, atomically; returns the path.
    A column too many or too few is a `RowError` naming it."""
    check_columns(table, columns)
    written = pa.schema([_written_field(f, columns[f.name]) for f in _SCHEMAS[table]()])
    arrow = pa.Table.from_pydict({f.name: columns[f.name] for f in written}, schema=written)
    path = generation_file(run_dir, table, generation)
    floats = _float_columns(written)

    def write(temporary: Path) -> None:
        pq.write_table(
            arrow,
            temporary,
            compression="zstd",
            # pyarrow takes column lists here; its stubs say bool
            use_dictionary=[f.name for f in written if f.name not in floats],  # pyright: ignore[reportArgumentType]
            use_byte_stream_split=floats or False,  # pyright: ignore[reportArgumentType]
        )

    atomic_write(path, write, root=run_dir)
    return path


def _float_columns(schema: pa.Schema) -> list[str]:
    """Parquet paths of the float columns (lists' values too). They are written byte stream
    split, not dictionary encoded: the trajectories table (the bulk of a run's Parquet) is
    30 % smaller for it, and the values are the same."""
    paths = []
    for f in schema:
        kind = (
            f.type.value_type
            if pa.types.is_list(f.type) or pa.types.is_fixed_size_list(f.type)
            else f.type
        )
        if pa.types.is_floating(kind):
            paths.append(f"{f.name}.list.element" if kind is not f.type else f.name)
    return paths


def _written_field(field: pa.Field, column: Any) -> pa.Field:
    """``field``, or a fixed-size list of its values where ``column`` is one (every row of the
    file as long: the joint signals of one body's evaluations)."""
    if isinstance(column, pa.FixedSizeListArray) and pa.types.is_list(field.type):
        return pa.field(field.name, pa.list_(field.type.value_type, column.type.list_size))
    return field


def _read_field(field: pa.Field, stored: pa.Field | None) -> pa.Field:
    """How a file's column is read: as in today's schema, but a fixed-size list stays one."""
    if (
        stored is not None
        and pa.types.is_fixed_size_list(stored.type)
        and pa.types.is_list(field.type)
        and stored.type.value_type == field.type.value_type
    ):
        return pa.field(field.name, stored.type)
    return field


def to_pandas(table: pa.Table) -> pd.DataFrame:
    """``table`` as a pandas DataFrame; a count column with nulls (a body that could not be
    built) as the nullable ``Int32`` rather than floats."""
    frame = table.to_pandas()
    for name in COUNT_DESCRIPTORS:
        if name in frame.columns and table.column(name).null_count:
            frame[name] = frame[name].astype("Int32")
    return frame


def table_generations(run_dir: Path, table: str) -> list[int]:
    """Generations with a finished file of ``table``, ascending."""
    return _numbered(Path(run_dir) / table, ".parquet")


def _check_footer(
    run_dir: Path,
    path: Path,
    metadata: pq.FileMetaData,
    data: bytes,
    manifest: Manifest,
    columns: Sequence[str] | None,
) -> None:
    """The rows and decoded size of a file about to be decoded (`rows_problem`,
    `size_problem`), for the run's config; `DamagedRunError` in one line else."""
    config = getattr(manifest, "config", None)
    problem = limits_problem(config)
    if problem is not None:
        raise damaged(run_dir, "run.json", problem)
    problem = rows_problem(config, path, metadata) or size_problem(
        config, path, metadata, pa.BufferReader(data), columns
    )
    if problem is None:
        return
    if not isinstance(problem, MemoryProblem):
        raise _unreadable(run_dir, path, problem)
    # Too big for this machine's memory: no damage, so not `damaged`'s "restore the folder".
    raise DamagedRunError(f"run folder {str(run_dir)!r}: {_name(run_dir, path)} {problem}")


def read_table(
    run_dir: Path,
    table: str,
    up_to: int | None = None,
    manifest: Manifest | None = None,
    columns: Sequence[str] | None = None,
) -> pa.Table:
    """All generations of ``table`` (those <= ``up_to`` when given) as one Arrow table.

    ``manifest`` (`ariel.recording.store._manifest.Manifest`): read the files it lists, each checked
    against it (a missing or changed file raises `DamagedRunError`) and against the rows its
    run's config can make (`row_limit`); without it, the files found. A file that cannot be
    decoded raises `DamagedRunError` too, one line naming it. ``columns``: decode only these.
    """
    schema = _SCHEMAS[table]()
    if columns is not None:
        schema = pa.schema([schema.field(name) for name in columns])
    if manifest is not None:
        paths = [path for _, path in manifest.table_files(table, up_to)]
    else:
        gens = [g for g in table_generations(run_dir, table) if up_to is None or g <= up_to]
        paths = [generation_file(run_dir, table, g) for g in gens]
    parts = [read_file(run_dir, path, table, manifest=manifest, columns=columns) for path in paths]
    if any(part.schema != parts[0].schema for part in parts):
        parts = [part.cast(schema) for part in parts]  # fixed-size lists of other sizes: lists
    return pa.concat_tables(parts) if parts else schema.empty_table()


def _unreadable(run_dir: Path, path: Path, problem: str) -> Exception:
    """The one line for file ``path`` of ``run_dir``; ``problem`` may quote the file's own
    bytes (Arrow's parse errors do), so it is written as one line, escaped (`one_line`)."""
    return damaged(run_dir, _name(run_dir, path), one_line(problem))


def _name(run_dir: Path, path: Path) -> str:
    """``path`` as a line names it: relative to the run folder where it lies in it."""
    return path.relative_to(run_dir).as_posix() if path.is_relative_to(run_dir) else str(path)


def _not_parquet(run_dir: Path, path: Path, exc: Exception) -> Exception:
    first = one_line((str(exc).splitlines() or [""])[0])
    problem = f"is not a readable Parquet table ({type(exc).__name__}: {first})"
    return _unreadable(run_dir, path, problem)


def _column_problem(table: str, stored: set[str], part: pa.Table) -> str | None:
    """What is wrong with the columns of a decoded run's file ``part`` of ``table``
    (``stored``: the columns the file has); None when nothing is. A column the file lacks
    that no older run lacked (`_ADDED_COLUMNS`): Arrow read it as nulls, which must not load
    as the run's values. A null in a column every row of a run has a value in (`_NEVER_NULL`)."""
    added = _ADDED_COLUMNS.get(table, {})
    for name in part.column_names:
        if name not in stored and name not in added:
            return f"has no column {name!r} (every run writes it): crafted or damaged"
    for name in _NEVER_NULL.get(table, ()):
        if name in part.column_names and part.column(name).null_count:
            return f"has a null {name!r} in its rows (no run writes one): crafted or damaged"
    return None


def read_file(
    run_dir: Path,
    path: Path,
    table: str,
    *,
    manifest: Manifest | None = None,
    filters: Sequence[tuple[str, str, object]] | None = None,
    columns: Sequence[str] | None = None,
) -> pa.Table:
    """One file of ``table`` in today's schema (columns it predates get the value they meant
    then), checked against ``manifest`` when given: its bytes, and before anything is decoded,
    its row count against what its run's config can make in a generation (`row_limit`). A link
    out of the run folder is refused: the folder's records are its own files, and a reader must
    not be pointed elsewhere. ``columns``: decode only these (``filters`` may name only them)."""

    run_dir, path = Path(run_dir), Path(path)
    if not within(path, run_dir):  # the file, or a folder on its way, a link elsewhere
        raise _unreadable(run_dir, path, "is a symbolic link out of the run folder")
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise _unreadable(run_dir, path, "is missing") from None
    except OSError as exc:
        raise _unreadable(run_dir, path, f"is unreadable ({exc.strerror})") from None
    if manifest is not None:
        manifest.check_bytes(path, data)
    try:
        parquet = pq.ParquetFile(pa.BufferReader(data))  # reads the footer only
        metadata, stored_schema = parquet.metadata, parquet.schema_arrow
        stored = set(stored_schema.names)
        wanted = set(columns) if columns is not None else None
        fields = [
            _read_field(f, stored_schema.field(f.name) if f.name in stored else None)
            for f in _SCHEMAS[table]()
            if wanted is None or f.name in wanted
        ]
        schema = pa.schema(fields)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise _not_parquet(run_dir, path, exc) from None
    if manifest is not None:
        _check_footer(run_dir, path, metadata, data, manifest, columns)
    try:
        part = pq.read_table(pa.BufferReader(data), schema=schema, filters=filters)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise _not_parquet(run_dir, path, exc) from None
    problem = None
    if manifest is not None:  # a run's file holds what a run writes (a bare table: anything)
        problem = rows_problem_of(part, path, manifest.run_id)
        problem = problem or _column_problem(table, stored, part)
    if problem is not None:
        raise _unreadable(run_dir, path, problem)
    for name, value in _ADDED_COLUMNS.get(table, {}).items():
        if name not in stored and name in schema.names:
            index = part.schema.get_field_index(name)
            column = pa.array([value] * part.num_rows, type=schema.field(name).type)
            part = part.set_column(index, schema.field(name), column)
    return part


def evaluation_trajectory(run: Run, row: Mapping[str, Any]) -> pd.DataFrame | None:
    """The trajectories rows of one evaluation (``row``: its evaluations row), read from its
    generation's file only, as a DataFrame in time order; None when that generation recorded
    no trajectories. ``run``: a `Run` (its path and manifest)."""
    path = generation_file(run.root, "trajectories", int(row["generation"]))
    if not path.is_file():
        return None
    table = read_file(
        run.root,
        path,
        "trajectories",
        manifest=run.manifest,
        filters=[("eval_id", "==", row["eval_id"])],
    )
    return table.to_pandas().sort_values("t")
