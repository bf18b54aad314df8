"""Headless runners (tutorial API; how they differ from upstream: docs/decisions.md, Control).

``simple_runner`` resets the data and steps exactly ``round(duration / timestep)`` physics
steps, in chunks, letting whatever control callback is registered drive the robot.
``thread_safe_runner`` drives a ``Controller`` directly, without the process-global MuJoCo
callback, so several simulations can run in threads.
"""

from __future__ import annotations

import math
import numbers
from typing import Protocol

import mujoco

from ariel.utils._arguments import number_argument

__all__ = ["num_steps", "simple_runner", "thread_safe_runner"]


class _SupportsSetControl(Protocol):
    def set_control(self, model: mujoco.MjModel, data: mujoco.MjData) -> None: ...


def num_steps(model: mujoco.MjModel, duration: float) -> int:
    """``round(duration / model.opt.timestep)``, with one-line errors for bad input.

    Args:
        model: The compiled model (its ``opt.timestep`` is used).
        duration: Simulated time in seconds (finite, >= 0).

    Returns:
        The number of physics steps that simulate ``duration`` seconds.

    Raises:
        TypeError: If ``duration`` is not a number (a string or a bool, say).
        ValueError: If ``duration`` is NaN, negative or infinite, or the timestep is not
            positive.
    """
    duration = number_argument("duration", duration, what="a number of seconds (an int or a float)")
    if math.isnan(duration) or duration < 0:
        raise ValueError(f"duration must be a number >= 0 seconds; got {duration}")
    if math.isinf(duration):
        raise ValueError("duration must be finite; got inf")
    timestep = float(model.opt.timestep)
    if not timestep > 0:
        raise ValueError(f"model.opt.timestep must be > 0; got {timestep}")
    return round(duration / timestep)


def simple_runner(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    duration: float = 10.0,
    steps_per_loop: int = 100,
) -> None:
    """Reset ``data`` (time 0, ``qpos0``, ``ctrl`` 0) and step ``round(duration / timestep)``
    steps, ``steps_per_loop`` at a time (the last chunk may be shorter).

    Whatever control callback is registered (``mujoco.set_mjcb_control``) drives the robot.

    Args:
        model: The compiled model.
        data: The model's data; it is reset, then stepped in place.
        duration: Simulated time in seconds (finite, >= 0).
        steps_per_loop: Physics steps per ``mj_step`` call (an int >= 1); the trajectory does
            not depend on it.

    Raises:
        TypeError: If ``duration`` is not a number (see `num_steps`).
        ValueError: If ``duration`` or ``steps_per_loop`` is out of range (see `num_steps`).
    """
    total = num_steps(model, duration)
    if (
        isinstance(steps_per_loop, bool)
        or not isinstance(steps_per_loop, numbers.Integral)
        or steps_per_loop < 1
    ):
        raise ValueError(f"steps_per_loop must be an integer >= 1; got {steps_per_loop!r}")
    mujoco.mj_resetData(model, data)
    remaining = total
    while remaining > 0:
        chunk = min(int(steps_per_loop), remaining)
        mujoco.mj_step(model, data, nstep=chunk)
        remaining -= chunk


def thread_safe_runner(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    controller: _SupportsSetControl,
    duration: float = 10.0,
) -> None:
    """Step ``round(duration / timestep)`` steps, calling ``controller.set_control`` before
    each step's actuation, without a global callback and without resetting ``data``.

    For the Euler and implicit integrators the step is split (``mj_step1``, control,
    ``mj_step2``), so the controller sees exactly what the global callback would see and the
    trajectory is the same as ``simple_runner`` with ``set_mjcb_control`` (after a reset).
    Leave the global callback unset, or it runs as well.

    Args:
        model: The compiled model.
        data: The model's data, stepped in place from its current state.
        controller: Any object with a ``set_control(model, data)`` method that writes
            ``data.ctrl`` (e.g. a `Controller`).
        duration: Simulated time in seconds (finite, >= 0).

    Raises:
        TypeError: If ``duration`` is not a number (see `num_steps`).
        ValueError: If ``duration`` is out of range (see `num_steps`).
    """
    total = num_steps(model, duration)
    split = model.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4
    for _ in range(total):
        if split:
            mujoco.mj_step1(model, data)
            controller.set_control(model, data)
            mujoco.mj_step2(model, data)
        else:  # RK4 cannot be split: compute the current kinematics, then control, then step
            mujoco.mj_forward(model, data)
            controller.set_control(model, data)
            mujoco.mj_step(model, data)
