"""Headless OpenGL helpers for MuJoCo rendering.

MuJoCo picks its OpenGL backend from the ``MUJOCO_GL`` environment variable when ``mujoco`` is
first imported (``egl`` or ``osmesa`` for headless machines, ``glfw`` for a desktop). Setting it
later has no effect, so ``make run``/``make test`` and ``tests/conftest.py`` set
``MUJOCO_GL=egl`` before anything imports ``mujoco``. Scripts can call
:func:`ensure_headless_gl` as their very first action instead.

This module imports ``mujoco`` only inside functions, so calling :func:`ensure_headless_gl`
from it is safe before ``mujoco`` has been imported.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import mujoco

__all__ = ["NO_GL_MESSAGE", "create_renderer", "ensure_headless_gl", "has_display"]

NO_GL_MESSAGE = (
    "no OpenGL backend available for headless rendering (MUJOCO_GL={backend}): "
    "install EGL (libegl1, libgl1-mesa-dri) or OSMesa (libosmesa6) "
    "and set MUJOCO_GL=egl or osmesa"
)


def ensure_headless_gl(backend: str = "egl") -> bool:
    """Select a headless GL backend if the user has not chosen one.

    Sets ``MUJOCO_GL=backend`` only on Linux, only when ``MUJOCO_GL`` is unset and only while
    ``mujoco`` has not been imported yet (afterwards the variable would be ignored). Returns
    True when it set the variable.
    """
    if sys.platform != "linux" or "MUJOCO_GL" in os.environ or "mujoco" in sys.modules:
        return False
    os.environ["MUJOCO_GL"] = backend
    return True


def _no_gl_error(cause: BaseException | None) -> RuntimeError:
    backend = os.environ.get("MUJOCO_GL") or "<unset>"
    message = NO_GL_MESSAGE.format(backend=backend)
    if cause is not None:
        first_line = (str(cause).strip().splitlines() or [type(cause).__name__])[0]
        message += f" (cause: {type(cause).__name__}: {first_line})"
    return RuntimeError(message)


def create_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """Create a ``mujoco.Renderer`` of ``width`` x ``height`` pixels, headless-friendly.

    The model's offscreen framebuffer is enlarged when the image is larger than it (MuJoCo
    refuses otherwise); the original size is restored once the GL context exists, so the
    model is left as it was. Raises a one-line ``RuntimeError`` when no OpenGL backend works.
    """
    import mujoco

    if not (isinstance(width, int) and isinstance(height, int)) or width <= 0 or height <= 0:
        raise ValueError(
            f"image size must be positive integers, got width={width!r}, height={height!r}"
        )
    renderer_cls = getattr(mujoco, "Renderer", None)
    if renderer_cls is None:  # mujoco could not import its rendering module at all
        raise _no_gl_error(None)

    global_vis = model.vis.global_
    old_size = (int(global_vis.offwidth), int(global_vis.offheight))
    global_vis.offwidth = max(old_size[0], width)
    global_vis.offheight = max(old_size[1], height)
    try:
        return renderer_cls(model, height=height, width=width)
    except Exception as exc:  # any failure to create a GL context means: no usable backend
        raise _no_gl_error(exc) from exc
    finally:
        # The framebuffer is allocated when the context is made; the model can be restored.
        global_vis.offwidth, global_vis.offheight = old_size


def has_display() -> bool:
    """Whether an interactive window can open here (Linux and other X11/Wayland systems:
    ``DISPLAY`` or ``WAYLAND_DISPLAY``; macOS and Windows always)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
