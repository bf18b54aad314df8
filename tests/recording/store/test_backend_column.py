"""The evaluations table's later columns (``backend``, ``settle_seconds``): written by the loop,
and an older run folder without them still loads, its rows reading as they were made (the CPU
engine, no settle)."""

from __future__ import annotations

import pyarrow as pa
import pyarrow.parquet as pq

from ariel.recording.store._tables import (
    evaluation_schema,
    generation_file,
    read_table,
    write_table,
)


def _rows(schema: pa.Schema, backend: str | None) -> dict[str, list]:
    columns = {f.name: [None, None] for f in schema}
    columns.update(eval_id=["a", "b"], fitness=[1.0, 2.0], status=["ok", "ok"])
    if "backend" in columns:
        columns["backend"] = [backend, backend]
    return columns


def test_a_file_from_before_the_backend_column_reads_as_the_cpu_engine(tmp_path) -> None:
    old = pa.schema([f for f in evaluation_schema() if f.name not in ("backend", "settle_seconds")])
    path = generation_file(tmp_path, "evaluations", 0)
    path.parent.mkdir(parents=True)
    pq.write_table(pa.Table.from_pydict(_rows(old, None), schema=old), path)
    write_table(tmp_path, "evaluations", 1, _rows(evaluation_schema(), "mujoco-warp:cuda"))
    table = read_table(tmp_path, "evaluations")
    assert table.schema == evaluation_schema()
    assert table.column("backend").to_pylist() == ["mujoco"] * 2 + ["mujoco-warp:cuda"] * 2
    assert table.column("fitness").to_pylist() == [1.0, 2.0, 1.0, 2.0]
    assert table.column("settle_seconds").to_pylist() == [0.0, 0.0, None, None]


def test_nulls_in_a_file_with_the_column_stay_null(tmp_path) -> None:
    # A body that could not be built has no backend: no physics ran.
    write_table(tmp_path, "evaluations", 0, _rows(evaluation_schema(), None))
    assert read_table(tmp_path, "evaluations").column("backend").to_pylist() == [None, None]
