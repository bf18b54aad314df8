"""A replay (`ReplayResult`) played in MuJoCo's interactive viewer, in real time.

Loaded at call time, through `ariel.recording.resim`: ``mujoco.viewer`` needs a display, and
mujoco reads its GL backend (``MUJOCO_GL``) when first imported (the cli chose it before).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import mujoco
import mujoco.viewer

from ariel.utils import has_display

if TYPE_CHECKING:
    from ariel.recording.resim._replay import ReplayResult

__all__ = ["play_replay"]


def play_replay(replayed: ReplayResult, *, loop: bool) -> None:
    """`ReplayResult.view`: the full-rate motion in the passive viewer, again while ``loop``."""
    if not has_display():
        raise RuntimeError("no display: the viewer needs a desktop session (DISPLAY unset)")
    replayed._need_body("the viewer")
    model = replayed.model
    controls = replayed.controls()
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    with mujoco.viewer.launch_passive(model, data) as viewer:
        while viewer.is_running():
            mujoco.mj_resetData(model, data)
            start = time.perf_counter()
            for k in range(controls.shape[0]):
                if not viewer.is_running():
                    return
                data.ctrl[:] = controls[k]
                mujoco.mj_step(model, data)
                viewer.sync()
                ahead = (k + 1) * dt - (time.perf_counter() - start)
                if ahead > 0:
                    time.sleep(ahead)
            if not loop:
                return
