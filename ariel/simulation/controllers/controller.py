"""Controller: wraps a callable into a MuJoCo control callback (tutorial API).

It counts physics steps exactly, unlike upstream ARIEL (docs/decisions.md, Control).

``mujoco.set_mjcb_control(controller.set_control)`` makes MuJoCo call ``set_control`` once per
physics step (before actuation). With ``k = round(data.time / model.opt.timestep)``, the
physics step about to be taken:

* ``k % time_steps_per_save == 0``: ``tracker.update(data)`` (skipped if never set up);
* ``k % time_steps_per_ctrl_step == 0``: ``out = callback(model, data)`` and
  ``data.ctrl = blend_and_clip(data.ctrl, out, alpha, low, high)``, the bounds being the
  actuators' ctrlrange (``±π/2`` for actuators without ``ctrllimited``).

``blend_and_clip`` and ``actuator_bounds`` are shared with the vectorised evaluation engine so
both paths produce identical floats. Only numpy and mujoco are imported here (a torch tensor
returned by the callback is converted by duck typing).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from ariel.utils import number_argument
from ariel.utils.tracker import Tracker

__all__ = ["DEFAULT_CTRL_BOUND", "Controller", "Tracker", "actuator_bounds", "blend_and_clip"]

DEFAULT_CTRL_BOUND = math.pi / 2
"""Bound used for actuators whose control is not limited (upstream's hard-coded ±π/2)."""


def blend_and_clip(
    old: ArrayLike,
    target: ArrayLike,
    alpha: float,
    low: ArrayLike,
    high: ArrayLike,
) -> np.ndarray:
    """``clip(old * (1 - alpha) + target * alpha, low, high)`` (elementwise, broadcasting).

    The one formula for smoothing controls; works on ``(nu,)`` and batched ``(B, nu)`` arrays
    with identical per-element results.

    Args:
        old: The current controls.
        target: The controls the controller asks for.
        alpha: Weight of ``target``, in [0, 1] (1: take the target as is; 0: keep ``old``).
        low: Lower bounds (e.g. from `actuator_bounds`).
        high: Upper bounds.

    Returns:
        The new controls, float64, in a new array (``old`` is not changed).
    """
    old = np.asarray(old, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    blended = old * (1.0 - alpha)
    blended += target * alpha
    return np.clip(blended, low, high, out=blended)


def actuator_bounds(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Per-actuator ``(low, high)``: ctrlrange where ctrllimited, else ``±π/2``.

    Args:
        model: The compiled model.

    Returns:
        Two float64 arrays of shape ``(nu,)``: the lower and the upper bounds.
    """
    limited = np.asarray(model.actuator_ctrllimited, dtype=bool)
    ranges = np.asarray(model.actuator_ctrlrange, dtype=np.float64).reshape(-1, 2)
    low = np.where(limited, ranges[:, 0], -DEFAULT_CTRL_BOUND)
    high = np.where(limited, ranges[:, 1], DEFAULT_CTRL_BOUND)
    return low, high


def _as_controls(out: Any, nu: int) -> np.ndarray:
    """Callback output -> float64 ``(nu,)``; one-line errors for wrong size or NaN/inf."""
    if hasattr(out, "detach"):  # torch tensor (without importing torch)
        out = out.detach().cpu().numpy()
    if out is None:
        raise TypeError(
            f"controller returned None; it must return {nu} numbers (a return missing?)"
        )
    try:
        values = np.asarray(out, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(
            f"controller must return {nu} numbers (list, numpy array or tensor); "
            f"got {type(out).__name__}"
        ) from None
    if values.size != nu or (np.ndim(out) > 1 and max(np.shape(out)) != nu):
        shape = (
            f"an array of shape {np.shape(out)}" if np.ndim(out) > 1 else f"{values.size} values"
        )
        raise ValueError(f"controller returned {shape}; model has {nu} actuators")
    if not np.all(np.isfinite(values)):
        bad = "NaN" if np.isnan(values).any() else "inf"
        raise ValueError(f"controller returned {bad} control values: {values.tolist()}")
    return values


@dataclass
class Controller:
    """Calls ``controller_callback_function(model, data)`` every ``time_steps_per_ctrl_step``
    physics steps, blends its output into ``data.ctrl`` with ``alpha`` and clips it to the
    actuator ranges; updates ``tracker`` every ``time_steps_per_save`` steps.

    Register ``set_control`` with ``mujoco.set_mjcb_control``, or pass the controller to
    ``thread_safe_runner`` (see the module docstring for the step counting).

    Attributes:
        controller_callback_function: The brain, called as ``f(model, data)`` (plus any extra
            arguments ``set_control`` receives); returns ``nu`` control values (a list, numpy
            array or torch tensor), all finite.
        time_steps_per_ctrl_step: Physics steps between two calls of the brain (an int >= 1).
        time_steps_per_save: Physics steps between two ``tracker.update`` calls (an int >= 1).
        alpha: Weight of the brain's output in the new controls, in [0, 1] (1: use it as is;
            smaller values smooth the controls).
        tracker: Records object attributes over the run; updated only once it is set up.
            Default: a new ``Tracker()`` (geoms whose name contains "core", ``xpos``).

    Raises:
        TypeError: If ``controller_callback_function`` is not callable.
        ValueError: If a step count is not an int >= 1, or ``alpha`` is not in [0, 1].

    Example:
        ```python
        import mujoco
        import numpy as np

        from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
        from ariel.simulation.controllers.controller import Controller
        from ariel.simulation.environments import SimpleFlatWorld
        from ariel.utils.runners import thread_safe_runner
        from ariel.utils.tracker import Tracker

        world = SimpleFlatWorld()
        world.spawn(gecko().spec, position=[0, 0, 0])
        model = world.spec.compile()
        data = mujoco.MjData(model)


        def wave(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
            return np.full(model.nu, np.sin(2 * np.pi * data.time))


        tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
        tracker.setup(world.spec, data)
        controller = Controller(wave, time_steps_per_ctrl_step=10, tracker=tracker)
        thread_safe_runner(model, data, controller, duration=2.0)
        print(len(tracker.history["xpos"][0]))  # 2 s / 0.002 s / 500 steps per save = 2 samples
        ```
    """

    controller_callback_function: Callable[..., Any]
    time_steps_per_ctrl_step: int = 50
    time_steps_per_save: int = 500
    alpha: float = 0.5
    tracker: Tracker = field(default_factory=Tracker)
    _model: Any = field(default=None, init=False, repr=False, compare=False)
    _timestep: float = field(default=0.0, init=False, repr=False, compare=False)
    _bounds: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not callable(self.controller_callback_function):
            raise TypeError(
                "controller_callback_function must be callable as f(model, data); "
                f"got {type(self.controller_callback_function).__name__}"
            )
        for name in ("time_steps_per_ctrl_step", "time_steps_per_save"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1; got {value!r}")
        self.alpha = number_argument("Controller: alpha", self.alpha, what="a number in [0, 1]")
        if not (math.isfinite(self.alpha) and 0.0 <= self.alpha <= 1.0):
            raise ValueError(f"alpha must be in [0, 1]; got {self.alpha}")

    def set_control(
        self, model: mujoco.MjModel, data: mujoco.MjData, *args: Any, **kwargs: Any
    ) -> None:
        """The MuJoCo control callback (``mujoco.set_mjcb_control(controller.set_control)``)."""
        # Called every physics step: keep the common no-op step cheap. The timestep and bounds
        # are read once per model and again at every reset (time 0), not on every step.
        time = data.time
        if model is not self._model or time == 0.0:
            self._model = model
            self._timestep = model.opt.timestep
            self._bounds = actuator_bounds(model)
        step = round(time / self._timestep)
        if step % self.time_steps_per_save == 0:
            tracker = self.tracker
            if tracker is not None and getattr(tracker, "is_set_up", True):
                tracker.update(data)
        if step % self.time_steps_per_ctrl_step == 0:
            out = _as_controls(
                self.controller_callback_function(model, data, *args, **kwargs), model.nu
            )
            low, high = self._bounds
            data.ctrl[:] = blend_and_clip(data.ctrl, out, self.alpha, low, high)
