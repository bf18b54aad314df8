"""Renderers and the video recorder, on a small hand-written model (no robot modules needed)."""

from __future__ import annotations

import re
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest

from ariel.errors import GLBackendError
from ariel.utils import _gl
from ariel.utils.renderers import (
    single_frame_renderer,
    tracking_video_renderer,
    video_renderer,
)
from ariel.utils.video_recorder import VideoRecorder

# A chequered floor, an "ortho-cam" like the ARIEL worlds', and a red core with a green arm.
SCENE_XML = """
<mujoco>
  <visual><headlight diffuse="0.6 0.6 0.6" ambient="0.1 0.1 0.1"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1=".1 .2 .3" rgb2=".2 .3 .4"
             width="300" height="300"/>
    <material name="grid" texture="grid" texrepeat="8 8"/>
  </asset>
  <worldbody>
    <light pos="0 0 3" directional="true" castshadow="false"/>
    <geom name="floor" type="plane" size="5 5 .1" material="grid"/>
    {camera}
    <body name="{core}" pos="0 0 .2">
      <freejoint/>
      <geom type="box" size=".1 .1 .1" rgba="1 0 0 1"/>
      <body pos=".2 0 0">
        <joint name="arm" type="hinge" axis="0 1 0"/>
        <geom type="box" size=".1 .05 .05" rgba="0 1 0 1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
ORTHO_CAM = (
    '<camera name="ortho-cam" projection="orthographic" pos="-5 0 5" '
    'xyaxes="0 -1 0 0.75 0 0.75" fovy="5"/>'
)


def _model(*, ortho: bool = True, core: str = "robot1_core") -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(
        SCENE_XML.format(camera=ORTHO_CAM if ortho else "", core=core)
    )


def _decode(path: Path) -> tuple[dict, list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(buf, np.uint8).reshape(height, width, 3) for buf in reader]
    return meta, frames


@pytest.fixture(scope="module")
def gl_available() -> None:
    """Skip rendering tests (with the library's own message) where no GL backend works."""
    try:
        _gl.create_renderer(_model(), 16, 16).close()
    except RuntimeError as exc:
        pytest.skip(str(exc))


# --- VideoRecorder (no OpenGL needed) -----------------------------------------------------


def test_recorder_rejects_odd_size(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="width must be even"):
        VideoRecorder(output_folder=tmp_path, width=641, height=480)
    with pytest.raises(ValueError, match="height must be even"):
        VideoRecorder(output_folder=tmp_path, width=640, height=479)
    with pytest.raises(ValueError, match="fps"):
        VideoRecorder(output_folder=tmp_path, fps=0)


def test_recorder_rejects_wrong_frame(tmp_path: Path) -> None:
    with VideoRecorder(output_folder=tmp_path, width=64, height=48) as recorder:
        with pytest.raises(ValueError, match=r"\(48, 64, 3\)"):
            recorder.write(np.zeros((64, 48, 3), np.uint8))
        with pytest.raises(ValueError, match="uint8"):
            recorder.write(np.zeros((48, 64, 3), np.float32))
    assert recorder.frame_count == 0
    assert not recorder.path.exists()  # no frame written -> no file


def test_recorder_writes_h264_mp4(tmp_path: Path) -> None:
    out = tmp_path / "videos"
    with VideoRecorder("clip", output_folder=out, width=64, height=48, fps=30) as recorder:
        assert out.is_dir()
        assert re.fullmatch(r"clip_\d{8}_\d{6}\.mp4", recorder.path.name)
        for i in range(12):
            frame = np.zeros((48, 64, 3), np.uint8)
            frame[:, : 5 * (i + 1)] = (255, 0, 0)  # a red band that grows: frames differ
            recorder.write(frame)
    assert recorder.frame_count == 12
    assert recorder.duration == pytest.approx(12 / 30)
    meta, frames = _decode(recorder.path)
    assert meta["codec"] == "h264"
    assert meta["pix_fmt"].startswith("yuv420p")
    assert meta["size"] == (64, 48)
    assert meta["fps"] == pytest.approx(30)
    assert len(frames) == 12
    assert frames[-1][:, 40:55, 0].mean() > 200  # the red band survived encoding
    assert frames[0][:, 40:55, 0].mean() < 50
    with pytest.raises(RuntimeError, match="released"):
        recorder.write(np.zeros((48, 64, 3), np.uint8))


def test_recorders_in_same_second_do_not_collide(tmp_path: Path) -> None:
    first = VideoRecorder(output_folder=tmp_path, width=16, height=16)
    first.write(np.zeros((16, 16, 3), np.uint8))
    first.release()
    second = VideoRecorder(output_folder=tmp_path, width=16, height=16)
    assert second.path != first.path


def test_recorder_defaults_to_cwd(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    recorder = VideoRecorder()
    assert recorder.path.parent == tmp_path
    assert (recorder.width, recorder.height, recorder.fps) == (640, 480, 30)


# --- GL errors (no OpenGL needed) -----------------------------------------------------------


def test_clear_error_without_gl_backend(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken_renderer(*args: object, **kwargs: object) -> None:
        raise mujoco.FatalError("gladLoadGL error")

    monkeypatch.setattr(mujoco, "Renderer", broken_renderer)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    model = _model()
    offscreen = (model.vis.global_.offwidth, model.vis.global_.offheight)
    with pytest.raises(RuntimeError) as info:
        single_frame_renderer(model, mujoco.MjData(model), width=2000, height=1500)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("no OpenGL backend available for headless rendering (MUJOCO_GL=egl)")
    assert "libegl1" in message and "libosmesa6" in message and "MUJOCO_GL=egl or osmesa" in message
    assert "gladLoadGL" in message  # the underlying cause is named
    # The model's framebuffer size is restored even on failure.
    assert (model.vis.global_.offwidth, model.vis.global_.offheight) == offscreen


def test_clear_error_when_mujoco_has_no_renderer(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.delattr(mujoco, "Renderer")
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    model = _model()
    with pytest.raises(RuntimeError, match=r"no OpenGL backend .*\(MUJOCO_GL=<unset>\)"):
        video_renderer(
            model,
            mujoco.MjData(model),
            duration=0.1,
            video_recorder=VideoRecorder(output_folder=tmp_path, width=16, height=16),
        )


def test_ensure_headless_gl_is_a_no_op_once_mujoco_is_imported(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    assert _gl.ensure_headless_gl() is False  # too late to matter: leave the env alone
    assert "MUJOCO_GL" not in __import__("os").environ


def _raised_in(module: str, exc: Exception) -> Exception:
    """``exc`` raised by code of ``module`` (its traceback passes through that module)."""
    namespace = {"__name__": module}
    exec("def fail(exc):\n    raise exc\n", namespace)
    try:
        namespace["fail"](exc)
    except Exception as raised:
        return raised
    raise AssertionError("not raised")


def test_a_failure_inside_the_gl_backend_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    """``import mujoco`` under MUJOCO_GL=egl, PyOpenGL installed, no libEGL: AttributeError
    in PyOpenGL; what the ``ariel`` command prints instead of the traceback."""
    monkeypatch.setenv("MUJOCO_GL", "egl")
    no_egl = AttributeError("'NoneType' object has no attribute 'eglQueryString'")
    error = _gl.gl_backend_error(_raised_in("OpenGL.raw.EGL._types", no_egl))
    assert isinstance(error, GLBackendError) and "\n" not in str(error)
    assert str(error).startswith(
        "no OpenGL backend available for headless rendering (MUJOCO_GL=egl)"
    )
    assert "libegl1" in str(error) and "unset MUJOCO_GL" in str(error)
    assert "(cause: AttributeError: 'NoneType' object has no attribute 'eglQueryString')" in str(
        error
    )
    # Failures elsewhere, the renderer module's own included, are not the backend's.
    assert _gl.gl_backend_error(_raised_in("ariel.cli", AttributeError("x"))) is None
    assert (
        _gl.gl_backend_error(_raised_in("mujoco.rendering.classic.renderer", ValueError())) is None
    )


# --- Rendering (needs OpenGL) ---------------------------------------------------------------


def _assert_not_blank(image: np.ndarray) -> None:
    assert image.dtype == np.uint8 and image.ndim == 3
    assert image.std() > 10  # not a flat colour
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 20


@pytest.mark.usefixtures("gl_available")
def test_single_frame_is_not_blank_and_has_requested_size(tmp_path: Path) -> None:
    model = _model()
    data = mujoco.MjData(model)
    target = tmp_path / "sub" / "frame.png"
    image = single_frame_renderer(
        model, data, steps=5, width=320, height=240, cam_fovy=1.5, save=True, save_path=target
    )
    assert image.size == (320, 240)  # PIL: (width, height)
    pixels = np.asarray(image)
    _assert_not_blank(pixels)
    red = (pixels[..., 0] > 150) & (pixels[..., 1] < 80) & (pixels[..., 2] < 80)
    assert red.sum() > 100  # the red core is in view
    assert target.is_file()
    assert data.time == pytest.approx(5 * model.opt.timestep)


@pytest.mark.usefixtures("gl_available")
def test_camera_overrides_apply_and_are_restored() -> None:
    model = _model()
    data = mujoco.MjData(model)
    before = (model.cam_fovy.copy(), model.cam_pos.copy(), model.cam_quat.copy())
    wide = np.asarray(single_frame_renderer(model, data, width=160, height=120))
    close = np.asarray(single_frame_renderer(model, data, width=160, height=120, cam_fovy=1.0))

    def red_pixels(image: np.ndarray) -> int:
        return int(((image[..., 0] > 150) & (image[..., 1] < 80)).sum())

    assert red_pixels(close) > 5 * red_pixels(wide) > 0  # zooming in made the robot bigger
    np.testing.assert_array_equal(model.cam_fovy, before[0])
    np.testing.assert_array_equal(model.cam_pos, before[1])
    np.testing.assert_array_equal(model.cam_quat, before[2])


def test_overrides_without_ortho_cam_are_rejected() -> None:
    model = _model(ortho=False)
    with pytest.raises(ValueError, match="ortho-cam"):
        single_frame_renderer(model, mujoco.MjData(model), cam_fovy=2.0)
    with pytest.raises(ValueError, match="cam_pos must be 3"):
        single_frame_renderer(_model(), mujoco.MjData(model), cam_pos=[1.0, 2.0])


@pytest.mark.usefixtures("gl_available")
def test_free_camera_without_ortho_cam() -> None:
    model = _model(ortho=False)
    image = np.asarray(single_frame_renderer(model, mujoco.MjData(model), width=160, height=120))
    _assert_not_blank(image)


@pytest.mark.usefixtures("gl_available")
def test_video_renderer_real_time_frame_count(tmp_path: Path) -> None:
    model = _model()
    model.opt.timestep = 0.005  # the model's timestep, not 0.002, sets the steps per frame
    data = mujoco.MjData(model)
    recorder = VideoRecorder("fixed", output_folder=tmp_path, width=160, height=120, fps=30)
    video_renderer(model, data, duration=1.0, video_recorder=recorder, cam_fovy=2.0)
    assert recorder.frame_count == 30
    assert data.time == pytest.approx(1.0, abs=model.opt.timestep)
    meta, frames = _decode(recorder.path)
    assert meta["size"] == (160, 120)
    assert len(frames) == 30
    _assert_not_blank(frames[0])
    # The core falls 9 cm onto the floor: the first and last frames differ.
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.05


@pytest.mark.usefixtures("gl_available")
def test_tracking_video_follows_core(tmp_path: Path) -> None:
    model = _model(ortho=False, core="my_core_body")  # found by the "core" substring
    data = mujoco.MjData(model)
    recorder = VideoRecorder("track", output_folder=tmp_path, width=160, height=120, fps=20)
    tracking_video_renderer(model, data, duration=0.5, video_recorder=recorder)
    _, frames = _decode(recorder.path)
    assert len(frames) == recorder.frame_count == 10
    last = frames[-1]
    red = (last[..., 0] > 150) & (last[..., 1] < 80) & (last[..., 2] < 80)
    rows, cols = np.nonzero(red)
    assert red.sum() > 50
    # The tracked core sits near the image centre.
    assert abs(rows.mean() - 60) < 30 and abs(cols.mean() - 80) < 40


def test_tracking_needs_a_core_body(tmp_path: Path) -> None:
    model = _model(core="torso")
    with pytest.raises(ValueError, match="contains 'core'"):
        tracking_video_renderer(
            model,
            mujoco.MjData(model),
            duration=0.1,
            video_recorder=VideoRecorder(output_folder=tmp_path, width=16, height=16),
        )


@pytest.mark.usefixtures("gl_available")
def test_gecko_frame_in_flat_world(tmp_path: Path) -> None:
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
    from ariel.simulation.environments import SimpleFlatWorld

    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=[0, 0, 0])
    model = world.spec.compile()
    image = single_frame_renderer(
        model,
        mujoco.MjData(model),
        width=320,
        height=240,
        cam_fovy=1.2,
        save=True,
        save_path=tmp_path / "gecko.png",
    )
    pixels = np.asarray(image).astype(int)
    _assert_not_blank(pixels.astype(np.uint8))
    # The yellow core and the red hinges of the gecko are in view.
    yellow = (pixels[..., 0] > 150) & (pixels[..., 1] > 150) & (pixels[..., 2] < 100)
    red = (pixels[..., 0] > 150) & (pixels[..., 1] < 80) & (pixels[..., 2] < 80)
    assert yellow.sum() > 200 and red.sum() > 50


@pytest.mark.parametrize("fps", [1e9, float("nan"), True, 1e-9])
def test_recorder_refuses_an_impossible_frame_rate(tmp_path: Path, fps: object) -> None:
    """1e9 frames per second and NaN were taken, to fail later inside the video writer; 1e-9
    made a frame every 5e11 physics steps."""
    with pytest.raises(ValueError, match=r"fps must be a number from 0\.01 to 1000"):
        VideoRecorder(output_folder=tmp_path, fps=fps)  # type: ignore[arg-type]


@pytest.mark.parametrize("steps", [float("nan"), 2.5, -1])
def test_single_frame_renderer_takes_whole_steps_only(steps: object) -> None:
    """steps=nan was taken (int(nan) failed deep inside); 2.5 was cut to 2."""
    import mujoco

    from ariel.utils.renderers import single_frame_renderer

    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises((TypeError, ValueError), match="single_frame_renderer: steps must be"):
        single_frame_renderer(model, mujoco.MjData(model), steps=steps)  # type: ignore[arg-type]
