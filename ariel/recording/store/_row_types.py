"""The rows of a run's tables, each declared once: a frozen dataclass per table whose fields, in
order, are the table's columns, each annotated with its column type (`String`, `Int32`, ...:
a Python type and its Arrow type) and, for the evaluation card in a generation's Rerun
recording, `CARD`. The tables' Arrow schemas are derived from these classes (`row_schema`), so
a column is added in one place, its row's class (and, so that older files still read as
before, in `_tables._ADDED_COLUMNS`).

A row is checked when it is made (`Row.of`) and a table when it is written (`check_columns`):
a missing or unknown key is a `RowError` naming the table and the key (a bug in ariel), never a
column of nulls.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from functools import cache
from typing import Annotated, Any, ClassVar, Self, get_type_hints

import pyarrow as pa

from ariel.body_phenotypes.robogen_lite.config import COUNT_DESCRIPTORS, DESCRIPTOR_NAMES

__all__ = [
    "COUNT_DESCRIPTORS",
    "ROWS",
    "ArchiveRow",
    "BodyRow",
    "EvaluationRow",
    "NoveltyRow",
    "Row",
    "RowError",
    "TrajectoryRow",
    "check_columns",
    "row_schema",
    "table_columns",
]

# COUNT_DESCRIPTORS (`robogen_lite.config`): integers in the tables (null for a body that could
# not be built; pandas reads such a column as the nullable ``Int32``). Files written before they
# were integers (float64 columns) are cast on read.


class RowError(TypeError):
    """A row (or a table's columns) with a key its table does not declare, or without one it
    declares: an internal error of ariel, named by the table and the key."""


def _unknown(table: str, key: str) -> RowError:
    return RowError(f"internal error: a row of the {table} table has key {key!r}, no column of it")


def _missing(table: str, key: str) -> RowError:
    return RowError(f"internal error: a row of the {table} table lacks key {key!r}")


class _Mark:
    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return self.name


#: In a field's `Annotated` type: the field is shown on the row's Rerun card.
CARD = _Mark("CARD")
#: The field's type: the morphology descriptors, a mapping name -> value that is one column per
#: descriptor (`descriptor_fields`); every descriptor or none (a body without a graph: nulls).
_DESCRIPTORS = _Mark("DESCRIPTORS")
Descriptors = Annotated[Mapping[str, float | int], _DESCRIPTORS]

# Column types: a Python type annotated with its Arrow type (every column is nullable).
String = Annotated[str, pa.string()]
MaybeString = Annotated[str | None, pa.string()]
Int32 = Annotated[int, pa.int32()]
Int64 = Annotated[int, pa.int64()]
Float64 = Annotated[float, pa.float64()]
Bool = Annotated[bool, pa.bool_()]
Strings = Annotated[list[str], pa.list_(pa.string())]
Floats = Annotated[list[float], pa.list_(pa.float64())]
Int32s = Annotated[list[int], pa.list_(pa.int32())]


@cache
def descriptor_names() -> tuple[str, ...]:
    return DESCRIPTOR_NAMES


def descriptor_fields() -> list[pa.Field]:
    return [
        pa.field(name, pa.int32() if name in COUNT_DESCRIPTORS else pa.float64())
        for name in descriptor_names()
    ]


def _descriptor_values(table: str, values: Mapping[str, object]) -> Mapping[str, object]:
    """``values`` checked: only descriptor names, and all of them unless none."""
    names = descriptor_names()
    for key in values:
        if key not in names:
            raise _unknown(table, key)
    if values and len(values) < len(names):
        raise _missing(table, next(name for name in names if name not in values))
    return values


@dataclass(frozen=True, kw_only=True)
class Row:
    """A row of `table`; its fields are the table's columns, in order."""

    table: ClassVar[str]

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> Self:
        """The row of ``values`` (field name -> value); `RowError` for a key too many or few."""
        names = [column.name for column in _layout(cls)]
        for key in values:
            if key not in names:
                raise _unknown(cls.table, key)
        for name in names:
            if name not in values:
                raise _missing(cls.table, name)
        row = cls(**values)
        for column in _layout(cls):
            if column.arrow is None:
                _descriptor_values(cls.table, values[column.name])
        return row

    def record(self) -> dict[str, object]:
        """The row as its table holds it: column name -> value, in column order."""
        return {name: values[0] for name, values in table_columns(type(self), [self]).items()}

    def card(self) -> dict[str, object]:
        """The fields shown on the row's Rerun card (marked `CARD`), in column order."""
        return {c.name: getattr(self, c.name) for c in _layout(type(self)) if c.card}


@dataclass(frozen=True)
class _Field:
    name: str
    arrow: pa.DataType | None  # None: the descriptors, a column each
    card: bool


@cache
def _layout(cls: type[Row]) -> tuple[_Field, ...]:
    """``cls``'s fields, in order, as their annotations declare them."""
    hints = get_type_hints(cls, include_extras=True)
    out = []
    for f in fields(cls):
        marks = getattr(hints[f.name], "__metadata__", ())
        arrow = [m for m in marks if isinstance(m, pa.DataType)]
        group = any(m is _DESCRIPTORS for m in marks)
        if len(arrow) + group != 1:
            raise TypeError(f"{cls.__name__}.{f.name}: no column type (String, Int32, ...)")
        out.append(_Field(f.name, arrow[0] if arrow else None, any(m is CARD for m in marks)))
    return tuple(out)


@cache
def row_schema(cls: type[Row]) -> pa.Schema:
    """The Arrow schema of ``cls``'s table: its fields in order, each nullable."""
    out: list[pa.Field] = []
    for column in _layout(cls):
        if column.arrow is None:
            out += descriptor_fields()
        else:
            out.append(pa.field(column.name, column.arrow))
    return pa.schema(out)


def table_columns(cls: type[Row], rows: Sequence[Row]) -> dict[str, list[object]]:
    """``rows`` (all of ``cls``) as the columns of its table, in column order."""
    columns: dict[str, list[object]] = {}
    for column in _layout(cls):
        if column.arrow is None:
            values = [_descriptor_values(cls.table, getattr(row, column.name)) for row in rows]
            columns.update({name: [v.get(name) for v in values] for name in descriptor_names()})
        else:
            columns[column.name] = [getattr(row, column.name) for row in rows]
    return columns


def check_columns(table: str, names: Iterable[str]) -> None:
    """`RowError` unless ``names`` are exactly the columns of ``table``."""
    declared = row_schema(ROWS[table]).names
    given = list(names)
    for key in given:
        if key not in declared:
            raise _unknown(table, key)
    for name in declared:
        if name not in given:
            raise _missing(table, name)


@dataclass(frozen=True, kw_only=True)
class EvaluationRow(Row):
    """One evaluation: candidate ``candidate`` of iteration ``iteration`` of a body's brain run,
    or (``status`` ``error``) a body that could not be built."""

    table: ClassVar[str] = "evaluations"
    run_id: Annotated[String, CARD]
    generation: Annotated[Int32, CARD]
    body_id: Annotated[String, CARD]
    eval_id: Annotated[String, CARD]
    iteration: Annotated[Int32, CARD]
    candidate: Annotated[Int32, CARD]
    parent_ids: Annotated[Strings, CARD]
    body_encoder: Annotated[String, CARD]
    body_genotype: String  # JSON of the genotype's plain data
    controller: Annotated[String, CARD]
    controller_params: Floats
    world: Annotated[String, CARD]
    fitness_fn: Annotated[String, CARD]
    # Seconds the robot was held at rest before the measured window (task.settle).
    settle_seconds: Float64
    fitness: Annotated[Float64, CARD]
    status: Annotated[String, CARD]
    error: Annotated[MaybeString, CARD]
    descriptors: Descriptors
    n_joints: Int32
    joint_names: Strings
    seed: Annotated[Int64, CARD]
    sim_seconds: Float64
    wall_seconds: Float64
    # The simulator that produced the fitness: "mujoco" (the CPU engine) or
    # "mujoco-warp:<device>"; null for a body that could not be built (no physics ran).
    backend: MaybeString


@dataclass(frozen=True, kw_only=True)
class BodyRow(Row):
    """A body taking part in a generation: new in it (``is_new``), kept after it
    (``selected``)."""

    table: ClassVar[str] = "bodies"
    run_id: String
    generation: Int32
    body_id: String
    parent_ids: Strings
    born_generation: Int32
    body_encoder: String
    body_genotype: String
    graph: String  # networkx node-link JSON of the decoded robot graph
    descriptors: Descriptors
    n_joints: Int32
    status: String
    error: String
    fitness: Float64
    best_eval_id: String
    evaluations: Int32
    is_new: Bool
    selected: Bool


@dataclass(frozen=True, kw_only=True)
class TrajectoryRow(Row):
    """One recorded frame of an evaluation (the table is written from arrays as columns,
    `_tables.trajectory_columns`, not row by row)."""

    table: ClassVar[str] = "trajectories"
    generation: Int32
    eval_id: String
    t: Float64
    core_x: Float64
    core_y: Float64
    core_z: Float64
    joint_target: Floats
    joint_angle: Floats


@dataclass(frozen=True, kw_only=True)
class ArchiveRow(Row):
    """A filled cell of a MAP-Elites archive after a generation (what the archive is, a grid or
    a CVT: run.json's ``archive``, `Run.archive_description`)."""

    table: ClassVar[str] = "archive"
    generation: Int32
    cell: Int32  # the cell's index: a grid's row-major over the measures, a CVT's centroid's
    body_id: String  # the elite
    fitness: Float64
    objective: Float64  # what the archive maximises: fitness, or -fitness
    measures: Floats  # the elite's value of each measure
    grid: Int32s  # cells per measure, a CVT's [cells] (coverage = rows / their product)


@dataclass(frozen=True, kw_only=True)
class NoveltyRow(Row):
    """Novelty search after a generation: a body of its population or of its novelty archive
    (`ariel.evolution.NoveltySearch`; the ``novelty`` table, novelty runs only)."""

    table: ClassVar[str] = "novelty"
    generation: Int32
    body_id: String
    place: Floats  # the body's measures mapped to [0, 1]: where novelty is measured
    novelty: Float64  # among the archive and the population; NaN: not in the population
    local_competition: Int32  # neighbours it outwalks; -1: not in the population
    rank: Int32  # place in the population's ranking, 0 = best; -1: not in the population
    in_archive: Bool  # a member of the novelty archive after the generation


#: Table name -> its row.
ROWS: dict[str, type[Row]] = {
    cls.table: cls for cls in (EvaluationRow, BodyRow, TrajectoryRow, ArchiveRow, NoveltyRow)
}
