"""Smoke test of experiments/benchmarks/gpu.py on Warp's CPU device: it runs every row (warp,
bare, testspeed, cpu) and ends with its JSON summary. Tiny settings and no timing assertions."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from _helpers import run_benchmark

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
pytestmark = [pytest.mark.warp, pytest.mark.soak]  # make test-soak


def test_gpu_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    coevolution = ["--coevolution", "2x2", "--coevolution-duration", "0.2"]
    result = run_benchmark(
        "gpu.py",
        "--quick",
        *coevolution,
        "--coevolution-cpu-brains",
        "2",
        cwd=tmp_path,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    for key in ("gpu_evals_per_s", "cpu_evals_per_s", "speedup"):
        assert isinstance(summary[key], float) and math.isfinite(summary[key]) and summary[key] > 0
    assert summary["device"] == "cpu" and summary["worlds"] == [2, 4] and summary["steps"] == 100
    assert [f["worlds"] for f in summary["per_worlds"]] == [2, 4]
    assert all(f["not_ok"] == 0 and f["bare_evals_per_s"] > 0 for f in summary["per_worlds"])
    assert "mujoco.rollout" in result.stdout and "bare stepping" in result.stdout
    # the testspeed row (MuJoCo Warp's own speed test, same worlds and steps) and its ratio
    assert "testspeed" in result.stdout
    for size in summary["per_worlds"]:
        assert size["testspeed_steps_per_s"] > 0 and size["testspeed_evals_per_s"] > 0
        assert size["testspeed_converged"] == size["worlds"]
        assert size["bare_over_testspeed"] > 0
        for key in ("ns_per_world_step", "bare_ns_per_world_step", "testspeed_ns_per_world_step"):
            assert math.isfinite(size[key]) and size[key] > 0, key
    assert summary["bare_over_testspeed"] > 0
    ns = summary["ns_per_world_step"]
    assert set(ns) == {"warp", "bare", "testspeed", "cpu_rollout"}
    assert all(math.isfinite(v) and v > 0 for v in ns.values()), ns
    assert set(summary["versions"]) == {"python", "mujoco", "mujoco_warp", "warp", "numpy"}
    assert all(summary["versions"].values()), summary["versions"]
    # no GPU on Warp's CPU device: the card's fields are None
    assert summary["card"] == dict.fromkeys(("name", "memory", "driver_version", "source"))
    assert isinstance(summary["date"], str) and summary["date"][:2] == "20"
    # the packed co-evolution row: 2 different bodies x 2 brains, against the local executor
    row = summary["coevolution"]
    assert (row["bodies"], row["brains"], row["not_ok"]) == (2, 2, 0)
    assert row["evals_per_s"] > 0 and row["cpu_evals_per_s"] > 0 and row["speedup"] > 0


def test_gpu_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("gpu.py", "--worlds", "16,x", cwd=tmp_path, timeout=600)
    assert result.returncode == 2
    assert "--worlds must be comma-separated integers" in result.stderr
    result = run_benchmark("gpu.py", "--coevolution", "1x8", cwd=tmp_path, timeout=600)
    assert result.returncode == 2 and "--coevolution needs K >= 2 bodies" in result.stderr


def test_gpu_benchmark_runs_the_coevolution_row_alone(tmp_path: Path) -> None:
    args = ["--quick", "--coevolution", "2x2", "--coevolution-duration", "0.2"]
    result = run_benchmark(
        "gpu.py", *args, "--coevolution-only", "--coevolution-cpu-brains", "1", cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert set(summary) == {"coevolution", "device_name", "card", "versions", "date", "threads"}
    assert summary["coevolution"]["cpu_evals"] == 2 and summary["coevolution"]["speedup"] > 0
    assert "bare stepping" not in result.stdout  # no gecko rows
