"""The process-wide MuJoCo control callback, set aside while code must not run it."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco

__all__ = ["control_callback_unset"]


@contextlib.contextmanager
def control_callback_unset() -> Iterator[None]:
    """Unset the global ``mjcb_control`` for the duration, then put it back.

    ``MjSpec.compile()`` evaluates the model once, which runs a registered control callback (a
    Python one makes compile fail: "engine error: Python exception raised"), and
    ``mujoco.rollout`` steps without the GIL, where a Python callback must never run. The
    callback is process-global: don't use this while another thread steps a simulation that
    relies on it.
    """
    callback = mujoco.get_mjcb_control()
    if callback is None:
        yield
        return
    mujoco.set_mjcb_control(None)
    try:
        yield
    finally:
        mujoco.set_mjcb_control(callback)
