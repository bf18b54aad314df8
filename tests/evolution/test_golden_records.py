"""Records of fixed runs, bit for bit, against digests taken before the loop was rebuilt.

`golden_records.json` holds, per config below, the SHA-256 of every table of every generation
(rows in id order, every cell in a bit-exact form; the ``wall_seconds`` column, a measured time,
left out). It was written by the loop before it was split into body optimizers, a scheduler
and row builders, and the rebuilt loop gave the same records. Written again only when records
change on purpose (``python tests/evolution/test_golden_records.py``), and said so in the commit:
since then once, for the integer count columns (the same values, cast).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # _helpers, when run as a script
from _helpers import plain

GOLDEN = Path(__file__).with_name("golden_records.json")

_COEVOLVE = {
    "name": "golden",
    "seed": 11,
    "generations": 3,
    "body": {"options": {"number_of_modules": 8}, "population": 3, "offspring": 4},
    "brain": {"popsize": 4, "iterations": 2},
    "task": {"duration": 0.6},
    "record": {"rerun": False, "rate_hz": 10.0},
    "executor": {"kind": "serial"},
}

CONFIGS: dict[str, dict[str, Any]] = {
    "coevolve": _COEVOLVE,
    "coevolve_inherit_generational": {
        **_COEVOLVE,
        "seed": 12,
        "body": {**_COEVOLVE["body"], "survivors": "generational", "crossover_rate": 0.9},
        "brain": {**_COEVOLVE["brain"], "inherit": True},
    },
    "brain_only_gecko": {
        "name": "golden",
        "seed": 13,
        "generations": 3,
        "body": {"encoder": "prebuilt", "genotype": "gecko"},
        "brain": {"popsize": 4, "iterations": 2},
        "task": {"duration": 0.6},
        "record": {"rerun": False},
        "executor": {"kind": "serial"},
    },
}

_UNMEASURED = {"wall_seconds"}  # a measured time, different in every run
_ORDER = {"evaluations": ["eval_id"], "bodies": ["body_id"], "trajectories": ["eval_id", "t"]}


def table_digests(run_dir: Path) -> dict[str, str]:
    """``"<table>/gen-N"`` -> SHA-256 of that table's rows in a bit-exact, ordered form."""
    import pyarrow.parquet as pq

    digests = {}
    for table, order in _ORDER.items():
        for path in sorted((run_dir / table).glob("gen-*.parquet")):
            frame = pq.read_table(path).to_pandas()
            columns = [c for c in frame.columns if c not in _UNMEASURED]
            frame = frame.sort_values(order, kind="stable")
            text = json.dumps(
                [columns, [[plain(v) for v in row] for row in frame[columns].itertuples(False)]],
                default=str,
            )
            digests[f"{table}/{path.stem}"] = hashlib.sha256(text.encode()).hexdigest()
    return digests


def _run(name: str, out: Path) -> dict[str, str]:
    from ariel.evolution import run_experiment

    run_experiment(CONFIGS[name], out=out)
    return table_digests(out)


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_records_equal_the_golden_digests(name: str, tmp_path: Path) -> None:
    expected = json.loads(GOLDEN.read_text())[name]
    found = _run(name, tmp_path / name)
    assert sorted(found) == sorted(expected)
    different = [key for key in expected if found[key] != expected[key]]
    assert not different, f"tables that differ from the golden records: {different}"


if __name__ == "__main__":  # write the digests again (only when the records are meant to change)
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        golden = {name: _run(name, Path(scratch) / name) for name in sorted(CONFIGS)}
    GOLDEN.write_text(json.dumps(golden, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
