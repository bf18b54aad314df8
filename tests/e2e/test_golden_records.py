"""Records of fixed runs, bit for bit, against digests taken before the loop was rebuilt.

`golden_records.json` holds, per config below, the SHA-256 of every table of every generation
(rows in id order, every cell in a bit-exact form; the ``wall_seconds`` column, a measured time,
left out). It was written by the loop before it was split into body optimizers, a scheduler
and row builders, and the rebuilt loop gave the same records. Written again only when records
change on purpose (``python tests/e2e/test_golden_records.py``), and said so in the commit:
since then once, for the integer count columns (the same values, cast).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # _helpers, when run as a script
from _helpers import table_digests

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
