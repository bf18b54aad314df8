"""An upstream-style script: the gecko driven by a SimpleCPG through the tutorial Controller,
run headless; it must move."""

from __future__ import annotations

import mujoco
import numpy as np

from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
from ariel.simulation.controllers.controller import Controller
from ariel.simulation.controllers.simple_cpg import SimpleCPG, create_fully_connected_adjacency
from ariel.simulation.controllers.utils.data_get import get_state_from_data
from ariel.simulation.environments import SimpleFlatWorld
from ariel.utils.runners import simple_runner
from ariel.utils.tracker import Tracker


def run_gecko(seed: int, duration: float = 3.0) -> list[np.ndarray]:
    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=(0, 0, 0))
    model = world.spec.compile()
    data = mujoco.MjData(model)
    cpg = SimpleCPG(create_fully_connected_adjacency(model.nu), seed=seed)
    cpg.set_params_by_group("w", np.full(model.nu, 2 * np.pi))  # one stride per second

    def policy(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
        assert get_state_from_data(d).shape == (3 + m.nu,)
        return cpg(d.time).numpy()

    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core")
    tracker.setup(world.spec, data)
    controller = Controller(controller_callback_function=policy, tracker=tracker)
    mujoco.set_mjcb_control(controller.set_control)
    try:
        simple_runner(model, data, duration=duration)
    finally:
        mujoco.set_mjcb_control(None)
    return tracker.history["xpos"][0]


def test_simple_cpg_gecko_moves_and_repeats() -> None:
    path = run_gecko(seed=1)
    assert len(path) == 3  # a snapshot every 500 steps (1 s): at 0, 1 and 2 s
    moved = float(np.linalg.norm(path[-1][:2] - path[0][:2]))
    assert 0.01 < moved < 5.0
    again = run_gecko(seed=1)
    assert np.array_equal(np.array(path), np.array(again))
