"""Settling: let a spawned robot come to rest before anything is measured.

A body is spawned with its lowest point 1 cm above the ground, in its construction pose. Many
evolved bodies are not stable in that pose: they tip over in their first second, and a
displacement fitness measured from the spawn then counts the fall (docs/methodology.md). So an
evaluation may first hold the robot for ``settle`` seconds with every actuator at its zero
target (the pose a controller starts from) and measure from the pose it reaches.

`settle_model` does this once per compiled model: it simulates the held robot and makes the
pose it ends in the model's reset pose (``model.qpos0``), with zero velocity. Every later
``mj_resetData`` (the CPU engine, the closed-loop path, MuJoCo Warp's ``reset_data``, the
tutorial renderers used by replays) then starts there, so all paths agree without knowing
about settling.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ariel.simulation.control_callback import control_callback_unset

__all__ = ["SettleError", "settle_model", "settle_steps"]


class SettleError(RuntimeError):
    """The held robot's physics became unstable while it settled."""


def settle_steps(model: mujoco.MjModel, seconds: float) -> int:
    """Physics steps of a settle of ``seconds``: ``round(seconds / timestep)``.

    Args:
        model: the compiled model; its ``opt.timestep`` is used.
        seconds: the settle's duration in simulated seconds (finite, >= 0).

    Returns:
        The number of ``mj_step`` calls (0 for 0 seconds).

    Raises:
        ValueError: ``seconds`` is negative, NaN or infinite.
    """
    if not (math.isfinite(seconds) and seconds >= 0):
        raise ValueError(f"settle must be a finite number of seconds >= 0, not {seconds!r}")
    return round(seconds / model.opt.timestep)


def settle_model(model: mujoco.MjModel, seconds: float) -> mujoco.MjModel:
    """Make the pose ``model`` reaches after ``seconds`` held at zero controls its reset pose.

    Changes ``model.qpos0`` in place; a settle of 0 steps (see `settle_steps`) changes
    nothing. MuJoCo's global control callback is unset while the robot settles.

    Args:
        model: the compiled model of the robot in its world, edited in place.
        seconds: how long to hold the robot at zero controls, in simulated seconds (finite,
            >= 0; rounded to whole physics steps).

    Returns:
        ``model`` itself.

    Raises:
        ValueError: ``seconds`` is negative, NaN or infinite.
        SettleError: the positions or velocities stop being finite while the robot settles.
    """
    nstep = settle_steps(model, seconds)
    if nstep == 0:
        return model
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    data.ctrl[:] = 0.0
    with control_callback_unset():
        mujoco.mj_step(model, data, nstep=nstep)
    if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
        raise SettleError(f"physics became unstable while the robot settled ({seconds} s)")
    model.qpos0[:] = data.qpos
    return model
