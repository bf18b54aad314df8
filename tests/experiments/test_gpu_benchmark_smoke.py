"""Smoke test of experiments/benchmarks/gpu.py on Warp's CPU device: it runs both sides and
ends with its JSON summary. Tiny settings and no timing assertions."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from _helpers import run_benchmark

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: pip install 'ariel[gpu]'")
pytestmark = pytest.mark.warp


def test_gpu_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("gpu.py", "--quick", cwd=tmp_path, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    for key in ("gpu_evals_per_s", "cpu_evals_per_s", "speedup"):
        assert isinstance(summary[key], float) and math.isfinite(summary[key]) and summary[key] > 0
    assert summary["device"] == "cpu" and summary["worlds"] == [2, 4] and summary["steps"] == 100
    assert [f["worlds"] for f in summary["per_worlds"]] == [2, 4]
    assert all(f["not_ok"] == 0 and f["bare_evals_per_s"] > 0 for f in summary["per_worlds"])
    assert "mujoco.rollout" in result.stdout and "bare stepping" in result.stdout


def test_gpu_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("gpu.py", "--worlds", "16,x", cwd=tmp_path, timeout=600)
    assert result.returncode == 2
    assert "--worlds must be comma-separated integers" in result.stderr
