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
from _helpers import ariel_run, tiny_run_toml

from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES
from ariel.recording import load_run
from ariel.recording._tables import (
    COUNT_DESCRIPTORS,
    body_schema,
    generation_file,
    read_table,
    to_pandas,
    write_table,
)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("tables")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("tables", 5))
    ariel_run(config, folder / "run")
    return folder / "run"


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
