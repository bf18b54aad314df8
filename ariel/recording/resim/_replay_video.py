"""A replay (`ReplayResult`) on film: an MP4 of its full-rate motion, filmed by a camera that
tracks the robot's core, with the replay's controls driving MuJoCo (`drive_replay`).

Loaded at call time, through `ariel.recording.resim`, after the replay simulated: mujoco was
imported then with the GL backend ``MUJOCO_GL`` named (`ariel replay --video` sets egl first
where no display is set; setting it now would be ignored); one that fails is
`ariel.utils.create_renderer`'s one line.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco

from ariel.evaluation import SPAWN_PREFIX
from ariel.utils.renderers import tracking_video_renderer
from ariel.utils.video_recorder import VideoRecorder

if TYPE_CHECKING:
    from ariel.recording.resim._replay import ReplayResult

__all__ = ["drive_replay", "replay_video"]


def replay_video(
    replayed: ReplayResult, path: str | Path, *, width: int, height: int, fps: int
) -> Path:
    """`ReplayResult.write_video`: the MP4 at ``path``."""
    replayed._need_body("a video")
    model = replayed.model
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:  # beside the video (one rename onto it); failing, it is the video that cannot be
        folder = tempfile.TemporaryDirectory(dir=path.parent, prefix=".replay-")
    except OSError as exc:  # written: the error names it, not our hidden scratch folder
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    with folder as scratch:
        recorder = VideoRecorder(
            "replay", output_folder=scratch, width=width, height=height, fps=fps
        )
        with drive_replay(replayed, model):
            tracking_video_renderer(
                model,
                mujoco.MjData(model),
                duration=replayed.task.duration,
                video_recorder=recorder,
                geom_to_track=f"{SPAWN_PREFIX}core",
            )
        os.replace(recorder.path, path)  # the recorder stamps its names; keep the asked one
    return path


@contextlib.contextmanager
def drive_replay(replayed: ReplayResult, model: mujoco.MjModel) -> Iterator[None]:
    """`ReplayResult.driven`: while inside, every ``mj_step`` of ``model`` applies the replay's
    controls (through the process-wide ``mjcb_control``; the previous one is restored)."""
    controls = replayed.controls()
    dt = float(model.opt.timestep)
    last = controls.shape[0] - 1

    def apply(m: mujoco.MjModel, d: mujoco.MjData) -> None:
        if m.nu:
            d.ctrl[:] = controls[min(max(0, round(d.time / dt)), last)]

    previous = mujoco.get_mjcb_control()
    mujoco.set_mjcb_control(apply)
    try:
        yield
    finally:
        mujoco.set_mjcb_control(previous)
