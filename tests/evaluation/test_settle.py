"""Settling (``EvaluationTask.settle``): every path starts from the pose the held robot reaches."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate, evaluate_batch
from ariel.evaluation.builtin_plugins import NaCPGController
from ariel.simulation.settle import settle_model

GECKO = BodySpec("prebuilt", "gecko")


def _task(settle: float, **kwargs: object) -> EvaluationTask:
    model = build(EvaluationTask(body=GECKO)).model
    params = NaCPGController().random_parameters(model, np.random.default_rng(3), 1)[0]
    kwargs.setdefault("params", params)
    return EvaluationTask(body=GECKO, duration=1.0, settle=settle, **kwargs)  # type: ignore[arg-type]


def test_the_settled_pose_is_where_the_held_robot_ends_and_time_starts_at_zero() -> None:
    spawned = build(_task(0.0)).model
    settled = build(_task(0.5)).model
    assert not np.array_equal(spawned.qpos0, settled.qpos0)
    # The same hold, done by hand: 0.5 s at zero controls from the spawn pose.
    data = mujoco.MjData(spawned)
    mujoco.mj_step(spawned, data, nstep=round(0.5 / spawned.opt.timestep))
    np.testing.assert_array_equal(settled.qpos0, data.qpos)
    # Spawned 1 cm above the ground, the gecko has dropped onto it.
    assert settled.qpos0[2] < spawned.qpos0[2] - 0.005
    result = evaluate(_task(0.5))
    assert result.time[0] == 0.0 and result.sim_time == pytest.approx(1.0)
    core = settled.geom("robot1_core").id
    data = mujoco.MjData(settled)
    mujoco.mj_kinematics(settled, data)
    np.testing.assert_array_equal(result.core_pos[0], data.geom_xpos[core])


def test_settle_zero_leaves_the_model_as_compiled_and_settle_changes_the_result() -> None:
    model = build(_task(0.0)).model
    before = model.qpos0.copy()
    assert settle_model(model, 0.0) is model
    np.testing.assert_array_equal(model.qpos0, before)
    assert evaluate(_task(0.0)).fitness != evaluate(_task(0.5)).fitness


def test_open_and_closed_loop_paths_start_from_the_same_settled_pose() -> None:
    open_loop = evaluate(_task(0.5))
    mlp_params = np.zeros(
        _mlp_size(build(_task(0.5)).model),
    )
    closed = evaluate(_task(0.5, controller="mlp", params=mlp_params))
    np.testing.assert_array_equal(open_loop.core_pos[0], closed.core_pos[0])
    np.testing.assert_array_equal(open_loop.joint_angle[0], closed.joint_angle[0])


def _mlp_size(model: mujoco.MjModel) -> int:
    from ariel.evaluation.builtin_plugins import MLPController

    return MLPController().num_parameters(model)


def test_a_batch_of_settled_tasks_equals_single_evaluations() -> None:
    tasks = [_task(0.5, seed=s) for s in range(3)]
    for single, batched in zip(map(evaluate, tasks), evaluate_batch(tasks), strict=True):
        np.testing.assert_array_equal(single.core_pos, batched.core_pos)
        assert single.fitness == batched.fitness


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), True, "1"])
def test_a_bad_settle_is_rejected_in_one_line(bad: object) -> None:
    with pytest.raises(ValueError, match="settle must be a finite number of seconds >= 0"):
        EvaluationTask(body=GECKO, settle=bad)  # type: ignore[arg-type]
