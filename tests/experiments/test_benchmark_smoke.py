"""Smoke tests of experiments/benchmarks/evaluation.py, coevolution.py, recording.py and
soak.py: each runs and ends with its JSON summary.

Tiny settings and no timing assertions (the machine's load decides the numbers).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from _helpers import benchmark_summary, run_benchmark

KEYS = (
    "tutorial_path_ratio",
    "fast_path_ratio",
    "batch_ratio",
    "build_ms",
    "build_tree_ms",
    "build_cppn_ms",
)


@pytest.mark.soak
def test_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark(
        "evaluation.py", "--repeats", "1", "--duration", "0.5", "--batch", "2", cwd=tmp_path
    )
    summary, table = benchmark_summary(result, KEYS)
    assert summary["nstep"] == 250 and summary["batch"] == 2
    # The table names every figure, and both paths walked the same gait.
    for label in ("raw mj_step", "tutorial path", "fast path", "evaluate_batch", "build"):
        assert label in table
    assert summary["same_gait_max_diff"] == 0.0


def test_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("evaluation.py", "--repeats", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--repeats must be an integer >= 1" in result.stderr


COEVOLUTION_KEYS = (
    "loop_vs_raw_ratio",
    "ga_vs_raw_ratio",
    "map_elites_vs_raw_ratio",
    "loop_evals_per_s",
    "raw_evals_per_s",
    "evaluations",
    "threads",
)


@pytest.mark.soak
def test_coevolution_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("coevolution.py", "--quick", cwd=tmp_path)
    summary, table = benchmark_summary(result, COEVOLUTION_KEYS)
    # --quick: 1 generation x 1 iteration x popsize 4.
    assert summary["evaluations"] == 4 and summary["repeats"] == 1
    for label in (
        "raw mujoco.rollout",
        "co-evolution loop",
        "body optimizer ga",
        "body optimizer map_elites",
        "body optimizer novelty",
        "body optimizer map_elites_cvt",
    ):
        assert label in table
    assert {"novelty_vs_raw_ratio", "map_elites_cvt_vs_raw_ratio"} <= set(summary)
    # The runs went into a temporary folder that is gone again; nothing written here.
    assert list(tmp_path.iterdir()) == []


def test_coevolution_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("coevolution.py", "--popsize", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert "--popsize must be an integer >= 2" in result.stderr


RECORDING_KEYS = ("recording_overhead_ratio", "rrd_bytes_per_eval", "parquet_bytes_per_eval")


@pytest.mark.soak
def test_recording_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("recording.py", "--quick", cwd=tmp_path)
    summary, table = benchmark_summary(result, RECORDING_KEYS)
    # --quick: 1 generation of 2 bodies x 1 iteration x popsize 3, serial; one round.
    assert summary["evaluations"] == 6 and summary["repeats"] == 1
    assert summary["folder_bytes"] > summary["folder_bytes_off"]
    for label in ("recording_overhead_ratio", ".rrd bytes per evaluation", "Parquet bytes"):
        assert label in table
    assert list(tmp_path.iterdir()) == []  # the runs went into a temporary folder


def test_recording_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("recording.py", "--repeats", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert "--repeats must be an integer >= 1" in result.stderr


SOAK_KEYS = (
    "evals_per_s_first",
    "evals_per_s_last",
    "worker_rss_max_mib",
    "driver_rss_first_mib",
    "driver_rss_last_mib",
    "raw_evals_per_s_before",
    "raw_evals_per_s_after",
)


@pytest.mark.soak
def test_soak_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("soak.py", "--quick", cwd=tmp_path)
    summary, table = benchmark_summary(result, SOAK_KEYS)
    # --quick: 2 generations of 2 bodies x 1 iteration x popsize 3, on one local worker.
    assert summary["evaluations"] == 12 and summary["workers"] == 1
    assert len(summary["evals_per_s"]) == 2 and len(summary["driver_rss_mib"]) == 2
    assert summary["evals_per_s"][0] == summary["evals_per_s_first"]
    # Growth is a fraction, from readings taken after the first and the last generation (the
    # JSON shows the readings rounded to 0.01 MiB and the growth to 4 decimals: one step apart).
    first, last = summary["driver_rss_first_mib"], summary["driver_rss_last_mib"]
    assert summary["driver_rss_growth"] == pytest.approx(last / first - 1, abs=1.5e-4)
    assert -1 < summary["worker_rss_growth"] < 10
    # The sampler saw the pool's worker (not only the forkserver) holding a whole engine.
    assert summary["workers_seen"] >= 1
    assert 30 < summary["worker_rss_max_mib"] < 4096
    assert summary["driver_rss_peak_mib"] >= max(first, last)
    for key in ("driver_fds_first", "driver_fds_last", "driver_fds_max", "worker_fds_max"):
        assert isinstance(summary[key], int) and summary[key] > 0, key
    assert summary["driver_fds_max"] >= summary["driver_fds_last"]
    assert summary["driver_fd_growth"] == summary["driver_fds_last"] - summary["driver_fds_first"]
    for label in ("evals/s, first generation", "driver RSS", "worker peak RSS", "descriptors"):
        assert label in table
    assert list(tmp_path.iterdir()) == []  # the run went into a temporary folder


def test_soak_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("soak.py", "--generations", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert "--generations must be an integer >= 2" in result.stderr
    result = run_benchmark("soak.py", "--out", str(tmp_path), cwd=tmp_path)
    assert result.returncode == 2
    assert "exists already" in result.stderr


CAMPAIGN_KEYS = ("campaign_vs_raw_ratio", "busy_share", "campaign_evals_per_s", "raw_evals_per_s")


@pytest.mark.soak
def test_campaign_benchmark_prints_json_summary_last(tmp_path: Path) -> None:
    result = run_benchmark("campaign.py", "--quick", cwd=tmp_path)
    summary, table = benchmark_summary(result, CAMPAIGN_KEYS)
    # --quick: 2 conditions x 3 seeds of 1 generation x 1 iteration x popsize 4.
    assert summary["evaluations"] == 24 and summary["runs"] == 6 and summary["repeats"] == 1
    assert 0 < summary["busy_share"] <= 1.0
    for label in ("raw mujoco.rollout", "campaign, run_campaign", "workers busy"):
        assert label in table
    assert list(tmp_path.iterdir()) == []  # the campaigns went into a temporary folder


def test_campaign_benchmark_rejects_bad_arguments(tmp_path: Path) -> None:
    result = run_benchmark("campaign.py", "--popsize", "1", cwd=tmp_path)
    assert result.returncode == 2
    assert "--popsize must be an integer >= 2" in result.stderr


@pytest.mark.soak
def test_science_benchmark_measures_a_run_and_prints_json_last(tmp_path: Path) -> None:
    tiny = [
        "generations=2",
        "body.population=2",
        "body.offspring=2",
        "brain.popsize=4",
        "brain.iterations=2",
        "task.duration=3.0",
        "task.settle=0.5",
        "record.rerun=false",
        "executor.kind=serial",
    ]
    args = [arg for item in tiny for arg in ("--set", item)]
    result = run_benchmark("science.py", *args, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["evaluations"] == 4 * 2 * 2 + 2 * 4 * 2
    assert (summary["fitness_fn"], summary["settle_seconds"]) == ("sustained_displacement", 0.5)
    for key in ("first_second_share", "late_step_share", "best_saturated_share"):
        assert 0.0 <= summary[key] <= 1.5, key  # shares (a fall and back can exceed 1)
    assert summary["learning_gain_median"] >= 0.0
    assert len(summary["distinct_bodies_per_generation"]) == 2
    assert isinstance(summary["targets_met"], bool)
