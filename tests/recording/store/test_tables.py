"""The tables for pandas: integer counts (older float files still load), fixed-size joint
signal lists and `Run.joint_signals`, the population's mean morphology in `Run.generations`,
and `Run`'s short repr."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import tiny_finished_run

from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES
from ariel.recording import load_run, table_schema
from ariel.recording.store._tables import (
    COUNT_DESCRIPTORS,
    body_schema,
    generation_file,
    read_table,
    to_pandas,
    write_table,
)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_finished_run(tmp_path_factory, "tables", 5)


def _body_rows(schema: pa.Schema, modules: list) -> dict[str, list]:
    columns = {f.name: [None] * len(modules) for f in schema}
    columns.update(body_id=[f"b{i}" for i in range(len(modules))], num_modules=modules)
    return columns


# -- counts ------------------------------------------------------------------------------------


def test_count_descriptors_are_integers_in_a_run(run_dir: Path) -> None:
    run = load_run(run_dir)
    for table in (run.evaluations, run.bodies):
        for name in COUNT_DESCRIPTORS:
            assert pd.api.types.is_integer_dtype(table[name]), (name, table[name].dtype)
        others = [n for n in DESCRIPTOR_NAMES if n not in COUNT_DESCRIPTORS]
        assert all(table[n].dtype == np.float64 for n in others)
    for name in ("evaluations", "bodies"):
        stored = pq.read_schema(generation_file(run_dir, name, 0))
        assert all(stored.field(n).type == pa.int32() for n in COUNT_DESCRIPTORS)


def test_a_count_with_nulls_reads_as_nullable_integers(tmp_path: Path) -> None:
    # A body that could not be built has no descriptors.
    write_table(tmp_path, "bodies", 0, _body_rows(body_schema(), [3, None]))
    frame = to_pandas(read_table(tmp_path, "bodies"))
    assert frame["num_modules"].dtype == pd.Int32Dtype()
    assert frame["num_modules"].tolist()[0] == 3 and frame["num_modules"].isna().tolist()[1]
    write_table(tmp_path, "bodies", 1, _body_rows(body_schema(), [3, 4]))
    whole = to_pandas(read_table(tmp_path, "bodies"))
    assert whole["num_modules"].dtype == pd.Int32Dtype()  # nulls in one file: nullable in all
    only = to_pandas(read_table(tmp_path, "bodies", up_to=1).slice(2))
    assert only["num_modules"].dtype == np.int32


def test_a_file_with_float_counts_from_before_reads_as_integers(tmp_path: Path) -> None:
    old = pa.schema(
        [
            pa.field(f.name, pa.float64()) if f.name in COUNT_DESCRIPTORS else f
            for f in body_schema()
        ]
    )
    path = generation_file(tmp_path, "bodies", 0)
    path.parent.mkdir(parents=True)
    pq.write_table(pa.Table.from_pydict(_body_rows(old, [8.0, None]), schema=old), path)
    table = read_table(tmp_path, "bodies")
    assert table.schema == body_schema()
    assert table.column("num_modules").to_pylist() == [8, None]


# -- joint signals -----------------------------------------------------------------------------


class _Frames:
    def __init__(self, steps: int, joints: int) -> None:
        self.time = np.arange(steps) * 0.1
        self.core_pos = np.zeros((steps, 3))
        self.joint_target = np.arange(steps * joints, dtype=float).reshape(steps, joints)
        self.joint_angle = -self.joint_target


def test_joint_lists_are_fixed_size_where_every_row_has_as_many_joints(tmp_path: Path) -> None:
    from ariel.recording.store._tables import trajectory_columns

    write_table(tmp_path, "trajectories", 0, trajectory_columns(0, [("a", _Frames(3, 2))] * 2))
    write_table(tmp_path, "trajectories", 1, trajectory_columns(1, [("b", _Frames(2, 2))]))
    both = read_table(tmp_path, "trajectories")
    assert both.schema.field("joint_angle").type == pa.list_(pa.float64(), 2)
    mixed = [("c", _Frames(2, 3)), ("d", _Frames(2, 1))]
    write_table(tmp_path, "trajectories", 2, trajectory_columns(2, mixed))
    stored = pq.read_schema(generation_file(tmp_path, "trajectories", 2))
    assert stored.field("joint_target").type == pa.list_(pa.float64())
    every = read_table(tmp_path, "trajectories")  # files of other sizes: variable lists
    assert every.schema.field("joint_target").type == pa.list_(pa.float64())
    assert every.column("joint_target").to_pylist()[-1] == [1.0]
    assert every.column("joint_target").to_pylist()[:2] == [[0.0, 1.0], [2.0, 3.0]]
    # pandas refuses the folder as it is (fixed-size and variable lists), reads it with the
    # table's schema (docs/records.md)
    folder = tmp_path / "trajectories"
    with pytest.raises(pa.ArrowInvalid):
        pd.read_parquet(folder)
    frame = pd.read_parquet(folder, schema=table_schema("trajectories"))
    assert len(frame) == every.num_rows and list(frame["joint_target"].iloc[-1]) == [1.0]
    with pytest.raises(ValueError, match="no table 'trajectory'; the tables: evaluations"):
        table_schema("trajectory")


def test_joint_signals_are_a_time_by_joint_frame(run_dir: Path) -> None:
    run = load_run(run_dir)
    row = run.evaluations[run.evaluations["status"] == "ok"].iloc[-1]
    signals = run.joint_signals(row["eval_id"])
    joints = list(row["joint_names"])
    assert list(signals.columns.names) == ["signal", "joint"]
    assert list(signals["target"].columns) == joints == list(signals["angle"].columns)
    frames = run.trajectories[run.trajectories["eval_id"] == row["eval_id"]].sort_values("t")
    np.testing.assert_array_equal(signals.index.to_numpy(), frames["t"].to_numpy())
    np.testing.assert_array_equal(signals["target"].to_numpy(), np.stack(frames["joint_target"]))
    np.testing.assert_array_equal(signals["angle"].to_numpy(), np.stack(frames["joint_angle"]))
    assert signals.index.name == "t"


def test_joint_signals_of_an_unknown_evaluation_is_one_line(run_dir: Path) -> None:
    from ariel.errors import UnknownEvaluationError

    with pytest.raises(UnknownEvaluationError, match="no evaluation 'b999999-i000-c000'"):
        load_run(run_dir).joint_signals("b999999-i000-c000")


# -- generations and repr ----------------------------------------------------------------------


def test_generations_hold_the_populations_mean_morphology(run_dir: Path) -> None:
    run = load_run(run_dir)
    generations, bodies = run.generations, run.bodies
    for name in DESCRIPTOR_NAMES:
        assert f"mean_{name}" in generations.columns
    for _, row in generations.iterrows():
        population = bodies[(bodies["generation"] == row["generation"]) & bodies["selected"]]
        population = population[np.isfinite(population["fitness"])]
        assert row["mean_num_modules"] == pytest.approx(population["num_modules"].mean())
        assert row["mean_symmetry"] == pytest.approx(population["symmetry"].mean())


def test_a_run_prints_as_a_short_summary(run_dir: Path) -> None:
    run = load_run(run_dir)
    text = repr(run)
    info = run.info
    assert "\n" not in text and len(text) < 160
    assert text.startswith(f"<Run {info['run_id']}: finished, 2/2 generations, ")
    assert f"{info['evaluations_done']:,} evaluations" in text
    assert f"best fitness {info['best_fitness']:.6g}>" in text
