"""Smoke test of experiments/benchmarks/pool.py: it runs and ends with its JSON summary.

Tiny settings and no timing assertions (the machine's load decides the numbers).
"""

from __future__ import annotations

from pathlib import Path

from _helpers import benchmark_summary, run_benchmark

KEYS = (
    "tiny_ratio",
    "batch_ratio",
    "tiny_ms_local_pool",
    "tiny_ms_process_pool",
    "batch_ms_local_pool",
    "batch_ms_process_pool",
    "recovery_s",
)


def test_pool_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("pool.py", "--quick", "--workers", "2", cwd=tmp_path)
    summary, table = benchmark_summary(result, KEYS)
    assert summary["workers"] == 2 and summary["batches"] == 2 and summary["popsize"] == 2
    assert "LocalPool" in table and "ProcessPool" in table and "SIGKILL" in table


def test_pool_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("pool.py", "--calls", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--calls must be an integer >= 1" in result.stderr
