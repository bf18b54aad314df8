"""Smoke tests of experiments/benchmarks/evaluation.py, coevolution.py and recording.py: each
runs and ends with its JSON summary.

Tiny settings and no timing assertions (the machine's load decides the numbers).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "benchmarks" / "evaluation.py"
KEYS = ("tutorial_path_ratio", "fast_path_ratio", "batch_ratio", "build_ms")


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = _run("--repeats", "1", "--duration", "0.5", "--batch", "2", cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.strip().splitlines()
    summary = json.loads(lines[-1])
    for key in KEYS:
        value = summary[key]
        assert isinstance(value, int | float) and not isinstance(value, bool), key
        assert math.isfinite(value) and value > 0, (key, value)
    assert summary["nstep"] == 250 and summary["batch"] == 2
    # The table names every figure, and both paths walked the same gait.
    table = "\n".join(lines[:-1])
    for label in ("raw mj_step", "tutorial path", "fast path", "evaluate_batch", "build"):
        assert label in table
    assert summary["same_gait_max_diff"] == 0.0


def test_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = _run("--repeats", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--repeats must be an integer >= 1" in result.stderr


COEVOLUTION = SCRIPT.with_name("coevolution.py")
COEVOLUTION_KEYS = (
    "loop_vs_raw_ratio",
    "loop_evals_per_s",
    "raw_evals_per_s",
    "evaluations",
    "threads",
)


def _run_coevolution(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(COEVOLUTION), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_coevolution_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = _run_coevolution("--quick", cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.strip().splitlines()
    summary = json.loads(lines[-1])
    for key in COEVOLUTION_KEYS:
        value = summary[key]
        assert isinstance(value, int | float) and not isinstance(value, bool), key
        assert math.isfinite(value) and value > 0, (key, value)
    # --quick: 1 generation x 1 iteration x popsize 4.
    assert summary["evaluations"] == 4 and summary["repeats"] == 1
    table = "\n".join(lines[:-1])
    for label in ("raw mujoco.rollout", "co-evolution loop"):
        assert label in table
    # The runs went into a temporary folder that is gone again; nothing written here.
    assert list(tmp_path.iterdir()) == []


def test_coevolution_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = _run_coevolution("--popsize", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert "--popsize must be an integer >= 2" in result.stderr


RECORDING = SCRIPT.with_name("recording.py")
RECORDING_KEYS = ("recording_overhead_ratio", "rrd_bytes_per_eval", "parquet_bytes_per_eval")


def _run_recording(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(RECORDING), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_recording_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = _run_recording("--quick", cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.strip().splitlines()
    summary = json.loads(lines[-1])
    for key in RECORDING_KEYS:
        value = summary[key]
        assert isinstance(value, int | float) and not isinstance(value, bool), key
        assert math.isfinite(value) and value > 0, (key, value)
    # --quick: 1 generation of 2 bodies x 1 iteration x popsize 3, serial; one round.
    assert summary["evaluations"] == 6 and summary["repeats"] == 1
    assert summary["folder_bytes"] > summary["folder_bytes_off"]
    table = "\n".join(lines[:-1])
    for label in ("recording_overhead_ratio", ".rrd bytes per evaluation", "Parquet bytes"):
        assert label in table
    assert list(tmp_path.iterdir()) == []  # the runs went into a temporary folder


def test_recording_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = _run_recording("--repeats", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--repeats must be an integer >= 1" in result.stderr
