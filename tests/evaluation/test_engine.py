"""The evaluation engine: results, purity, batch = single, fast path = tutorial path, failures."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate, evaluate_batch
from ariel.evaluation.builtin_plugins import NaCPGController

GECKO = BodySpec("prebuilt", "gecko")


def gecko_params(n: int, seed: int = 0) -> np.ndarray:
    model = build(EvaluationTask(body=GECKO)).model
    return NaCPGController().random_parameters(model, np.random.default_rng(seed), n)


def task(params: np.ndarray, **kwargs: object) -> EvaluationTask:
    kwargs.setdefault("duration", 2.0)
    return EvaluationTask(body=GECKO, params=params, **kwargs)  # type: ignore[arg-type]


def assert_same_result(a, b) -> None:
    assert a.status == b.status
    assert a.fitness == b.fitness or (math.isinf(a.fitness) and a.fitness == b.fitness)
    for name in ("time", "core_pos", "joint_target", "joint_angle", "body_pos", "body_quat"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_result_holds_recorded_arrays_at_the_recording_rate() -> None:
    result = evaluate(task(gecko_params(1)[0], record_every=50, eval_id="e1"))
    assert result.status == "ok" and result.error == ""
    assert result.eval_id == "e1"
    assert math.isfinite(result.fitness) and result.fitness >= 0
    frames = 2.0 / 0.002 / 50 + 1  # t = 0, 0.1, ..., 2.0
    assert result.time.shape == (frames,)
    assert result.time[0] == 0.0 and result.time[-1] == pytest.approx(2.0)
    assert result.core_pos.shape == (frames, 3)
    assert result.joint_target.shape == result.joint_angle.shape == (frames, 8)
    assert result.body_pos.shape[0] == frames and result.body_pos.shape[2] == 3
    assert result.body_quat.shape[:2] == result.body_pos.shape[:2]
    assert len(result.body_names) == result.body_pos.shape[1]
    assert all(name.startswith("robot1_") for name in result.body_names)
    assert len(result.joint_names) == 8
    # The gecko spawns with its core geom at (0, 0.1, 0.1307) and the robot moved.
    np.testing.assert_allclose(result.core_pos[0], [0.0, 0.1, 0.130711], atol=1e-5)
    assert result.fitness == pytest.approx(np.linalg.norm(result.core_pos[-1, :2] - [0, 0.1]))
    assert np.abs(result.joint_target).max() <= math.pi / 2
    assert result.descriptors["num_hinges"] == 8
    assert result.sim_time == pytest.approx(2.0)


def test_recording_options_change_what_is_kept() -> None:
    params = gecko_params(1)[0]
    sparse = evaluate(task(params, record_every=0, record_bodies=False))
    dense = evaluate(task(params, record_every=10))
    assert sparse.time.tolist() == [0.0, pytest.approx(2.0)]
    assert sparse.body_pos is None
    assert dense.time.size == 101
    # Same physics whatever is recorded: the same last frame and fitness.
    np.testing.assert_array_equal(sparse.core_pos[-1], dense.core_pos[-1])
    assert sparse.fitness == dense.fitness


def test_evaluate_is_a_pure_function_of_the_task() -> None:
    t = task(gecko_params(1, seed=3)[0], seed=7)
    assert_same_result(evaluate(t), evaluate(t))


def test_the_seed_sets_the_cpg_initial_state() -> None:
    params = gecko_params(1)[0]
    a, b = evaluate(task(params, seed=1)), evaluate(task(params, seed=2))
    assert not np.array_equal(a.joint_target, b.joint_target)


def test_batch_equals_single_evaluations_bit_for_bit() -> None:
    params = gecko_params(4, seed=5)
    tasks = [task(p, seed=11, eval_id=str(i)) for i, p in enumerate(params)]
    batch = evaluate_batch(tasks, nthread=2)
    assert [r.eval_id for r in batch] == ["0", "1", "2", "3"]
    for t, r in zip(tasks, batch):
        assert_same_result(evaluate(t), r)


def test_fast_path_matches_the_tutorial_path_bit_for_bit() -> None:
    """Controller + mjcb_control + simple_runner drive the gecko exactly as the engine does."""
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
    from ariel.simulation.controllers.controller import Controller
    from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
    from ariel.simulation.environments import SimpleFlatWorld
    from ariel.utils.runners import simple_runner
    from ariel.utils.tracker import Tracker

    params, seed = gecko_params(1, seed=9)[0], 4
    fast = evaluate(task(params, seed=seed, record_every=50, duration=3.0))

    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=[0, 0, 0])
    model = world.spec.compile()
    data = mujoco.MjData(model)
    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker.setup(world.spec, data)
    cpg = NaCPG(create_fully_connected_adjacency(model.nu), hard_bounds=(-np.pi / 2, np.pi / 2))
    cpg.set_flat_params(params)
    cpg.set_initial_state(*NaCPGController().initial_state(model, seed))
    controller = Controller(
        controller_callback_function=lambda m, d: cpg.forward(time=d.time),
        time_steps_per_ctrl_step=50,
        time_steps_per_save=50,
        alpha=0.5,
        tracker=tracker,
    )
    mujoco.set_mjcb_control(controller.set_control)
    try:
        simple_runner(model, data, duration=3.0)
    finally:
        mujoco.set_mjcb_control(None)

    tutorial = np.array(tracker.history["xpos"][0])  # steps 0, 50, ..., 1450
    assert tutorial.shape == (30, 3)
    np.testing.assert_array_equal(fast.core_pos[:30], tutorial)
    joints = model.jnt_qposadr[model.actuator_trnid[:, 0]]
    np.testing.assert_array_equal(fast.joint_angle[-1], data.qpos[joints])
    np.testing.assert_array_equal(fast.joint_target[-1], data.ctrl)


def test_closed_loop_controller_runs_in_chunks_and_is_deterministic() -> None:
    model = build(EvaluationTask(body=GECKO)).model
    from ariel.plugins import controllers

    mlp = controllers.make("mlp")
    params = mlp.random_parameters(model, np.random.default_rng(0), 1)[0]
    t = task(params, controller="mlp", record_every=25)
    a, b = evaluate(t), evaluate(t)
    assert a.status == "ok" and math.isfinite(a.fitness)
    assert a.joint_target.shape == (41, 8)
    assert np.ptp(a.joint_target, axis=0).max() > 0.01  # the policy reacts over time
    assert_same_result(a, b)


def test_unstable_physics_gives_status_unstable_and_the_worst_fitness() -> None:
    unstable_world = {"timestep": 0.05, "mujoco_config": {"integrator": "EULER"}}
    params = gecko_params(2)
    batch = evaluate_batch([task(p, world_options=unstable_world) for p in params], nthread=2)
    results = [*batch, evaluate(task(params[0], world_options=unstable_world))]
    for result in results:
        assert result.status == "unstable"
        assert result.fitness == -math.inf
        assert "unstable" in result.error


def test_a_body_that_cannot_be_built_gives_an_error_result() -> None:
    bad = EvaluationTask(body=BodySpec("nde", [[0.1] * 64] * 2), params=(), duration=1.0)
    result = evaluate(bad)
    assert result.status == "error"
    assert result.fitness == -math.inf
    assert "3" in result.error and "\n" not in result.error


def test_wrong_parameter_count_names_the_expected_count() -> None:
    result = evaluate(task(np.zeros(7)))
    assert result.status == "error"
    assert "needs 40 parameters" in result.error and "has 7" in result.error


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"duration": -1.0}, "duration must be > 0"),
        ({"duration": float("nan")}, "duration must be a finite"),
        ({"params": [float("nan")] * 40}, "NaN or inf"),
        ({"control_period": 0}, "control_period"),
        ({"record_every": -5}, "record_every"),
        ({"spawn_position": (0, 0)}, "spawn_position"),
    ],
)
def test_bad_tasks_are_rejected_with_one_line_errors(kwargs: dict, message: str) -> None:
    kwargs.setdefault("params", np.zeros(40))
    with pytest.raises(ValueError, match=message) as info:
        EvaluationTask(body=GECKO, **kwargs)
    assert "\n" not in str(info.value)


def test_unknown_plugin_names_list_the_known_ones() -> None:
    from ariel.plugins import UnknownPluginError

    with pytest.raises(UnknownPluginError, match=r"known: .*na_cpg"):
        evaluate(task(np.zeros(40), controller="no_such_brain"))
    with pytest.raises(UnknownPluginError, match=r"known: .*flat"):
        evaluate(task(np.zeros(40), world="moon"))


def test_batch_with_a_seed_per_candidate_equals_single_evaluations() -> None:
    params = gecko_params(3, seed=6)
    tasks = [task(p, seed=100 + i) for i, p in enumerate(params)]
    for t, r in zip(tasks, evaluate_batch(tasks, nthread=2)):
        assert_same_result(evaluate(t), r)
