"""The gallery's thumbnails: each body's start pose (after settling), drawn headless from the
report's three-quarter camera (`three_quarter_view`) aimed at the middle of the robot's box,
cached as a PNG in its run folder.

A thumbnail is ``RUN/gallery/thumbnails/<body_id>-<size>.png``: a body id names one body of a
run for good, so a thumbnail already there is reused, never drawn again. Only a regular file
that starts like a PNG counts (a link planted in a copied folder is drawn over, never read);
thumbnails are written whole (`atomic_write`), never through a linked folder.

Speed: MuJoCo's ``Renderer`` makes a GL context per image, and the first ``MjrContext`` on a
fresh context costs ~0.13 s on a software renderer (Mesa llvmpipe), its 8192-pixel shadow map
~0.1 s more. A `_Painter` keeps one GL context for all its thumbnails and makes each model's
``MjrContext`` with a 1024-pixel shadow map and a thumbnail-sized framebuffer of 2 samples
(~5 ms; drawing and reading the pixels ~8 ms more). Many thumbnails are drawn by a process
pool (forkserver, else spawn: never fork a process holding MuJoCo's threads), each worker a
chunk of them with one painter; few are drawn here, since a worker takes a second or two to
start.
"""

from __future__ import annotations

import contextlib
import hashlib
import multiprocessing
import re
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ariel.errors import ArielError
from ariel.recording.rerun import three_quarter_view
from ariel.recording.store import Run, atomic_write, cannot_write, load_run
from ariel.utils import gl_backend_error, mujoco_module

if TYPE_CHECKING:
    from multiprocessing.queues import SimpleQueue

    import mujoco  # lazy: loads its GL backend (MUJOCO_GL) on import
    import pandas as pd
    from PIL import Image

__all__ = [
    "THUMBNAIL_SIZE",
    "ThumbnailJob",
    "cached_thumbnail",
    "gl_problem",
    "render_thumbnails",
    "thumbnail_path",
]

THUMBNAIL_SIZE = 256  # pixels, square
#: The robot's box as `three_quarter_view` is told it: its picture (at most ~1.4 times the box
#: across, seen from 30 degrees above) then fills about three quarters of the thumbnail.
FRAMING = 0.75
SHADOW_SIZE = 1024  # pixels of the shadow map: looks as the model's 8192 does at this size
SAMPLES = 2  # multisampling: edges as smooth as with the model's 4, a third faster to read
#: Fewer thumbnails than this per worker to draw: they are drawn in this process.
PER_WORKER = 8
_PNG = b"\x89PNG\r\n\x1a\n"
_SAFE_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")


@dataclass(frozen=True)
class ThumbnailJob:
    """One thumbnail to draw: body ``body_id`` of the run in ``run_path``, to ``path``."""

    run_path: str
    body_id: str
    path: str


def thumbnail_path(run_path: Path, body_id: str, size: int = THUMBNAIL_SIZE) -> Path:
    """Where body ``body_id``'s thumbnail is cached: ``RUN/gallery/thumbnails/ID-SIZE.png``
    (an id that is not a plain name, from a crafted table, by its hash)."""
    name = body_id if _SAFE_NAME.fullmatch(body_id) else "body-" + _digest(body_id)
    return Path(run_path) / "gallery" / "thumbnails" / f"{name}-{size}.png"


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:16]


#: The largest cached thumbnail read back (pixels a side; they are drawn at 256): a crafted
#: PNG of 60,000 x 60,000 pixels is a few KB on disk and GBs decoded (in the sheet, and in
#: every browser that opens the gallery's page).
LARGEST_THUMBNAIL = 2048


def cached_thumbnail(path: Path) -> bytes | None:
    """The PNG at ``path`` when it is a regular file (not a link) that starts like one, of at
    most `LARGEST_THUMBNAIL` pixels a side (its IHDR header says)."""
    if path.is_symlink() or not path.is_file():
        return None
    with contextlib.suppress(OSError):
        data = path.read_bytes()
        if data.startswith(_PNG) and data[12:16] == b"IHDR":
            width, height = int.from_bytes(data[16:20]), int.from_bytes(data[20:24])
            if max(width, height) <= LARGEST_THUMBNAIL:
                return data
    return None


def gl_problem() -> str | None:
    """Why nothing can be drawn here (`create_renderer`'s one line, e.g. no EGL), or None."""
    mujoco = mujoco_module()

    from ariel.utils import renderers  # lazy: imports mujoco (as above)

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    try:
        renderers.create_renderer(model, 16, 16).close()
    except RuntimeError as exc:  # GLBackendError: what to install or set
        return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return None


@contextlib.contextmanager
def _thumbnail_settings(
    model: mujoco.MjModel, camera_id: int, view: dict[str, Any] | None
) -> Iterator[None]:
    """The camera overrides ``view`` on ``camera_id`` and a thumbnail's framebuffer and shadow
    map, for the block only: the model is the build cache's, shared (`build`)."""
    quality, buffers = model.vis.quality, model.vis.global_
    saved = (quality.shadowsize, quality.offsamples, buffers.offwidth, buffers.offheight)
    cameras = None
    if view is not None:
        cameras = (model.cam_fovy[camera_id].copy(), model.cam_pos[camera_id].copy())
        cameras += (model.cam_quat[camera_id].copy(),)
        model.cam_fovy[camera_id] = view["cam_fovy"]
        model.cam_pos[camera_id] = view["cam_pos"]
        model.cam_quat[camera_id] = view["cam_quat"]
    quality.shadowsize = min(int(saved[0]), SHADOW_SIZE)
    quality.offsamples = min(int(saved[1]), SAMPLES)
    buffers.offwidth = buffers.offheight = THUMBNAIL_SIZE
    try:
        yield
    finally:
        quality.shadowsize, quality.offsamples, buffers.offwidth, buffers.offheight = saved
        if cameras is not None:
            model.cam_fovy[camera_id], model.cam_pos[camera_id], model.cam_quat[camera_id] = cameras


class _Built(Protocol):
    """What a thumbnail needs of a built body (`ariel.evaluation.build`'s result)."""

    model: mujoco.MjModel
    core_geom: int
    robot_bodies: np.ndarray


class _Painter:
    """One GL context (``mujoco.GLContext``) for many thumbnails; see the module docstring."""

    def __init__(self, size: int = THUMBNAIL_SIZE) -> None:
        mujoco = mujoco_module()

        self.size = size
        try:
            self._context = mujoco.GLContext(size, size)
        except Exception as exc:  # the backend's own error: the one line that says why
            error = gl_backend_error(exc)
            if error is None:
                raise
            raise error from exc

    def paint(self, built: _Built) -> np.ndarray:
        """The RGB pixels (``size`` x ``size`` x 3) of ``built``'s start pose."""
        mujoco = mujoco_module()

        model, size = built.model, self.size
        camera = mujoco.MjvCamera()
        camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "ortho-cam")
        data = mujoco.MjData(model)
        view = _view(built, data) if camera_id >= 0 else None
        if view is None:  # no "ortho-cam": the free camera frames the whole model
            mujoco.mjv_defaultFreeCamera(model, camera)
        else:
            camera.type, camera.fixedcamid = mujoco.mjtCamera.mjCAMERA_FIXED, camera_id
        pixels = np.empty((size, size, 3), dtype=np.uint8)
        self._context.make_current()
        with _thumbnail_settings(model, camera_id, view):
            mujoco.mj_forward(model, data)  # places the camera: after the overrides
            context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50.value)
            try:
                mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, context)
                scene = mujoco.MjvScene(model, maxgeom=max(1000, 4 * model.ngeom))
                options, everything = mujoco.MjvOption(), mujoco.mjtCatBit.mjCAT_ALL.value
                mujoco.mjv_updateScene(model, data, options, None, camera, everything, scene)
                viewport = mujoco.MjrRect(0, 0, size, size)
                mujoco.mjr_render(viewport, scene, context)
                mujoco.mjr_readPixels(pixels, None, viewport, context)
            finally:
                context.free()
        return np.flipud(pixels)  # OpenGL's rows run bottom up

    def close(self) -> None:
        self._context.free()


def _view(built: _Built, data: mujoco.MjData) -> dict[str, Any]:
    """The report's three-quarter view (`three_quarter_view`) of ``built`` in its reset pose,
    aimed at the middle of the robot's box and sized to it (the report aims at the centre of
    mass, which a heavy core pulls aside, and sizes by the descriptors, which do not know the
    settled pose)."""
    mujoco = mujoco_module()

    model = built.model
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    geoms = np.flatnonzero(np.isin(model.geom_bodyid, built.robot_bodies))
    reach = model.geom_rbound[geoms, None]  # each geom's bounding sphere
    low = (data.geom_xpos[geoms] - reach).min(axis=0)
    high = (data.geom_xpos[geoms] + reach).max(axis=0)
    view = three_quarter_view(built, FRAMING * float((high - low).max()))
    aimed_at = data.subtree_com[model.geom_bodyid[built.core_geom]]
    view["cam_pos"] = view["cam_pos"] + (low + high) / 2 - aimed_at
    return view


def _draw(
    run: Run, body: dict[str, Any], evaluations: pd.DataFrame, painter: _Painter
) -> Image.Image:
    """The PIL image of ``body`` (a bodies-table row) of ``run``, built as its best evaluation
    was (`replay_task`, from the stored robot graph where there is one)."""
    from PIL import Image  # lazy: heavy optional library

    from ariel.evaluation import build  # lazy: imports mujoco, which reads MUJOCO_GL (as above)
    from ariel.recording.resim import replay_task  # lazy: slow (~0.6 s: the engine, networkx)

    row = evaluations.loc[body["best_eval_id"]].to_dict()
    row["eval_id"] = body["best_eval_id"]
    built = build(replay_task(run, row, graph=body.get("graph") or None))
    return Image.fromarray(painter.paint(built))


def _tables(run: Run) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The run's bodies by id (each its last row) and its evaluations by id."""
    bodies = run.bodies.drop_duplicates("body_id", keep="last").set_index("body_id", drop=False)
    evaluations = run.evaluations.drop_duplicates("eval_id").set_index("eval_id", drop=False)
    return bodies, evaluations


#: A pool worker's queue of finished thumbnails (`_report_to`), which the parent reads to
#: show progress while the chunks are drawn: a chunk's result only comes back at its end.
_FINISHED: SimpleQueue[int] | None = None


def _report_to(queue: SimpleQueue[int]) -> None:
    """A pool worker's initializer: put a token into ``queue`` per thumbnail finished."""
    global _FINISHED
    _FINISHED = queue


def _finished(on_done: Callable[[int], None] | None) -> None:
    if on_done is not None:
        on_done(1)
    elif _FINISHED is not None:
        _FINISHED.put(1)


def _render_chunk(
    jobs: Sequence[ThumbnailJob],
    runs: dict[str, Run] | None = None,
    on_done: Callable[[int], None] | None = None,
) -> list[tuple[str, str | None]]:
    """Draw ``jobs`` with one painter: ``(path, None)`` per thumbnail written, ``(path, why)``
    per body that could not be drawn. ``runs``: run path -> `Run` already loaded;
    ``on_done(1)`` after each thumbnail (in a pool worker: a token on its queue)."""
    runs = dict(runs or {})
    tables: dict[str, tuple[pd.DataFrame, pd.DataFrame]] = {}
    done: list[tuple[str, str | None]] = []
    painter = _Painter()
    try:
        for job in jobs:
            if job.run_path not in runs:
                runs[job.run_path] = load_run(job.run_path)
            run = runs[job.run_path]
            if job.run_path not in tables:
                tables[job.run_path] = _tables(run)
            bodies, evaluations = tables[job.run_path]
            try:
                image = _draw(run, bodies.loc[job.body_id].to_dict(), evaluations, painter)
                atomic_write(
                    Path(job.path),
                    lambda temporary, image=image: image.save(temporary, format="PNG"),
                    fsync=False,  # a cache: whole or absent is enough, durable is not needed
                    root=job.run_path,
                )
            except OSError as exc:  # disk full, read-only folder: the rest is still shown
                done.append((job.path, cannot_write(exc, job.path)))
            except (ArielError, KeyError, ValueError, RuntimeError) as exc:
                done.append((job.path, _reason(exc)))
            else:
                done.append((job.path, None))
            _finished(on_done)
    finally:
        painter.close()
    return done


def _reason(exc: BaseException) -> str:
    """``exc`` as one line: its message's first line, else its type."""
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def _chunks(jobs: Sequence[ThumbnailJob], workers: int) -> list[list[ThumbnailJob]]:
    """``jobs`` dealt round-robin into at most ``workers`` chunks of >= `PER_WORKER` each."""
    count = max(1, min(workers, len(jobs) // PER_WORKER))
    return [list(jobs[start::count]) for start in range(count)]


def render_thumbnails(
    jobs: Sequence[ThumbnailJob],
    *,
    workers: int,
    runs: dict[str, Run] | None = None,
    on_done: Callable[[int], None] | None = None,
) -> dict[str, str | None]:
    """Draw every job's thumbnail: path -> None (written) or why it could not be drawn.

    ``workers`` processes at most, `PER_WORKER` thumbnails each at least; what makes one
    chunk only is drawn in this process, with the runs in ``runs`` (run path -> `Run`).
    ``on_done(n)``: called in this process as thumbnails finish (n of them), for progress.
    """
    chunks = _chunks(jobs, workers) if jobs else []
    if len(chunks) <= 1:
        try:
            return dict(_render_chunk(jobs, runs, on_done))
        except RuntimeError as exc:  # no GL context after all
            return {job.path: _reason(exc) for job in jobs}
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    finished: SimpleQueue[int] = (
        context.SimpleQueue()
    )  # passed at each worker's start, as queues must be
    drawn: dict[str, str | None] = {}
    with ProcessPoolExecutor(
        max_workers=len(chunks), mp_context=context, initializer=_report_to, initargs=(finished,)
    ) as pool:
        futures = [pool.submit(_render_chunk, chunk) for chunk in chunks]
        pending = set(futures)
        while pending:  # progress as the workers' tokens come in
            pending = wait(pending, timeout=0.25)[1]
            _drain(finished, on_done)
        for chunk, future in zip(chunks, futures, strict=True):
            try:
                drawn.update(future.result())
            except (ArielError, RuntimeError, OSError) as exc:  # no GL there, a run that
                # does not load there, or a worker that died (BrokenProcessPool)
                drawn.update((job.path, _reason(exc)) for job in chunk)
    return drawn


def _drain(queue: SimpleQueue[int], on_done: Callable[[int], None] | None) -> None:
    """Take the tokens in ``queue`` now, and tell ``on_done`` how many."""
    count = 0
    while not queue.empty():
        queue.get()
        count += 1
    if count and on_done is not None:
        on_done(count)
