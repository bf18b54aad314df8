"""The MuJoCo Warp evaluator, on Warp's CPU device: same frames and fitness as the CPU engine.

Warp computes in float32, so the comparison is to a tolerance (the issue's: 1e-3 m of core
position after 1 simulated second on flat ground); what is computed on the host (times, joint
targets, the fitness function) must be equal. The first test of a fresh machine compiles
MuJoCo Warp's kernels (~20 s on 2 cores; cached on disk afterwards).
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace

import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, TrajectoryRecord, build, evaluate_batch
from ariel.evaluation.builtin_plugins import NaCPGController

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
pytestmark = pytest.mark.warp

from ariel.evaluation._warp import (  # noqa: E402
    WarpEvaluator,
    WarpUnavailableError,
    check_device,
    cuda_available,
    warp_modules,
)

GECKO = BodySpec("prebuilt", "gecko")


@pytest.fixture(scope="module")
def evaluator() -> WarpEvaluator:
    return WarpEvaluator("cpu")


def gecko_tasks(n: int, *, seed: int = 1, **fields: object) -> list[EvaluationTask]:
    model = build(EvaluationTask(body=GECKO)).model
    params = NaCPGController().random_parameters(model, np.random.default_rng(seed), n)
    fields = {"duration": 1.0, "record_every": 50, "seed": 3, **fields}
    return [
        EvaluationTask(body=GECKO, params=p, eval_id=f"e{i}", **fields)  # type: ignore[arg-type]
        for i, p in enumerate(params)
    ]


def test_trajectories_match_the_cpu_engine_after_one_second(evaluator) -> None:
    tasks = gecko_tasks(6)
    cpu = evaluate_batch(tasks)
    warp = evaluator.evaluate_batch(tasks)
    core = max(np.abs(a.core_pos - b.core_pos).max() for a, b in zip(cpu, warp))
    angle = max(np.abs(a.joint_angle - b.joint_angle).max() for a, b in zip(cpu, warp))
    pose = max(np.abs(a.body_pos - b.body_pos).max() for a, b in zip(cpu, warp))
    print(f"after 1 s: core {core:.2e} m, joints {angle:.2e} rad, bodies {pose:.2e} m apart")
    assert core < 1e-3
    assert angle < 1e-2 and pose < 1e-3
    # The robots did move: the comparison is not between two robots lying still.
    assert max(np.abs(a.joint_angle - a.joint_angle[0]).max() for a in cpu) > 0.3
    for a, b in zip(cpu, warp):
        assert (b.eval_id, b.status, b.backend) == (a.eval_id, "ok", "mujoco-warp:cpu")
        assert a.backend == "mujoco"
        np.testing.assert_array_equal(b.time, a.time)
        np.testing.assert_array_equal(b.joint_target, a.joint_target)  # host-side controls
        assert b.body_names == a.body_names and b.joint_names == a.joint_names
        assert b.body_quat.shape == a.body_quat.shape
        np.testing.assert_allclose(b.body_quat, a.body_quat, atol=1e-3)  # (w, x, y, z) both
        assert b.fitness == pytest.approx(a.fitness, abs=1e-3)
        assert b.descriptors == a.descriptors and b.sim_time == a.sim_time


def test_a_settled_batch_starts_from_the_cpu_engines_settled_pose(evaluator) -> None:
    # The settled pose is the model's reset pose (qpos0), which put_model carries to the device.
    tasks = gecko_tasks(3, settle=0.5, record_bodies=False)
    cpu = evaluate_batch(tasks)
    warp = evaluator.evaluate_batch(tasks)
    spawned = evaluate_batch(gecko_tasks(1, record_bodies=False))[0]
    for a, b in zip(cpu, warp):
        np.testing.assert_allclose(b.core_pos[0], a.core_pos[0], atol=1e-6)
        assert abs(a.core_pos[0, 2] - spawned.core_pos[0, 2]) > 0.005  # it did settle
        assert np.abs(a.core_pos - b.core_pos).max() < 1e-3


@pytest.mark.parametrize(
    "name", ["xy_displacement", "sustained_displacement", "x_speed", "turning_in_place"]
)
def test_fitness_is_the_registered_function_on_the_recorded_frames(evaluator, name) -> None:
    from ariel.plugins import fitness_functions

    tasks = gecko_tasks(3, seed=2, fitness=name, record_bodies=False)
    warp = evaluator.evaluate_batch(tasks)
    cpu = evaluate_batch(tasks)
    fitness = fitness_functions.get(name)
    for a, b in zip(cpu, warp):
        frames = TrajectoryRecord(b.time, b.core_pos, b.joint_target, b.joint_angle)
        assert b.fitness == float(fitness(frames))  # the same function, on these frames
        assert b.fitness == pytest.approx(a.fitness, abs=1e-3)
        assert b.body_pos is None


def test_recording_rate_does_not_change_the_physics(evaluator) -> None:
    sparse = evaluator.evaluate_batch(gecko_tasks(3, record_every=0, record_bodies=False))
    dense = evaluator.evaluate_batch(gecko_tasks(3, record_every=10, record_bodies=False))
    for a, b in zip(sparse, dense):
        assert a.time.tolist() == [0.0, pytest.approx(1.0)]
        assert b.time.size == 51
        np.testing.assert_array_equal(a.core_pos[-1], b.core_pos[-1])
        assert a.fitness == b.fitness


def test_the_same_batch_twice_gives_the_same_results_on_the_cpu_device(evaluator) -> None:
    # Each batch starts from a reset of the same device data and replays the same graphs.
    tasks = gecko_tasks(3, record_bodies=False)
    first, second = evaluator.evaluate_batch(tasks), evaluator.evaluate_batch(tasks)
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a.core_pos, b.core_pos)


def test_unstable_physics_gives_status_unstable_and_the_worst_fitness(evaluator) -> None:
    exploding = {"timestep": 0.05, "mujoco_config": {"integrator": "EULER"}}
    results = evaluator.evaluate_batch(gecko_tasks(2, world_options=exploding))
    for result in results:
        assert result.status == "unstable" and "unstable" in result.error
        assert result.fitness == -math.inf
        assert np.all(np.isfinite(result.core_pos))  # poses of the finite state, as on CPU


def test_buffers_that_overflow_grow_and_the_batch_runs_again(evaluator) -> None:
    tasks = gecko_tasks(2, seed=7, record_bodies=False)
    small = WarpEvaluator("cpu")
    body = small._lone_body(tasks[0], build(tasks[0]))
    body.sizes = (4, 8)  # room for 4 contacts and 8 constraint rows per world
    results = small.evaluate_batch(tasks)
    assert body.sizes[0] > 1 and body.sizes[1] > 1
    cpu = evaluate_batch(tasks)
    for a, b in zip(cpu, results):
        assert b.status == "ok"
        assert np.abs(a.core_pos - b.core_pos).max() < 1e-3


def test_groups_mix_open_and_closed_loop_and_bad_bodies_in_input_order(evaluator) -> None:
    from ariel.evaluation.builtin_plugins import MLPController

    model = build(EvaluationTask(body=GECKO)).model
    mlp = MLPController().random_parameters(model, np.random.default_rng(0), 1)[0]
    tasks = [
        *gecko_tasks(1, record_bodies=False),
        EvaluationTask(body=GECKO, params=mlp, controller="mlp", duration=0.2, eval_id="mlp"),
        EvaluationTask(body=BodySpec("graph", {"nodes": []}), duration=0.2, eval_id="bad"),
    ]
    results = evaluator.evaluate_batch(tasks)
    assert [r.eval_id for r in results] == ["e0", "mlp", "bad"]
    assert results[0].backend == "mujoco-warp:cpu"
    assert results[1].backend == "mujoco" and results[1].status == "ok"  # the CPU engine
    assert results[2].status == "error"
    with pytest.raises(ValueError, match="needs 40 parameters"):
        evaluator.evaluate_batch([EvaluationTask(body=GECKO, params=[0.0] * 3)])


def test_the_gpu_executor_runs_submitted_evaluate_batch_calls_on_warp() -> None:
    """docs/gpu.md's `ex.submit(evaluate_batch, tasks)` ran on the CPU engine (backend
    mujoco), while the example said Warp."""
    from ariel.evaluation import make_executor

    tasks = gecko_tasks(2, duration=0.2)
    with make_executor("gpu", device="cpu") as ex:
        results = ex.submit(evaluate_batch, tasks).result()
        named = ex.submit(evaluate_batch, tasks=tasks).result()  # the keyword form too
        other = ex.submit(len, tasks).result()  # any other call: here, as before
    assert [r.backend for r in results + named] == ["mujoco-warp:cpu"] * 4 and other == 2


def test_a_heightfield_world_runs_on_the_cpu_engine_and_says_so(capsys) -> None:
    """MuJoCo Warp's contacts with a heightfield differ from MuJoCo's: on rugged ground the
    gecko was launched (0.47 m where the CPU engine gave 0.03), with status ok."""
    fresh = WarpEvaluator("cpu")  # its notes are said once per evaluator
    tasks = gecko_tasks(2, world="rugged", duration=0.3)
    cpu, warp = evaluate_batch(tasks), fresh.evaluate_batch(tasks)
    assert [r.backend for r in warp] == ["mujoco", "mujoco"]
    assert [r.fitness for r in warp] == [r.fitness for r in cpu]
    fresh.evaluate_batch(tasks)
    notes = [line for line in capsys.readouterr().err.splitlines() if "heightfield" in line]
    assert notes == [
        "note: gpu: world 'rugged' has a heightfield, whose contacts MuJoCo Warp computes unlike "
        "MuJoCo: its evaluations run on the CPU engine (docs/gpu.md)"
    ]


def test_devices_are_checked_with_one_line(monkeypatch, tmp_path) -> None:
    with pytest.raises(ValueError, match="device must be one of cuda, cpu"):
        check_device("tpu")
    for worlds in (0, True, 2.0):  # True was taken as 1
        with pytest.raises(ValueError, match="max_worlds must be an integer >= 1 or None"):
            WarpEvaluator("cpu", max_worlds=worlds)  # type: ignore[arg-type]
    assert check_device("cpu") == "cpu"
    if not cuda_available():
        with pytest.raises(WarpUnavailableError, match=r'executor\.device = "cpu"') as info:
            WarpEvaluator("cuda")
        assert "\n" not in str(info.value)
    monkeypatch.setitem(sys.modules, "mujoco_warp", None)  # as if it were not installed
    # a hint to paste: the checkout's `make gpu` (a bare `pip` is the system's, not .venv's)
    with pytest.raises(WarpUnavailableError, match=r"is not installed\): make gpu$"):
        warp_modules()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(WarpUnavailableError, match=r"\): make -C /\S+ gpu$"):
        warp_modules()
    from ariel.evaluation import _warp_runtime

    monkeypatch.setattr(_warp_runtime, "__file__", str(tmp_path / "site/ariel/evaluation/x.py"))
    with pytest.raises(WarpUnavailableError, match=r"\): /\S+python\S* -m pip install 'ariel"):
        warp_modules()  # installed from the registry: this interpreter's pip


def test_a_world_that_overflows_every_size_tried_is_an_error_result() -> None:
    tasks = gecko_tasks(1, seed=7, record_bodies=False)
    small = WarpEvaluator("cpu")
    small._lone_body(tasks[0], build(tasks[0])).sizes = (1, 1)  # 4 doublings: still short
    (result,) = small.evaluate_batch(tasks)
    assert result.status == "error" and result.fitness == -math.inf
    assert "overflowed the device buffers" in result.error


def test_tasks_with_different_seeds_get_their_own_controls(evaluator) -> None:
    # One seed: controls computed piecewise along time; several: in one piece. Same values.
    tasks = [
        replace(t, seed=s)
        for t, s in zip(gecko_tasks(2, duration=0.3, record_bodies=False), (5, 6))
    ]
    warp, cpu = evaluator.evaluate_batch(tasks), evaluate_batch(tasks)
    for a, b in zip(cpu, warp):
        np.testing.assert_array_equal(b.joint_target, a.joint_target)
    assert not np.array_equal(warp[0].joint_target, warp[1].joint_target)


def test_the_package_exports_the_evaluator_lazily() -> None:
    import ariel.evaluation

    assert ariel.evaluation.WarpEvaluator is WarpEvaluator
    assert "WarpEvaluator" in dir(ariel.evaluation)


def test_shutting_down_during_a_device_call_says_it_waits(capsys) -> None:
    """Ctrl-C during a kernel compilation or a batch waited up to a minute without a word."""
    import time

    from ariel.evaluation import _executor_gpu, make_executor

    class Slow:
        def evaluate_batch(self, tasks: list) -> list:
            time.sleep(_executor_gpu.WAIT_NOTE_S + 0.5)
            return [None] * len(tasks)

    ex = make_executor("gpu", device="cpu")
    ex.evaluator = Slow()  # type: ignore[assignment]
    ex.submit_batch([object()])  # type: ignore[list-item]
    ex.dispatch()
    time.sleep(0.1)  # the device thread has taken it
    ex.shutdown()
    assert "waiting for the device to finish its current call" in capsys.readouterr().err
