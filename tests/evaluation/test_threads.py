"""Evaluations in two threads of one process at once (a notebook's two runs, a user's own
thread pool): the same results as one at a time, and no crash (issue 27, probe X)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import mujoco

from ariel.simulation.control_callback import control_callback_unset
from ariel.utils import SharedSetting

# In a child process: the crash this guards against was a segfault (two threads stepping one
# cached mujoco.rollout.Rollout), which would take the test session down with it.
_TWO_THREADS = """
import threading
import numpy as np
from ariel.evaluation import BodySpec, EvaluationTask, evaluate_batch

params = np.random.default_rng(0).uniform(-1, 1, (6, 40))
tasks = [
    EvaluationTask(body=BodySpec("prebuilt", "gecko"), params=p, world="flat",
                   fitness="xy_displacement", duration=1.0, seed=1, eval_id=f"c{i}")
    for i, p in enumerate(params)
]
alone = [r.fitness for r in evaluate_batch(tasks)]
same = []
def evaluate_again():
    for _ in range(3):
        same.append([r.fitness for r in evaluate_batch(tasks)] == alone)
threads = [threading.Thread(target=evaluate_again) for _ in range(2)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
print(len(same), all(same), len(set(alone)) > 1)
"""


def test_two_threads_evaluating_at_once_get_what_one_gets_alone() -> None:
    env = {**os.environ, "MUJOCO_GL": "egl"}
    done = subprocess.run(
        [sys.executable, "-c", _TWO_THREADS], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["6", "True", "True"]


def test_a_shared_setting_is_put_back_when_the_last_overlapping_thread_leaves() -> None:
    box = {"value": "mine"}
    setting = SharedSetting(lambda: box["value"], lambda v: box.update(value=v), "held")
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()

    def first() -> None:
        with setting.held():
            first_in.set()
            second_in.wait(10)
        first_out.set()

    thread = threading.Thread(target=first)
    thread.start()
    first_in.wait(10)
    with setting.held():  # entered while the other holds it, left after the other left
        second_in.set()
        first_out.wait(10)
        assert box["value"] == "held"  # the first one out did not put it back under us
    thread.join()
    assert box["value"] == "mine"  # saving around each use left "held" here for good


def test_the_control_callback_is_back_after_overlapping_unsets() -> None:
    def callback(model: mujoco.MjModel, data: mujoco.MjData) -> None: ...

    mujoco.set_mjcb_control(callback)
    try:
        with control_callback_unset():
            with control_callback_unset():  # re-entered, as a nested compile does
                assert mujoco.get_mjcb_control() is None
            assert mujoco.get_mjcb_control() is None
        assert mujoco.get_mjcb_control() is callback
    finally:
        mujoco.set_mjcb_control(None)
