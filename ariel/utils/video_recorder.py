"""Write RGB frames to an H.264 MP4 file.

Uses the ffmpeg binary shipped with ``imageio-ffmpeg`` (no system ffmpeg or OpenCV needed).
Upstream ARIEL writes with OpenCV's ``mp4v`` fourcc; H.264 + yuv420p plays everywhere
(browsers, QuickTime, VS Code, Rerun).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Generator
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import imageio_ffmpeg
import numpy as np

__all__ = ["MAX_FPS", "MIN_FPS", "VideoRecorder"]

#: The most frames per second a video is written at (a thousand: far beyond any screen).
MAX_FPS = 1000
#: The fewest: a frame every 100 s (a time-lapse); fewer made a frame every 5e11 steps.
MIN_FPS = 0.01


class VideoRecorder:
    """Record frames to ``<output_folder>/<file_name>_<UTC YYYYmmdd_HHMMSS>.mp4``.

    Frames are RGB ``uint8`` arrays of shape ``(height, width, 3)``. The ffmpeg process starts
    on the first `write`, so a recorder that never receives a frame leaves no file.
    Use it as a context manager or call `release` to finish the file.

    Args:
        file_name: Stem of the file name, a plain name without folders (a suffix such as
            ".mp4" is dropped). If the stamped name exists, ``_1``, ``_2``... is appended.
        output_folder: Folder of the file, created if needed; None: the current directory.
        width: Frame width in pixels (positive and even, as H.264/yuv420p needs).
        height: Frame height in pixels (positive and even).
        fps: Frames per second of the video, from `MIN_FPS` to `MAX_FPS`.

    Raises:
        ValueError: If a size is not a positive even int, ``fps`` is outside `MIN_FPS` to
            `MAX_FPS`, or ``file_name`` is empty or has folders.
    """

    def __init__(
        self,
        file_name: str = "video",
        output_folder: str | Path | None = None,
        width: int = 640,
        height: int = 480,
        fps: int = 30,
    ) -> None:
        for label, value in (("width", width), ("height", height)):
            if not isinstance(value, int | np.integer) or isinstance(value, bool) or value <= 0:
                raise ValueError(f"{label} must be a positive integer, got {value!r}")
            if value % 2:
                # yuv420p stores colour at half resolution: both sides must be even.
                raise ValueError(f"{label} must be even for H.264/yuv420p video, got {value}")
        if not (
            isinstance(fps, int | float | np.integer | np.floating)
            and not isinstance(fps, bool)
            and MIN_FPS <= fps <= MAX_FPS
        ):  # 1e9 was taken (ffmpeg's frame timing then fails far from here), NaN too; 1e-9
            # made a frame every 5e11 physics steps
            raise ValueError(f"fps must be a number from {MIN_FPS} to {MAX_FPS}, got {fps!r}")
        if not file_name or Path(file_name).name != file_name:
            raise ValueError(
                f"file_name must be a plain file name without folders, got {file_name!r}"
            )

        self.width = int(width)
        self.height = int(height)
        self.fps = fps
        self.frame_count = 0
        folder = Path.cwd() if output_folder is None else Path(output_folder)
        folder.mkdir(parents=True, exist_ok=True)
        self.output_folder = folder
        self.path = self._unique_path(folder, file_name)
        self._writer: Generator[Any, Any, None] | None = None
        self._released = False

    @staticmethod
    def _unique_path(folder: Path, file_name: str) -> Path:
        stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%d_%H%M%S")
        stem = f"{Path(file_name).stem}_{stamp}"
        path = folder / f"{stem}.mp4"
        counter = 1
        while path.exists():  # two recorders in the same second must not overwrite each other
            path = folder / f"{stem}_{counter}.mp4"
            counter += 1
        return path

    def _start(self) -> None:
        self._writer = imageio_ffmpeg.write_frames(
            str(self.path),
            size=(self.width, self.height),
            fps=self.fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            macro_block_size=2,  # sizes are even, so ffmpeg never rescales the frames
            quality=None,
            output_params=["-crf", "20", "-movflags", "+faststart"],
        )
        self._writer.send(None)  # start the ffmpeg process

    def write(self, frame: np.ndarray) -> None:
        """Append one RGB ``uint8`` frame of shape ``(height, width, 3)``."""
        if self._released:
            raise RuntimeError(f"VideoRecorder for {self.path} was already released")
        frame = np.asarray(frame)
        expected = (self.height, self.width, 3)
        if frame.shape != expected:
            raise ValueError(
                f"frame shape must be (height, width, 3) = {expected}, got {frame.shape}"
            )
        if frame.dtype != np.uint8:
            raise ValueError(f"frame dtype must be uint8, got {frame.dtype}")
        if self._writer is None:
            self._start()
        assert self._writer is not None
        self._writer.send(np.ascontiguousarray(frame))
        self.frame_count += 1

    def release(self) -> None:
        """Finish the file (flush ffmpeg). Safe to call more than once."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        self._released = True

    @property
    def duration(self) -> float:
        """Length of the recorded video in seconds."""
        return self.frame_count / float(self.fps)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()

    def __repr__(self) -> str:
        return (
            f"VideoRecorder(path={str(self.path)!r}, size={self.width}x{self.height}, "
            f"fps={self.fps}, frames={self.frame_count})"
        )
