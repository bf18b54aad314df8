"""Tracker (binding, history structure, reset) and the runners (exact step counts, validation)."""

from __future__ import annotations

import logging

import mujoco
import numpy as np
import pytest

from ariel.utils.runners import num_steps, simple_runner
from ariel.utils.tracker import Tracker

XML = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="robot1_core" pos="0 0 0.3">
      <freejoint/>
      <geom name="robot1_core" type="box" size="0.05 0.05 0.05"/>
      <geom name="robot1_core_extra" type="sphere" size="0.02" pos="0.06 0 0"/>
      <body name="arm" pos="0.1 0 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="arm_geom" type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="hinge" kp="1" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""


def build() -> tuple[mujoco.MjSpec, mujoco.MjModel, mujoco.MjData]:
    spec = mujoco.MjSpec.from_string(XML)
    model = spec.compile()
    return spec, model, mujoco.MjData(model)


def test_tracker_binds_by_name_substring_and_records_copies() -> None:
    spec, model, data = build()
    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos", "xmat"])
    tracker.setup(spec, data)
    assert tracker.is_set_up
    assert len(tracker.to_track) == 2  # robot1_core and robot1_core_extra, not floor/arm
    assert set(tracker.history) == {"xpos", "xmat"}
    assert set(tracker.history["xpos"]) == {0, 1}
    mujoco.mj_forward(model, data)
    tracker.update(data)
    mujoco.mj_step(model, data, nstep=200)  # falls under gravity
    tracker.update(data)
    first, second = tracker.history["xpos"][0]
    assert isinstance(first, np.ndarray) and first.shape == (3,)
    np.testing.assert_allclose(first, [0.0, 0.0, 0.3])
    assert second[2] < first[2]  # copies, not views of live data
    np.testing.assert_allclose(tracker.history["xpos"][1][0], [0.06, 0.0, 0.3])
    assert tracker.history["xmat"][0][0].shape == (9,)


def test_tracker_reset_and_resetup_keep_keys() -> None:
    spec, model, data = build()
    tracker = Tracker(mujoco.mjtObj.mjOBJ_BODY, "arm", ["xpos"])
    tracker.setup(spec, data)
    mujoco.mj_forward(model, data)
    tracker.update(data)
    tracker.setup(spec, data)  # existing lists are kept
    tracker.update(data)
    assert len(tracker.history["xpos"][0]) == 2
    tracker.reset()
    assert tracker.history == {"xpos": {0: []}}


def test_default_tracker_tracks_core_geoms_and_logs(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="ariel.utils.tracker"):
        tracker = Tracker()
    assert tracker.mujoco_obj_to_find == mujoco.mjtObj.mjOBJ_GEOM
    assert tracker.name_to_bind == "core"
    assert tracker.observable_attributes == ["xpos"]
    assert any("core" in record.message for record in caplog.records)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="ariel.utils.tracker"):
        Tracker(quiet=True)
        Tracker(mujoco.mjtObj.mjOBJ_BODY, None)  # one missing -> default, logged
    assert len(caplog.records) == 1


def test_tracker_before_setup_and_bad_input() -> None:
    tracker = Tracker(quiet=True)
    assert not tracker.is_set_up
    tracker.update(None)  # no-op
    tracker.reset()
    assert tracker.history == {}
    with pytest.raises(TypeError, match="MjSpec"):
        tracker.setup(object(), None)
    with pytest.raises(TypeError, match="list of names"):
        Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", "xpos")


def test_tracker_warns_when_nothing_matches(caplog: pytest.LogCaptureFixture) -> None:
    spec, _, data = build()
    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "no-such-name", ["xpos"])
    with caplog.at_level(logging.WARNING, logger="ariel.utils.tracker"):
        tracker.setup(spec, data)
    assert tracker.history == {"xpos": {}}
    assert "no-such-name" in caplog.text


@pytest.mark.parametrize(
    ("duration", "steps_per_loop", "expected"),
    [(15.0, 100, 7500), (1.0, 7, 500), (0.0031, 100, 2), (0.0, 100, 0), (0.2, 1000, 100)],
)
def test_simple_runner_steps_exactly(duration: float, steps_per_loop: int, expected: int) -> None:
    _, model, data = build()
    calls: list[float] = []
    mujoco.set_mjcb_control(lambda m, d: calls.append(d.time))
    data.ctrl[:] = 0.7
    mujoco.mj_step(model, data, nstep=13)  # dirty state: the runner resets it
    calls.clear()
    simple_runner(model, data, duration=duration, steps_per_loop=steps_per_loop)
    assert len(calls) == expected
    assert data.time == pytest.approx(expected * model.opt.timestep, abs=1e-9)
    assert calls[:1] in ([], [0.0])
    np.testing.assert_array_equal(data.ctrl, 0.0)  # reset, no random initial control


def test_simple_runner_validates() -> None:
    _, model, data = build()
    with pytest.raises(ValueError, match=">= 0"):
        simple_runner(model, data, duration=-1.0)
    with pytest.raises(ValueError, match=">= 0"):
        simple_runner(model, data, duration=float("nan"))
    with pytest.raises(ValueError, match="steps_per_loop"):
        simple_runner(model, data, duration=1.0, steps_per_loop=0)
    assert num_steps(model, 15) == 7500
