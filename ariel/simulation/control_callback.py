"""The process-wide MuJoCo control callback, set aside while code must not run it."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco

from ariel.utils import SharedSetting

__all__ = ["control_callback_unset"]

#: Unset while any thread is inside `control_callback_unset` (two threads' evaluations at
#: once: the first one out must not put the callback back under the other's rollout).
_UNSET = SharedSetting(mujoco.get_mjcb_control, mujoco.set_mjcb_control, None)


@contextlib.contextmanager
def control_callback_unset() -> Iterator[None]:
    """Unset the global ``mjcb_control`` for the duration, then put it back.

    ``MjSpec.compile()`` evaluates the model once, which runs a registered control callback (a
    Python one makes compile fail: "engine error: Python exception raised"), and
    ``mujoco.rollout`` steps without the GIL, where a Python callback must never run. The
    callback is process-global: don't use this while another thread steps a simulation that
    relies on it. Threads may overlap in it: the callback is back when the last one leaves.

    Yields:
        None; inside the ``with`` block no control callback is set (the previous one, if any,
        is restored on leaving, also on an exception).

    Example:
        ```python
        import mujoco

        from ariel.simulation.control_callback import control_callback_unset

        spec = mujoco.MjSpec()
        spec.worldbody.add_geom(size=[0.1, 0.1, 0.1])
        mujoco.set_mjcb_control(lambda model, data: None)
        with control_callback_unset():
            model = spec.compile()  # would fail with the Python callback set
        assert mujoco.get_mjcb_control() is not None  # put back
        mujoco.set_mjcb_control(None)
        ```
    """
    with _UNSET.held():
        yield
