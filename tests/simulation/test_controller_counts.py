"""Controller: exact step counting, blending and clipping to the actuator ranges, errors for bad
callback output, and agreement with the vectorised path (kernel + blend_and_clip)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from ariel.simulation.controllers import controller as controller_module
from ariel.simulation.controllers.controller import (
    Controller,
    actuator_bounds,
    blend_and_clip,
)
from ariel.utils.runners import simple_runner, thread_safe_runner
from ariel.utils.tracker import Tracker

# A free body with two hinge arms; actuator 0 limited to [-1, 1], actuator 1 unlimited.
TINY_XML = """
<mujoco>
  <option timestep="0.002" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="core" pos="0 0 0.2">
      <freejoint/>
      <geom name="core_geom" type="box" size="0.05 0.05 0.05" mass="0.2"/>
      <body name="arm1" pos="0.07 0 0">
        <joint name="j1" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 -0.05" size="0.01" mass="0.02"/>
      </body>
      <body name="arm2" pos="-0.07 0 0">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 -0.1 0 -0.05" size="0.01" mass="0.02"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="j1" kp="1" kv="0.1" ctrlrange="-1 1"/>
    <position joint="j2" kp="1" kv="0.1" ctrllimited="false"/>
  </actuator>
</mujoco>
"""


def tiny() -> tuple[mujoco.MjSpec, mujoco.MjModel, mujoco.MjData]:
    spec = mujoco.MjSpec.from_string(TINY_XML)
    model = spec.compile()
    return spec, model, mujoco.MjData(model)


def wave(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    return np.array([2.0 * math.sin(3.0 * data.time), 2.0 * math.cos(2.0 * data.time)])


def test_tracker_is_reexported() -> None:
    assert controller_module.Tracker is Tracker


def test_fifteen_seconds_give_150_calls_and_15_snapshots() -> None:
    spec, model, data = tiny()
    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker.setup(spec, data)
    call_times: list[float] = []

    def callback(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
        call_times.append(d.time)
        return wave(m, d)

    controller = Controller(callback, time_steps_per_ctrl_step=50, time_steps_per_save=500)
    controller.tracker = tracker
    mujoco.set_mjcb_control(controller.set_control)
    simple_runner(model, data, duration=15)
    assert round(data.time / model.opt.timestep) == 7500
    assert len(call_times) == 150
    np.testing.assert_allclose(call_times, np.arange(150) * 0.1, atol=1e-9)
    snapshots = tracker.history["xpos"][0]
    assert len(snapshots) == 15
    np.testing.assert_allclose(snapshots[0], [0.0, 0.0, 0.2])  # first save: step 0


def test_blend_and_clip_to_actuator_ranges() -> None:
    _spec, model, data = tiny()
    low, high = actuator_bounds(model)
    np.testing.assert_array_equal(low, [-1.0, -math.pi / 2])
    np.testing.assert_array_equal(high, [1.0, math.pi / 2])
    controller = Controller(lambda m, d: [5.0, -0.4], alpha=0.5)
    mujoco.mj_resetData(model, data)
    data.ctrl[:] = [0.2, 0.2]
    controller.set_control(model, data)  # time 0: a control step
    np.testing.assert_allclose(data.ctrl, [1.0, -0.1])  # 0.2*0.5 + 5*0.5 -> clipped to 1
    controller.set_control(model, data)
    np.testing.assert_allclose(data.ctrl, [1.0, -0.25])
    data.time = 0.002  # not a control step: ctrl unchanged
    controller.set_control(model, data)
    np.testing.assert_allclose(data.ctrl, [1.0, -0.25])


def test_blend_and_clip_is_elementwise_for_batches() -> None:
    rng = np.random.default_rng(0)
    old, target = rng.normal(size=(5, 3)), rng.normal(size=(5, 3)) * 3
    low, high = np.array([-1.0, -2.0, -0.5]), np.array([1.0, 2.0, 0.5])
    batched = blend_and_clip(old, target, 0.3, low, high)
    for row in range(5):
        np.testing.assert_array_equal(
            blend_and_clip(old[row], target[row], 0.3, low, high), batched[row]
        )
    np.testing.assert_allclose(batched, np.clip(0.7 * old + 0.3 * target, low, high), atol=1e-15)


def test_torch_tensor_output_is_accepted() -> None:
    torch = pytest.importorskip("torch")
    _spec, model, data = tiny()
    controller = Controller(lambda m, d: torch.tensor([0.5, -0.5], dtype=torch.float32), alpha=1.0)
    controller.set_control(model, data)
    np.testing.assert_array_equal(data.ctrl, [0.5, -0.5])


def test_wrong_length_output_raises_one_line_error() -> None:
    _spec, model, data = tiny()
    controller = Controller(lambda m, d: [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"^controller returned 3 values; model has 2 actuators$"):
        controller.set_control(model, data)


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_output_raises(bad: float) -> None:
    _spec, model, data = tiny()
    controller = Controller(lambda m, d: [0.1, bad])
    mujoco.set_mjcb_control(controller.set_control)
    with pytest.raises(ValueError, match=r"NaN|inf"):
        mujoco.mj_step(model, data)
    mujoco.set_mjcb_control(None)
    assert np.all(np.isfinite(data.ctrl))  # nothing was written


def test_unset_tracker_is_skipped() -> None:
    _spec, model, data = tiny()
    controller = Controller(wave)  # default Tracker(): never set up
    assert not controller.tracker.is_set_up
    mujoco.set_mjcb_control(controller.set_control)
    simple_runner(model, data, duration=1.2)  # passes save steps 0 and 500
    assert controller.tracker.history == {}


def test_invalid_configuration() -> None:
    with pytest.raises(ValueError, match="time_steps_per_ctrl_step"):
        Controller(wave, time_steps_per_ctrl_step=0)
    with pytest.raises(ValueError, match="alpha"):
        Controller(wave, alpha=1.5)
    with pytest.raises(TypeError, match="callable"):
        Controller("not a function")


def test_thread_safe_runner_matches_global_callback_bit_for_bit() -> None:
    spec, model, data = tiny()
    tracker_a = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker_a.setup(spec, data)
    mujoco.set_mjcb_control(Controller(wave, 25, 100, 0.5, tracker_a).set_control)
    simple_runner(model, data, duration=2.0)
    mujoco.set_mjcb_control(None)
    qpos_a = data.qpos.copy()

    data_b = mujoco.MjData(model)
    tracker_b = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker_b.setup(spec, data_b)
    thread_safe_runner(model, data_b, Controller(wave, 25, 100, 0.5, tracker_b), duration=2.0)
    np.testing.assert_array_equal(data_b.qpos, qpos_a)
    assert data_b.time == pytest.approx(2.0)
    np.testing.assert_array_equal(tracker_a.history["xpos"][0], tracker_b.history["xpos"][0])
    assert np.abs(qpos_a[7:]).max() > 0.1  # the arms moved


def test_controller_with_nacpg_matches_vectorised_path() -> None:
    """What the evaluation engine does (kernel targets, float32 cast, blend_and_clip) gives the
    same controls as the tutorial path, bit for bit."""
    pytest.importorskip("torch")
    from ariel.simulation.controllers.cpg_kernel import cpg_targets
    from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency

    _spec, model, data = tiny()
    cpg = NaCPG(create_fully_connected_adjacency(model.nu), seed=5)
    recorded: list[np.ndarray] = []

    def callback(m: mujoco.MjModel, d: mujoco.MjData):
        return cpg.forward(time=d.time)

    controller = Controller(callback, time_steps_per_ctrl_step=50, alpha=0.5)

    def spy(m: mujoco.MjModel, d: mujoco.MjData) -> None:
        controller.set_control(m, d)
        if round(d.time / m.opt.timestep) % 50 == 0:
            recorded.append(d.ctrl.copy())

    mujoco.set_mjcb_control(spy)
    simple_runner(model, data, duration=3.0)
    mujoco.set_mjcb_control(None)

    times = np.arange(30) * 50 * model.opt.timestep  # 3 s: a control call every 0.1 s
    targets = cpg_targets(cpg.get_flat_params().numpy(), cpg.initial_state, times)
    targets = targets.astype(np.float32).astype(np.float64)
    low, high = actuator_bounds(model)
    ctrl = np.zeros(model.nu)
    expected = []
    for row in targets:
        ctrl = blend_and_clip(ctrl, row, 0.5, low, high)
        expected.append(ctrl)
    assert len(recorded) == 30
    np.testing.assert_array_equal(np.array(recorded), np.array(expected))


def test_output_of_another_shape_or_none_and_a_text_alpha_are_one_line_errors() -> None:
    _spec, model, data = tiny()
    with pytest.raises(ValueError, match=r"shape \(2, 4\); model has 8 actuators"):
        controller_module._as_controls(np.zeros((2, 4)), 8)  # was flattened into 8 controls
    Controller(lambda m, d: [[0.1], [0.2]]).set_control(model, data)  # a column: one per joint
    with pytest.raises(TypeError, match="returned None"):
        Controller(lambda m, d: None).set_control(model, data)
    with pytest.raises(TypeError, match="Controller: alpha must be a number"):
        Controller(wave, alpha="0.5")  # type: ignore[arg-type]
    simple_runner(model, data, duration=0.01, steps_per_loop=np.int64(2))  # type: ignore
