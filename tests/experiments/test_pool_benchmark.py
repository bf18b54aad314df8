"""Smoke test of experiments/benchmarks/pool.py: it runs and ends with its JSON summary.

Tiny settings and no timing assertions (the machine's load decides the numbers).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "benchmarks" / "pool.py"
KEYS = (
    "tiny_ratio",
    "batch_ratio",
    "tiny_ms_local_pool",
    "tiny_ms_process_pool",
    "batch_ms_local_pool",
    "batch_ms_process_pool",
    "recovery_s",
)


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def test_pool_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = _run("--quick", "--workers", "2", cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.strip().splitlines()
    summary = json.loads(lines[-1])
    for key in KEYS:
        value = summary[key]
        assert isinstance(value, int | float) and not isinstance(value, bool), key
        assert math.isfinite(value) and value > 0, (key, value)
    assert summary["workers"] == 2 and summary["batches"] == 2 and summary["popsize"] == 2
    table = "\n".join(lines[:-1])
    assert "LocalPool" in table and "ProcessPool" in table and "SIGKILL" in table


def test_pool_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = _run("--calls", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--calls must be an integer >= 1" in result.stderr
