"""The evaluation engine: results, purity, batch = single, fast path = tutorial path, failures."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import ClassVar

import mujoco
import numpy as np
import pytest

from ariel.evaluation import (
    BodyBuildError,
    BodySpec,
    EvaluationTask,
    build,
    evaluate,
    evaluate_batch,
)
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


@pytest.mark.parametrize("settle", [0.0, 0.4])
def test_fast_path_matches_the_tutorial_path_bit_for_bit(settle: float) -> None:
    """Controller + mjcb_control + simple_runner drive the gecko exactly as the engine does,
    also after a settle (`settle_model` on the tutorial's own compiled model)."""
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
    from ariel.simulation.controllers.controller import Controller
    from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
    from ariel.simulation.environments import SimpleFlatWorld
    from ariel.simulation.settle import settle_model
    from ariel.utils.runners import simple_runner
    from ariel.utils.tracker import Tracker

    params, seed = gecko_params(1, seed=9)[0], 4
    fast = evaluate(task(params, seed=seed, record_every=50, duration=3.0, settle=settle))

    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=[0, 0, 0])
    model = settle_model(world.spec.compile(), settle)
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


def test_unstable_physics_gives_status_unstable_and_the_worst_fitness(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo wrote its warnings to MUJOCO_LOG.TXT here
    unstable_world = {"timestep": 0.05, "mujoco_config": {"integrator": "EULER"}}
    params = gecko_params(2)
    batch = evaluate_batch([task(p, world_options=unstable_world) for p in params], nthread=2)
    results = [*batch, evaluate(task(params[0], world_options=unstable_world))]
    for result in results:
        assert result.status == "unstable"
        assert result.fitness == -math.inf
        assert "unstable" in result.error
    assert list(tmp_path.iterdir()) == []  # nothing written where the run was started
    assert "WARNING" not in capfd.readouterr().err  # nor printed instead
    config = mujoco.MjLogConfig.get()
    assert config.logto_file  # the process's own setting is back


def test_a_body_that_cannot_be_built_gives_an_error_result() -> None:
    bad = EvaluationTask(body=BodySpec("nde", [[0.1] * 64] * 2), params=(), duration=1.0)
    result = evaluate(bad)
    assert result.status == "error"
    assert result.fitness == -math.inf
    assert "3" in result.error and "\n" not in result.error


def test_build_raises_body_build_error_for_genotypes_only() -> None:
    from ariel.plugins import UnknownPluginError

    bad_genotypes = [BodySpec("nde", [[0.1] * 64] * 2), BodySpec("prebuilt", "dragon")]
    for body in bad_genotypes:
        with pytest.raises(BodyBuildError, match=f"body encoder {body.encoder!r}") as info:
            build(EvaluationTask(body=body))
        assert info.value.__cause__ is not None
    # The caller's mistakes are not the genotype's: they propagate as they are.
    with pytest.raises(UnknownPluginError):
        build(EvaluationTask(body=GECKO, world="moon"))
    with pytest.raises(TypeError, match="world 'flat'") as info:
        build(EvaluationTask(body=GECKO, world_options={"gravity_scale": 2}))
    assert not isinstance(info.value, BodyBuildError)
    with pytest.raises(ValueError, match="body encoder 'nde'"):
        build(EvaluationTask(body=BodySpec("nde", [[0.1] * 64] * 3, {"number_of_modules": 1})))


def test_only_unbuildable_bodies_become_error_results_in_a_batch() -> None:
    bad = EvaluationTask(body=BodySpec("prebuilt", "dragon"), duration=0.5, eval_id="bad")
    good = task(gecko_params(1)[0], duration=0.5, eval_id="good")
    results = evaluate_batch([bad, good])
    assert [r.status for r in results] == ["error", "ok"]
    assert "BodyBuildError" in results[0].error and "dragon" in results[0].error


def test_wrong_parameter_count_raises_naming_controller_count_actuators_and_id() -> None:
    with pytest.raises(ValueError, match="parameters") as info:
        evaluate_batch([task(np.zeros(40)), task(np.zeros(7), eval_id="gen3-7")])
    message = str(info.value)
    for part in ("'na_cpg'", "needs 40", "8 actuators", "'gen3-7'", "has 7"):
        assert part in message


@pytest.mark.parametrize(
    ("kwargs", "error", "plugin"),
    [
        ({"world_options": {"no_such_option": 1}}, TypeError, "world 'flat'"),
        ({"world": "rugged", "world_options": {"no_such_option": 1}}, TypeError, "'rugged'"),
        ({"controller_options": {"no_such_option": 1}}, TypeError, "controller 'na_cpg'"),
        ({"controller_options": {"coupling": "ring"}}, ValueError, "controller 'na_cpg'"),
        ({"fitness_options": {"no_such_option": 1}}, TypeError, "'xy_displacement'"),
        (
            {"fitness": "distance_to_target", "fitness_options": {"target": "north"}},
            ValueError,
            "fitness function 'distance_to_target'",
        ),
    ],
)
def test_bad_plugin_options_raise_naming_the_plugin(
    kwargs: dict, error: type[Exception], plugin: str
) -> None:
    with pytest.raises(error, match=plugin):
        evaluate(task(gecko_params(1)[0], duration=0.2, **kwargs))


def test_bad_body_encoder_options_raise_naming_the_encoder() -> None:
    body = BodySpec("nde", [[0.5] * 64] * 3, {"number_of_modules": 0})
    with pytest.raises(ValueError, match="body encoder 'nde'"):
        evaluate(EvaluationTask(body=body, duration=0.2))
    body = BodySpec("prebuilt", "gecko", {"size": 2})
    with pytest.raises(TypeError, match="body encoder 'prebuilt'"):
        evaluate(EvaluationTask(body=body, duration=0.2))


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


class SeededNoiseController:
    """Open-loop test plugin: a sine per actuator plus noise from ``default_rng(seed)``."""

    open_loop = True
    calls: ClassVar[list[int]] = []

    def num_parameters(self, model: mujoco.MjModel) -> int:
        return model.nu

    def random_parameters(self, model: mujoco.MjModel, rng: np.random.Generator, n: int):
        return rng.uniform(0.2, 1.0, (n, model.nu))

    def targets(self, params, sample_times, model, *, seed):
        assert type(seed) is int, f"seed is {type(seed).__name__}, not int"
        SeededNoiseController.calls.append(seed)
        # Noise depends on the seed only, never on which other rows share the call.
        noise = np.random.default_rng(seed).uniform(-0.3, 0.3, (sample_times.size, model.nu))
        wave = np.sin(2 * np.pi * sample_times)[None, :, None]
        return params[:, None, :] * wave + noise[None]


@pytest.fixture
def seeded_noise() -> Iterator[str]:
    from ariel.plugins import controllers

    controllers.register("test_seeded_noise", SeededNoiseController)
    SeededNoiseController.calls.clear()
    try:
        yield "test_seeded_noise"
    finally:
        controllers.unregister("test_seeded_noise")


def test_a_batch_mixing_seeds_calls_targets_once_per_seed_with_an_int(seeded_noise: str) -> None:
    model = build(EvaluationTask(body=GECKO)).model
    params = SeededNoiseController().random_parameters(model, np.random.default_rng(2), 6)
    seeds = [3, np.int64(1), 3, 2, 1, 2]
    tasks = [
        task(p, controller=seeded_noise, seed=s, eval_id=str(i))
        for i, (p, s) in enumerate(zip(params, seeds))
    ]
    batch = evaluate_batch(tasks, nthread=2)
    assert SeededNoiseController.calls == [3, 1, 2]  # one call per distinct seed, first-seen order
    assert [r.eval_id for r in batch] == [str(i) for i in range(6)]
    for t, r in zip(tasks, batch):
        assert_same_result(evaluate(t), r)
    assert not np.array_equal(batch[0].joint_target, batch[3].joint_target)


def test_a_seed_must_be_one_integer() -> None:
    assert type(task(np.zeros(40), seed=np.int64(5)).seed) is int
    for bad in ([1, 2], 1.5, True, "3"):
        with pytest.raises(ValueError, match="seed must be an integer"):
            task(np.zeros(40), seed=bad)
    model = build(EvaluationTask(body=GECKO)).model
    with pytest.raises(TypeError):
        NaCPGController().targets(gecko_params(2), np.zeros(3), model, seed=[1, 2])


def test_smoothing_is_a_task_field_that_changes_the_trajectory() -> None:
    params = gecko_params(1, seed=8)[0]
    default, fast = evaluate(task(params)), evaluate(task(params, smoothing=1.0))
    assert default.status == fast.status == "ok"
    assert not np.array_equal(default.joint_target, fast.joint_target)
    assert not np.array_equal(default.core_pos, fast.core_pos)
    assert_same_result(evaluate(task(params, smoothing=0.5)), default)
    batch = evaluate_batch([task(params), task(params, smoothing=1.0)], nthread=2)
    assert_same_result(batch[0], default)  # smoothing is part of the batch group key
    assert_same_result(batch[1], fast)
    from ariel.plugins import controllers

    model = build(EvaluationTask(body=GECKO)).model
    mlp = controllers.make("mlp").random_parameters(model, np.random.default_rng(0), 1)[0]
    closed = [evaluate(task(mlp, controller="mlp", smoothing=s)) for s in (0.2, 1.0)]
    assert not np.array_equal(closed[0].joint_target, closed[1].joint_target)


@pytest.mark.parametrize("bad", [0, -0.1, 1.5, float("nan"), float("inf"), True, "0.5"])
def test_smoothing_outside_0_1_is_rejected(bad: object) -> None:
    with pytest.raises(ValueError, match=r"smoothing must be a finite number in \(0, 1\]"):
        task(np.zeros(40), smoothing=bad)


def test_smoothing_is_no_longer_a_controller_option() -> None:
    with pytest.raises(TypeError, match=r"controller .na_cpg.*smoothing"):
        evaluate(task(gecko_params(1)[0], controller_options={"smoothing": 0.3}))


def _writes_its_record(record) -> float:
    record.core_pos[:] = 0.0  # would zero the recorded trajectory
    return 0.0


def test_a_fitness_function_cannot_reach_the_recorded_arrays() -> None:
    """A view's flag could be set writable again, and the stored trajectory changed."""
    from ariel.plugins import fitness_function, fitness_functions

    @fitness_function(maximise=True)
    def sneaky(record) -> float:
        record.core_pos.setflags(write=True)
        record.core_pos[:] = 5.0
        return 0.0

    fitness_functions.register("test_sneaky", sneaky)
    try:
        result = evaluate(task(gecko_params(1)[0], duration=0.2, fitness="test_sneaky"))
    finally:
        fitness_functions.unregister("test_sneaky")
    assert result.ok and not (result.core_pos == 5.0).all()


@pytest.mark.parametrize(
    ("fitness", "error", "said"),
    [
        (lambda record: "0.25", TypeError, "returned str, not a float"),  # float("0.25") took it
        (lambda record: True, TypeError, "returned bool, not a float"),
        (_writes_its_record, ValueError, "failed: assignment destination is read-only"),
    ],
)
def test_a_run_holds_a_fitness_function_to_the_check_s_rules(
    fitness: object, error: type[Exception], said: str
) -> None:
    """The check refused these; a run recorded them as ok (fitness 0.25, 1.0, or a
    trajectory zeroed by the function that scored it)."""
    from ariel.plugins import fitness_function, fitness_functions

    fitness_functions.register("test_fitness_rules", fitness_function(maximise=True)(fitness))
    try:
        with pytest.raises(error, match=f"fitness function 'test_fitness_rules' {said}"):
            evaluate(task(gecko_params(1)[0], duration=0.2, fitness="test_fitness_rules"))
    finally:
        fitness_functions.unregister("test_fitness_rules")
