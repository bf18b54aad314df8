"""NA-CPG controls computed on the device (Warp's CPU device here) equal the host's."""

from __future__ import annotations

import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, build
from ariel.evaluation._engine import held_controls, num_steps, open_loop_targets
from ariel.evaluation.builtin_plugins import MLPController, NaCPGController

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
pytestmark = pytest.mark.warp

from ariel.evaluation import _warp  # noqa: E402
from ariel.evaluation._warp_cpg import DeviceCPG, cpg_inputs, device_cpg_reason  # noqa: E402

GECKO = BodySpec("prebuilt", "gecko")
# Float32 targets that round the other way where the device fuses a multiply-add: one float32
# step of a value below pi/2.
FLOAT32_ROUNDING = 2.0**-23 * 2


def _states(controller, model, seeds) -> np.ndarray:
    out = []
    for seed in seeds:
        xy, xy_dot_old = controller.initial_state(model, seed)
        out.append(np.stack([xy, xy_dot_old], axis=-1))
    return np.array(out)


def _device_held(inputs, controller, smoothing, low, high, ncalls) -> np.ndarray:
    """The held control after each call, ``(B, calls, nu)``, from the device kernel."""
    wp, _ = _warp.warp_modules()
    with wp.ScopedDevice("cpu"):
        cpg = DeviceCPG(wp, inputs, controller, smoothing, low, high)
        cpg.load(inputs)
        ctrl = wp.zeros(inputs.z.shape[:2], dtype=wp.float32)
        held = []
        for _ in range(ncalls):
            cpg.launch(ctrl)
            held.append(cpg.held.numpy().copy())
        np.testing.assert_array_equal(ctrl.numpy(), held[-1].astype(np.float32))
    return np.stack(held, axis=1)


def test_device_controls_equal_the_hosts_to_float32_rounding() -> None:
    task = EvaluationTask(body=GECKO, duration=2.0, smoothing=0.3)
    built = build(task)
    model = built.model
    controller = NaCPGController(alpha=0.2)
    params = controller.random_parameters(model, np.random.default_rng(4), 6)
    seeds = [5, 5, 6, 7, 7, 8]
    nstep = num_steps(task, model)
    call_times = np.arange(0, nstep, task.control_period) * model.opt.timestep
    targets = open_loop_targets(controller, params, seeds, call_times, model)
    host = held_controls(targets, task.smoothing, built.low, built.high)
    inputs = cpg_inputs(controller, [(0, params, _states(controller, model, seeds))], call_times)
    device = _device_held(
        inputs, controller, task.smoothing, built.low, built.high, len(call_times)
    )
    np.testing.assert_allclose(device, host, rtol=0, atol=FLOAT32_ROUNDING)
    assert np.median(np.ptp(host, axis=1)) > 0.1  # the controls move: a real comparison


def test_networks_of_different_sizes_share_a_world_without_coupling() -> None:
    # A packed model's robots: one network per robot, each its own coupling block.
    controller = NaCPGController()
    rng = np.random.default_rng(9)
    sizes = (3, 5)
    params = [controller.random_parameters(_nu(n), rng, 4) for n in sizes]
    states = [rng.standard_normal((4, n, 2, 2)) for n in sizes]
    times = np.arange(12) * 0.1
    low, high = np.full(8, -1.2), np.full(8, 1.2)
    packed = cpg_inputs(controller, [(0, params[0], states[0]), (3, params[1], states[1])], times)
    together = _device_held(packed, controller, 0.5, low, high, times.size)
    for first, p, s, n in zip((0, 3), params, states, sizes):
        alone = cpg_inputs(controller, [(0, p, s)], times)
        own = _device_held(alone, controller, 0.5, low[:n], high[:n], times.size)
        np.testing.assert_array_equal(together[..., first : first + n], own)


def test_the_evaluator_gives_the_same_results_with_host_controls(monkeypatch) -> None:
    tasks = [
        EvaluationTask(body=GECKO, params=p, eval_id=f"e{i}", duration=0.5, seed=3)
        for i, p in enumerate(
            NaCPGController().random_parameters(build(EvaluationTask(body=GECKO)).model,
                                                np.random.default_rng(2), 3)
        )
    ]  # fmt: skip
    evaluator = _warp.WarpEvaluator("cpu")
    on_device = evaluator.evaluate_batch(tasks)
    monkeypatch.setattr(_warp, "device_cpg_reason", lambda controller: "host, for the test")
    on_host = evaluator.evaluate_batch(tasks)
    for a, b in zip(on_device, on_host):
        assert a.status == b.status == "ok"
        np.testing.assert_allclose(a.joint_target, b.joint_target, rtol=0, atol=FLOAT32_ROUNDING)
        np.testing.assert_allclose(a.core_pos, b.core_pos, rtol=0, atol=1e-5)


def test_only_the_na_cpg_has_a_device_kernel() -> None:
    assert device_cpg_reason(NaCPGController()) is None
    reason = device_cpg_reason(MLPController())
    assert reason is not None and "MLPController" in reason


def _nu(n: int):
    class Model:  # what random_parameters reads of a model
        nu = n

    return Model()
