"""Executor ``gpu``: the loop sends brain batches to MuJoCo Warp (here on Warp's CPU device),
records name the backend, replay re-simulates on Warp and reports the difference, and a machine
without CUDA or without MuJoCo Warp gets one clear line before anything is written."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from ariel.cli import main
from ariel.evolution import ConfigError, run_experiment
from ariel.recording import load_run

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
pytestmark = pytest.mark.warp

from ariel.evaluation._warp import cuda_available  # noqa: E402

GECKO = {
    "name": "gecko_gpu_tiny",
    "seed": 4,
    "generations": 2,
    "body": {"encoder": "prebuilt", "genotype": "gecko"},
    "brain": {"popsize": 4, "iterations": 1},
    "task": {"duration": 0.5},
    "record": {"rerun": False},
}


@pytest.fixture(scope="module")
def gpu_run(tmp_path_factory):
    config = {**GECKO, "executor": {"kind": "gpu", "device": "cpu"}}
    return run_experiment(config, out=tmp_path_factory.mktemp("gpu") / "run")


def test_brain_batches_run_on_warp_and_records_name_the_backend(gpu_run, tmp_path) -> None:
    assert gpu_run.status == "finished"
    evals = load_run(gpu_run.run_dir).evaluations
    assert len(evals) == 2 * 4
    assert set(evals["backend"]) == {"mujoco-warp:cpu"}
    assert set(evals["status"]) == {"ok"}
    # The same experiment on the CPU engine: the first batch has the same parameters (CMA-ES is
    # seeded), and its fitness agrees to float32 physics' precision.
    cpu = load_run(
        run_experiment({**GECKO, "executor": {"kind": "serial"}}, out=tmp_path / "cpu").run_dir
    ).evaluations
    assert set(cpu["backend"]) == {"mujoco"}
    first = evals[evals["generation"] == 0].sort_values("eval_id")
    cpu_first = cpu[cpu["generation"] == 0].sort_values("eval_id")
    np.testing.assert_array_equal(
        np.stack(first["controller_params"]), np.stack(cpu_first["controller_params"])
    )
    np.testing.assert_allclose(first["fitness"], cpu_first["fitness"], atol=1e-3)


def test_replay_of_a_warp_evaluation_resimulates_on_warp_and_reports_the_difference(
    gpu_run, capsys
) -> None:
    from ariel.recording.resim._replay import replay

    replayed = replay(gpu_run.run_dir, "best")
    assert replayed.stored_backend == replayed.backend == "mujoco-warp:cpu"
    assert not replayed.exact
    assert abs(replayed.difference) < 1e-3
    assert main(["replay", str(gpu_run.run_dir), "best"]) == 0
    out = capsys.readouterr().out
    assert "backend: stored mujoco-warp:cpu, replayed mujoco-warp:cpu" in out
    assert "difference: " in out and "not bitwise repeatable" in out
    assert "identical: yes" not in out


def test_a_cuda_evaluation_replays_on_the_cpu_engine_without_cuda() -> None:
    if cuda_available():
        pytest.skip("this machine has CUDA: the stored device is available")
    from ariel.evaluation import BodySpec, EvaluationTask
    from ariel.recording.resim._replay import _evaluate_as_stored

    task = EvaluationTask(body=BodySpec("prebuilt", "gecko"), params=[0.1] * 40, duration=0.1)
    assert _evaluate_as_stored(task, "mujoco-warp:cuda").backend == "mujoco"
    assert _evaluate_as_stored(task, "mujoco-warp:cpu").backend == "mujoco-warp:cpu"


def test_without_cuda_the_gpu_executor_is_one_line_and_exit_2(tmp_path) -> None:
    if cuda_available():
        pytest.skip("this machine has CUDA")
    out = tmp_path / "run"
    config = tmp_path / "gecko.toml"
    config.write_text('[body]\nencoder = "prebuilt"\ngenotype = "gecko"\n')
    # A fresh process: Warp's first initialisation is where its native library speaks up.
    command = ["run", str(config), "--executor", "gpu", "--out", str(out), "--quiet"]
    done = subprocess.run(
        [sys.executable, "-m", "ariel.cli", *command],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert "executor.device" in done.stderr and "no CUDA device" in done.stderr
    assert "executor.device=cpu" in done.stderr and "--executor local" in done.stderr
    assert "..." not in done.stderr  # nothing to fill in: every part can be used as it is
    assert not out.exists()


def test_without_mujoco_warp_the_error_names_the_extra(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco_warp", None)  # as if it were not installed
    config = {**GECKO, "executor": {"kind": "gpu", "device": "cpu"}}
    with pytest.raises(ConfigError, match=r"executor\.kind: .*is not installed\): make gpu$"):
        run_experiment(config, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_the_gpu_executor_takes_no_worker_count(tmp_path) -> None:
    config = {**GECKO, "executor": {"kind": "gpu", "device": "cpu", "workers": 2}}
    with pytest.raises(ConfigError, match=r"executor\.workers: the gpu executor runs on one"):
        run_experiment(config, out=tmp_path / "run")


def test_make_executor_gpu_evaluates_batches_on_warp() -> None:
    from ariel.evaluation import BodySpec, EvaluationTask, make_executor

    task = EvaluationTask(body=BodySpec("prebuilt", "gecko"), params=[0.1] * 40, duration=0.1)
    with make_executor("gpu", device="cpu") as executor:
        assert executor.capacity == 1  # a body's whole batch is one set of worlds
        (result,) = executor.submit_batch([task]).result()
        assert executor.submit(len, [1, 2]).result() == 2  # any other call runs as it is
    assert result.backend == "mujoco-warp:cpu" and math.isfinite(result.fitness)
    with pytest.raises(ValueError, match="one device; no workers"):
        make_executor("gpu", device="cpu", workers=2)


def test_queued_batches_go_to_the_device_together_and_a_faulty_one_fails_alone() -> None:
    from ariel.evaluation import make_executor

    calls: list[list[str]] = []

    def evaluate_batch(tasks):
        calls.append(list(tasks))
        if "bad" in tasks:
            raise ValueError("a plugin failed")
        return [f"result of {t}" for t in tasks]

    with make_executor("gpu", device="cpu") as executor:
        executor.evaluator.evaluate_batch = evaluate_batch
        first = executor.submit_batch(["a", "b"])
        second = executor.submit_batch(["c"])
        assert not calls  # queued until dispatched (the scheduler does it before it waits)
        executor.dispatch()
        assert first.result() == ["result of a", "result of b"]
        assert second.result() == ["result of c"]
        assert calls == [["a", "b", "c"]]  # one call for both batches
        calls.clear()
        good, bad = executor.submit_batch(["d"]), executor.submit_batch(["bad"])
        assert good.result() == ["result of d"]  # asking for a result dispatches too
        with pytest.raises(ValueError, match="a plugin failed"):
            bad.result()
        assert calls == [["d", "bad"], ["d"], ["bad"]]  # together, then batch by batch
