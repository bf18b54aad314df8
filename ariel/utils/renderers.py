"""Headless renderers: one frame, a fixed-camera video, a tracking video (tutorial API).

Rendering needs an OpenGL backend. On a machine without a display set ``MUJOCO_GL=egl``
(or ``osmesa``) before ``mujoco`` is first imported; ``make run``, ``make test``, the test
suite and the ``ariel`` commands that render do so. Without a working backend these functions
raise a one-line ``RuntimeError`` (`ariel.errors.GLBackendError`) saying what to install.

Camera: if the model has a camera named ``"ortho-cam"`` (every ARIEL world does) it is used,
with ``cam_fovy`` / ``cam_pos`` / ``cam_quat`` overriding its settings for this call only;
otherwise MuJoCo's default free camera frames the whole model (and the overrides, which
belong to "ortho-cam", raise ``ValueError`` instead of being silently ignored).

Differences from upstream ARIEL (on purpose):
* ``video_renderer`` steps by the MODEL's timestep so that frame ``i`` shows simulated time
  ``(i + 1) / fps`` and the video plays at real time (upstream assumes 0.002 s and a fixed
  ``floor(1 / (0.002 * fps))`` steps per frame, ~0.96x real time). A video of ``duration``
  seconds therefore has exactly ``round(duration * fps)`` frames.
* ``width`` / ``height`` mean what they say (upstream passes them to ``mujoco.Renderer`` in
  swapped order, so its 480 x 640 default comes out 640 wide and 480 tall).
* Camera overrides are restored after the call, and the camera's ``sensorsize`` is not
  touched (setting it makes a perspective camera ignore ``fovy``).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from ariel.utils._arguments import count_argument
from ariel.utils._gl import create_renderer
from ariel.utils.video_recorder import VideoRecorder

__all__ = ["single_frame_renderer", "tracking_video_renderer", "video_renderer"]

ORTHO_CAMERA_NAME = "ortho-cam"

CameraSpec = int | str | mujoco.MjvCamera


def _ortho_camera_id(model: mujoco.MjModel) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, ORTHO_CAMERA_NAME)


@contextmanager
def _camera(
    model: mujoco.MjModel,
    cam_fovy: float | None,
    cam_pos: Sequence[float] | None,
    cam_quat: Sequence[float] | None,
) -> Iterator[CameraSpec]:
    """Yield the camera to render with; overrides on "ortho-cam" last for the block only."""
    cam_id = _ortho_camera_id(model)
    if cam_id < 0:
        if any(v is not None for v in (cam_fovy, cam_pos, cam_quat)):
            # The overrides belong to "ortho-cam"; silently ignoring them would surprise.
            raise ValueError(
                f"cam_fovy/cam_pos/cam_quat need a camera named {ORTHO_CAMERA_NAME!r} in the "
                "model; this model has none (the default free camera is used without overrides)"
            )
        yield -1  # MuJoCo's default free camera
        return

    saved = (
        model.cam_fovy[cam_id].copy(),
        model.cam_pos[cam_id].copy(),
        model.cam_quat[cam_id].copy(),
    )
    try:
        if cam_fovy is not None:
            model.cam_fovy[cam_id] = float(cam_fovy)
        if cam_pos is not None:
            model.cam_pos[cam_id] = _vector(cam_pos, 3, "cam_pos")
        if cam_quat is not None:
            quat = _vector(cam_quat, 4, "cam_quat")
            norm = np.linalg.norm(quat)
            if norm == 0:
                raise ValueError("cam_quat must be a non-zero quaternion (w, x, y, z)")
            model.cam_quat[cam_id] = quat / norm
        yield cam_id
    finally:
        model.cam_fovy[cam_id], model.cam_pos[cam_id], model.cam_quat[cam_id] = saved


def _vector(values: Sequence[float], size: int, label: str) -> np.ndarray:
    array = np.asarray(values, dtype=float).reshape(-1)
    if array.shape != (size,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{label} must be {size} finite numbers, got {values!r}")
    return array


def _default_image_path() -> Path:
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d_%H-%M-%S-%f")
    return Path.cwd() / f"img_{stamp}.png"


def single_frame_renderer(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    steps: int = 1,
    width: int = 480,
    height: int = 640,
    cam_fovy: float | None = None,
    cam_pos: Sequence[float] | None = None,
    cam_quat: Sequence[float] | None = None,
    *,
    show: bool = False,
    save: bool = False,
    save_path: str | Path | None = None,
) -> Image.Image:
    """Reset ``data``, step ``steps`` times and return one ``width`` x ``height`` image.

    Args:
        model: The compiled model (with an "ortho-cam" camera, or the free camera is used).
        data: The model's data; it is reset, then stepped.
        steps: Physics steps to take after the reset (0: the initial state, after
            ``mj_forward``).
        width: Image width in pixels.
        height: Image height in pixels.
        cam_fovy: Vertical field of view of "ortho-cam" for this call (degrees for a
            perspective camera, metres for an orthographic one); None keeps the model's.
        cam_pos: Position ``(x, y, z)`` of "ortho-cam" for this call; None keeps the model's.
        cam_quat: Orientation ``(w, x, y, z)`` of "ortho-cam" for this call (normalised);
            None keeps the model's.
        show: Display the image with matplotlib.
        save: Write the image as a PNG (its folder is created if needed).
        save_path: Where ``save=True`` writes the PNG; None: ``./img_<UTC time>.png``. Ignored
            without ``save``.

    Returns:
        The rendered RGB image.

    Raises:
        TypeError: If ``steps`` is not a whole number (an int).
        ValueError: If ``steps`` is negative, the image size is not positive or above 16384
            pixels a side, a camera override is malformed, or an override is given and the
            model has no "ortho-cam".
        ariel.errors.GLBackendError: A ``RuntimeError``, when no OpenGL backend works.

    Example:
        ```python
        import os

        os.environ.setdefault("MUJOCO_GL", "egl")  # headless; set before mujoco is first imported

        import mujoco

        from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
        from ariel.simulation.environments import SimpleFlatWorld
        from ariel.utils.renderers import single_frame_renderer

        world = SimpleFlatWorld()
        world.spawn(gecko().spec, position=[0, 0, 0])
        model = world.spec.compile()
        data = mujoco.MjData(model)
        image = single_frame_renderer(model, data, steps=10, width=320, height=240)
        print(image.size)  # (320, 240)
        ```
    """
    steps = count_argument("steps", steps, maximum=10**9, function="single_frame_renderer")
    mujoco.mj_resetData(model, data)
    with _camera(model, cam_fovy, cam_pos, cam_quat) as camera:
        if steps > 0:
            mujoco.mj_step(model, data, nstep=int(steps))
        else:
            mujoco.mj_forward(model, data)
        renderer = create_renderer(model, width, height)
        try:
            renderer.update_scene(data, camera=camera)
            image = Image.fromarray(renderer.render())
        finally:
            renderer.close()

    if save:
        path = Path(save_path) if save_path is not None else _default_image_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        image.save(path)
    if show:
        import matplotlib.pyplot as plt  # lazy: only when a window is asked for

        plt.imshow(image)
        plt.axis("off")
        plt.show()
    return image


def _record(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    duration: float,
    recorder: VideoRecorder,
    camera: CameraSpec,
) -> None:
    """Step to each frame's time, render, write; the recorder is released at the end."""
    if not duration > 0:
        raise ValueError(f"duration must be > 0 seconds, got {duration}")
    timestep = float(model.opt.timestep)
    n_frames = max(1, round(duration * recorder.fps))
    try:
        renderer = create_renderer(model, recorder.width, recorder.height)
        try:
            step = 0
            for frame in range(1, n_frames + 1):
                # Target step counted from the reset: no drift from accumulating rounded counts.
                target = round(frame / (recorder.fps * timestep))
                if target > step:
                    mujoco.mj_step(model, data, nstep=target - step)
                    step = target
                renderer.update_scene(data, camera=camera)
                recorder.write(renderer.render())
        finally:
            renderer.close()
    finally:
        recorder.release()


def video_renderer(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    duration: float = 10.0,
    video_recorder: VideoRecorder | None = None,
    cam_fovy: float | None = None,
    cam_pos: Sequence[float] | None = None,
    cam_quat: Sequence[float] | None = None,
) -> None:
    """Reset ``data``, simulate ``duration`` seconds and record a real-time video.

    Frame ``i`` (from 1) shows simulated time ``i / fps``, so the video has
    ``round(duration * fps)`` frames (at least one) and plays at real time. Whatever control
    callback is registered drives the robot.

    Args:
        model: The compiled model (with an "ortho-cam" camera, or the free camera is used).
        data: The model's data; it is reset, then stepped.
        duration: Simulated seconds to record (> 0).
        video_recorder: Where the frames go; its ``width``, ``height`` and ``fps`` set the
            video's. None: a ``VideoRecorder()`` (``./video_<UTC time>.mp4``, 640 x 480,
            30 fps). It is released at the end; the file is at ``video_recorder.path``.
        cam_fovy: Vertical field of view of "ortho-cam" for this call (degrees for a
            perspective camera, metres for an orthographic one); None keeps the model's.
        cam_pos: Position ``(x, y, z)`` of "ortho-cam" for this call; None keeps the model's.
        cam_quat: Orientation ``(w, x, y, z)`` of "ortho-cam" for this call (normalised);
            None keeps the model's.

    Raises:
        ValueError: If ``duration`` is not positive, a camera override is malformed, or an
            override is given and the model has no "ortho-cam".
        ariel.errors.GLBackendError: A ``RuntimeError``, when no OpenGL backend works.

    Example:
        ```python
        import os
        import tempfile

        os.environ.setdefault("MUJOCO_GL", "egl")  # headless; set before mujoco is first imported

        import mujoco

        from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
        from ariel.simulation.environments import SimpleFlatWorld
        from ariel.utils.renderers import video_renderer
        from ariel.utils.video_recorder import VideoRecorder

        world = SimpleFlatWorld()
        world.spawn(gecko().spec, position=[0, 0, 0])
        model = world.spec.compile()
        data = mujoco.MjData(model)
        recorder = VideoRecorder("gecko", output_folder=tempfile.mkdtemp(), width=320, height=240)
        video_renderer(model, data, duration=1.0, video_recorder=recorder)
        print(recorder.path, recorder.frame_count)  # .../gecko_<UTC time>.mp4 30
        ```
    """
    recorder = video_recorder if video_recorder is not None else VideoRecorder()
    mujoco.mj_resetData(model, data)
    with _camera(model, cam_fovy, cam_pos, cam_quat) as camera:
        _record(model, data, duration, recorder, camera)


def _tracked_body_id(model: mujoco.MjModel, name: str) -> int:
    body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if body_id >= 0:
        return body_id
    for candidate in range(model.nbody):
        body_name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, candidate) or ""
        if "core" in body_name:
            return candidate
    raise ValueError(f"no body named {name!r} and no body whose name contains 'core' to track")


def tracking_video_renderer(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    duration: float = 10.0,
    video_recorder: VideoRecorder | None = None,
    geom_to_track: str = "robot-core",
    tracking_distance: float = 1.5,
    tracking_azimuth: float = 135,
    tracking_elevation: float = -30,
) -> None:
    """Like `video_renderer`, with a camera that follows the robot's core body.

    The camera starts on the centre of mass of the tracked body's subtree (the whole robot
    when that is its core) and moves with it. The model's cameras are not used.

    Args:
        model: The compiled model.
        data: The model's data; it is reset, then stepped.
        duration: Simulated seconds to record (> 0).
        video_recorder: Where the frames go (see `video_renderer`); None: a
            ``VideoRecorder()``. It is released at the end.
        geom_to_track: Name of the BODY to follow (despite the parameter's upstream name);
            if there is none, the first body whose name contains ``"core"`` (e.g.
            ``robot1_core``) is followed.
        tracking_distance: Distance from the camera to the tracked point, in metres.
        tracking_azimuth: Camera azimuth, in degrees.
        tracking_elevation: Camera elevation, in degrees (negative looks down).

    Raises:
        ValueError: If no body has that name and no body name contains ``"core"``, or
            ``duration`` is not positive.
        ariel.errors.GLBackendError: A ``RuntimeError``, when no OpenGL backend works.
    """
    body_id = _tracked_body_id(model, geom_to_track)
    recorder = video_recorder if video_recorder is not None else VideoRecorder()
    camera = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, camera)
    camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    camera.trackbodyid = body_id
    camera.distance = float(tracking_distance)
    camera.azimuth = float(tracking_azimuth)
    camera.elevation = float(tracking_elevation)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    # Start on the centre of mass of the body's subtree (the whole robot when tracking its
    # core): MuJoCo then moves the camera with that point, so the robot stays centred.
    camera.lookat[:] = data.subtree_com[body_id]
    _record(model, data, duration, recorder, camera)
