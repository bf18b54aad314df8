"""Closed loop: chunked stepping between policy calls.

A closed-loop controller's policy maps an observation to targets once per control period:
``mj_step(model, data, nstep=...)`` runs the physics steps between two events (a policy call, a
recorded frame), never a Python callback per physics step. Re-exported by
`ariel.evaluation._engine`.
"""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ariel.evaluation._build import BuiltBody
from ariel.evaluation._results import _blame, _finish, frame_steps, num_steps
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.controllers.controller import blend_and_clip
from ariel.simulation.controllers.observations import hinge_observation

if TYPE_CHECKING:
    from ariel.plugins import ClosedLoopController, FitnessFunction

_BAD_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)


def _closed_loop(
    task: EvaluationTask,
    built: BuiltBody,
    controller: ClosedLoopController,
    fitness_fn: FitnessFunction,
) -> EvaluationResult:
    model = built.model
    nstep = num_steps(task, model)
    period = task.control_period
    smoothing = task.smoothing
    policy = controller.make_policy(np.asarray(task.params), model)
    observe = getattr(controller, "observation", hinge_observation)
    steps = frame_steps(nstep, task.record_every)
    wanted = set(steps.tolist())
    qpos = np.empty((steps.size, model.nq))
    targets = np.empty((steps.size, model.nu))

    start = _time.perf_counter()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    boundaries = sorted(set(range(0, nstep, period)) | wanted)
    frame = 0
    stable = True
    with control_callback_unset():
        for i, k in enumerate(boundaries):
            if k % period == 0 and k < nstep:
                try:
                    out = np.asarray(policy(observe(model, data)), dtype=np.float64)
                except Exception as exc:
                    raise _blame(exc, f"controller {task.controller!r}") from None
                if out.shape != (model.nu,) or not np.all(np.isfinite(out)):
                    raise ValueError(
                        f"policy returned {out.shape} values (NaN/inf or wrong size); "
                        f"model has {model.nu} actuators"
                    )
                data.ctrl[:] = blend_and_clip(data.ctrl, out, smoothing, built.low, built.high)
            if k in wanted:
                qpos[frame] = data.qpos
                targets[frame] = data.ctrl
                frame += 1
            if k < nstep:
                mujoco.mj_step(model, data, nstep=boundaries[i + 1] - k)
                if any(data.warning[w].number for w in _BAD_WARNINGS) or not np.all(
                    np.isfinite(data.qpos)
                ):
                    stable = False
                    qpos[frame:] = data.qpos
                    targets[frame:] = data.ctrl
                    break
    wall = _time.perf_counter() - start
    return _finish(task, built, fitness_fn, steps * model.opt.timestep, qpos, targets, stable, wall)
