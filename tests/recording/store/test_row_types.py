"""Typed rows: each table's row is declared once (`ariel.recording.store._row_types`), its Arrow
schema derived from it exactly as the schemas were written by hand before, and a row or a table
with a key too many or too few is an internal error naming the table and the key, never a column
of nulls."""

from __future__ import annotations

import math
from dataclasses import fields
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pyarrow as pa
import pytest

from ariel.recording.store._row_types import ArchiveRow, EvaluationRow, RowError
from ariel.recording.store._rows import RunWriter
from ariel.recording.store._tables import (
    archive_schema,
    body_schema,
    evaluation_schema,
    trajectory_schema,
    write_table,
)

# The schemas as they were written by hand before the rows were declared (frozen here).
_COUNTS = ["num_modules", "num_hinges", "num_bricks", "num_limbs", "num_core_children", "depth"]
_MEASURES = ["branching", "joints_ratio", "symmetry", "extent_x", "extent_y", "extent_z"]
_DESCRIPTORS = [(n, pa.int32()) for n in _COUNTS] + [(n, pa.float64()) for n in _MEASURES]
_OLD_SCHEMAS = {
    "evaluations": pa.schema(
        [
            ("run_id", pa.string()),
            ("generation", pa.int32()),
            ("body_id", pa.string()),
            ("eval_id", pa.string()),
            ("iteration", pa.int32()),
            ("candidate", pa.int32()),
            ("parent_ids", pa.list_(pa.string())),
            ("body_encoder", pa.string()),
            ("body_genotype", pa.string()),
            ("controller", pa.string()),
            ("controller_params", pa.list_(pa.float64())),
            ("world", pa.string()),
            ("fitness_fn", pa.string()),
            ("settle_seconds", pa.float64()),
            ("fitness", pa.float64()),
            ("status", pa.string()),
            ("error", pa.string()),
            *_DESCRIPTORS,
            ("n_joints", pa.int32()),
            ("joint_names", pa.list_(pa.string())),
            ("seed", pa.int64()),
            ("sim_seconds", pa.float64()),
            ("wall_seconds", pa.float64()),
            ("backend", pa.string()),
        ]
    ),
    "bodies": pa.schema(
        [
            ("run_id", pa.string()),
            ("generation", pa.int32()),
            ("body_id", pa.string()),
            ("parent_ids", pa.list_(pa.string())),
            ("born_generation", pa.int32()),
            ("body_encoder", pa.string()),
            ("body_genotype", pa.string()),
            ("graph", pa.string()),
            *_DESCRIPTORS,
            ("n_joints", pa.int32()),
            ("status", pa.string()),
            ("error", pa.string()),
            ("fitness", pa.float64()),
            ("best_eval_id", pa.string()),
            ("evaluations", pa.int32()),
            ("is_new", pa.bool_()),
            ("selected", pa.bool_()),
        ]
    ),
    "trajectories": pa.schema(
        [
            ("generation", pa.int32()),
            ("eval_id", pa.string()),
            ("t", pa.float64()),
            ("core_x", pa.float64()),
            ("core_y", pa.float64()),
            ("core_z", pa.float64()),
            ("joint_target", pa.list_(pa.float64())),
            ("joint_angle", pa.list_(pa.float64())),
        ]
    ),
    "archive": pa.schema(
        [
            ("generation", pa.int32()),
            ("cell", pa.int32()),
            ("body_id", pa.string()),
            ("fitness", pa.float64()),
            ("objective", pa.float64()),
            ("measures", pa.list_(pa.float64())),
            ("grid", pa.list_(pa.int32())),
        ]
    ),
}
_DERIVED = {
    "evaluations": evaluation_schema,
    "bodies": body_schema,
    "trajectories": trajectory_schema,
    "archive": archive_schema,
}


@pytest.mark.parametrize("table", list(_OLD_SCHEMAS))
def test_the_derived_schema_is_the_hand_written_one(table: str) -> None:
    derived = _DERIVED[table]()
    assert derived.equals(_OLD_SCHEMAS[table], check_metadata=True)
    assert all(f.nullable for f in derived)
    # The same bytes in a Parquet footer: the schemas serialise identically.
    assert derived.serialize().to_pybytes() == _OLD_SCHEMAS[table].serialize().to_pybytes()


def _evaluation() -> dict[str, Any]:
    return {f.name: None for f in fields(EvaluationRow)} | {"descriptors": {}}


def test_a_row_with_a_misspelt_key_names_the_table_and_the_key() -> None:
    EvaluationRow.of(_evaluation())  # the well-formed row is accepted
    with pytest.raises(RowError, match=r"internal error: .*evaluations table .*'fitnes'"):
        EvaluationRow.of(_evaluation() | {"fitnes": 1.0})
    with pytest.raises(RowError, match=r"evaluations table .*'num_modulez'"):
        EvaluationRow.of(_evaluation() | {"descriptors": {"num_modulez": 3}})


def test_a_row_with_a_missing_key_names_the_table_and_the_key() -> None:
    values = _evaluation()
    del values["backend"]
    with pytest.raises(RowError, match=r"internal error: .*evaluations table lacks key 'backend'"):
        EvaluationRow.of(values)
    some = {"num_modules": 3}  # descriptors: every one or none
    with pytest.raises(RowError, match=r"evaluations table lacks key 'num_hinges'"):
        EvaluationRow.of(_evaluation() | {"descriptors": some})


def _writer(path: Path) -> RunWriter:
    config = SimpleNamespace(record=SimpleNamespace(rerun=False, trajectories=False))
    return RunWriter(SimpleNamespace(path=str(path)), config, "run")


def test_writing_a_generation_with_a_misspelt_archive_key_fails(tmp_path: Path) -> None:
    cell = {"cell": 0, "body_id": "b000001", "fitness": 1.0, "objective": 1.0, "grid": [2]}
    with pytest.raises(RowError, match=r"archive table has key 'mesures'"):
        _writer(tmp_path).write_generation(0, [], [cell | {"mesures": [0.5]}])
    with pytest.raises(RowError, match=r"archive table lacks key 'measures'"):
        _writer(tmp_path).write_generation(0, [], [cell])
    assert not (tmp_path / "archive").exists()
    row = ArchiveRow.of({"generation": 0, **cell, "measures": [math.pi]})
    assert list(row.record()) == archive_schema().names


def test_a_table_written_with_a_column_too_many_or_too_few_fails(tmp_path: Path) -> None:
    columns = {name: [] for name in trajectory_schema().names}
    with pytest.raises(RowError, match=r"trajectories table has key 'core_w'"):
        write_table(tmp_path, "trajectories", 0, columns | {"core_w": []})
    del columns["t"]
    with pytest.raises(RowError, match=r"trajectories table lacks key 't'"):
        write_table(tmp_path, "trajectories", 0, columns)
    assert not (tmp_path / "trajectories").exists()
