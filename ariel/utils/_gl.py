"""Headless OpenGL helpers for MuJoCo rendering.

MuJoCo picks its OpenGL backend from the ``MUJOCO_GL`` environment variable when ``mujoco`` is
first imported (``egl`` or ``osmesa`` for headless machines, ``glfw`` for a desktop), and
imports that backend with itself. Setting it later has no effect, so ``make run``/``make test``
and ``tests/conftest.py`` set ``MUJOCO_GL=egl`` before anything imports ``mujoco``. The
``ariel`` command calls `ensure_headless_gl` only where it renders (``replay --video``,
``report`` without ``--no-render``) and no display is set: a command that draws nothing loads
no GL library. Scripts that render can call it as their very first action.

A backend that does not work is one line, `ariel.errors.GLBackendError`, naming what to install
or set: `create_renderer` raises it when no GL context can be made, and
`gl_backend_error` makes it from an ``import mujoco`` that failed inside the backend
(``MUJOCO_GL=egl`` with PyOpenGL installed but no libEGL raises ``AttributeError`` there, even
where nothing is rendered); the ``ariel`` command prints it (exit code 2).

This module imports ``mujoco`` only inside functions, so calling `ensure_headless_gl`
from it is safe before ``mujoco`` has been imported.
"""

from __future__ import annotations

import numbers
import os
import socket
import sys
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from ariel.errors import GLBackendError

if TYPE_CHECKING:
    import mujoco

__all__ = [
    "NO_GL_MESSAGE",
    "GLBackendError",
    "create_renderer",
    "ensure_headless_gl",
    "gl_backend_error",
    "has_display",
    "mujoco_module",
]

NO_GL_MESSAGE = (
    "no OpenGL backend available for headless rendering (MUJOCO_GL={backend}): "
    "install EGL (apt install libegl1 libgl1-mesa-dri) or OSMesa (apt install libosmesa6) "
    "and set MUJOCO_GL=egl or osmesa"
)

#: The modules in which ``import mujoco`` loads the backend ``MUJOCO_GL`` names (MuJoCo's
#: backend modules, PyOpenGL, glfw): an exception raised inside one of them is the backend's.
_GL_MODULES = (
    "mujoco.rendering.classic.gl_context",
    "mujoco.egl",
    "mujoco.osmesa",
    "mujoco.glfw",
    "mujoco.cgl",
    "OpenGL",
    "glfw",
)

#: How to go without rendering, once `ensure_headless_gl` has set ``MUJOCO_GL`` (else None).
_chosen: str | None = None


def ensure_headless_gl(backend: str = "egl", *, without: str = "leave rendering out") -> bool:
    """Select a headless GL backend if the user has not chosen one.

    Sets ``MUJOCO_GL=backend`` only on Linux, only when ``MUJOCO_GL`` is unset and only while
    ``mujoco`` has not been imported yet (afterwards the variable would be ignored). Returns
    True when it set the variable. ``without`` says how to run without rendering (e.g. "run
    without --video"): `gl_backend_error` offers it where that backend then fails.
    """
    global _chosen
    if sys.platform != "linux" or "MUJOCO_GL" in os.environ or "mujoco" in sys.modules:
        return False
    os.environ["MUJOCO_GL"] = backend
    _chosen = without
    return True


#: MUJOCO_GL's values MuJoCo takes on some system ("<unset>" stands for unset here).
_BACKENDS = (
    *("<unset>", "egl", "osmesa", "glfw", "glx", "cgl", "wgl"),
    *("enable", "enabled", "on", "true", "1", "disable", "disabled", "off", "false", "0"),
)


def _no_gl_error(cause: BaseException | None, *, importing: bool = False) -> GLBackendError:
    """The one line: what to install, how to go without rendering where this process chose the
    backend (else, for a failed ``import mujoco``: unset ``MUJOCO_GL``), and the cause."""
    backend = os.environ.get("MUJOCO_GL") or "<unset>"
    if backend.lower().strip() not in _BACKENDS:  # a typo, not a missing library
        return GLBackendError(
            f"MUJOCO_GL={backend[:40]!r} is not an OpenGL backend MuJoCo knows: set it to "
            "egl, osmesa or glfw (cgl, wgl on macOS, Windows), or unset it"
        )
    message = NO_GL_MESSAGE.format(backend=backend)
    if _chosen:
        message += f", or {_chosen}"
    elif importing:
        message += "; where nothing is rendered, unset MUJOCO_GL"
    if cause is not None:
        first_line = (str(cause).strip().splitlines() or [type(cause).__name__])[0]
        message += f" (cause: {type(cause).__name__}: {first_line})"
    return GLBackendError(message)


def _raised_in_gl_backend(exc: BaseException) -> bool:
    """Whether ``exc``, or an exception it was raised from, passed through `_GL_MODULES`."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        tb = current.__traceback__
        while tb is not None:
            name = str(tb.tb_frame.f_globals.get("__name__", ""))
            if any(name == m or name.startswith(m + ".") for m in _GL_MODULES):
                return True
            tb = tb.tb_next
        current = current.__cause__
    return False


def gl_backend_error(exc: BaseException) -> GLBackendError | None:
    """``exc`` as a one-line `GLBackendError` when MuJoCo's OpenGL backend raised it, else None.

    ``import mujoco`` imports the backend ``MUJOCO_GL`` names even where nothing is rendered,
    and a broken one fails there: PyOpenGL's EGL platform without libEGL raises
    ``AttributeError``, other set-ups ``ImportError``, ``OSError`` or ``RuntimeError``. The
    message says what to install, and how to go without rendering: leave it out where this
    process chose the backend (`ensure_headless_gl`), else unset ``MUJOCO_GL``.
    """
    if isinstance(exc, GLBackendError):
        return exc
    if not _raised_in_gl_backend(exc):
        return None
    return _no_gl_error(exc, importing=True)


def mujoco_module() -> ModuleType:
    """``mujoco``, imported on the first call: for modules that a light path loads, which must
    not choose the GL backend at their import (``MUJOCO_GL`` is read when mujoco is first
    imported; the commands that render set it before they call into such a module)."""
    import mujoco  # lazy: MUJOCO_GL is read when mujoco is first imported: chosen before this

    return mujoco


#: The largest image side rendered: the common limit of OpenGL framebuffers (16384). Above
#: it, making the GL context failed and the error blamed a missing OpenGL backend.
MAX_IMAGE_SIDE = 16384


def create_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """Create a ``mujoco.Renderer`` of ``width`` x ``height`` pixels, headless-friendly.

    The model's offscreen framebuffer is enlarged when the image is larger than it (MuJoCo
    refuses otherwise); the original size is restored once the GL context exists, so the
    model is left as it was. Raises a one-line `GLBackendError` (a ``RuntimeError``) when no
    OpenGL backend works.
    """
    mujoco = mujoco_module()
    whole = all(
        isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in (width, height)
    )
    if not whole or width <= 0 or height <= 0:
        raise ValueError(
            f"image size must be positive integers, got width={width!r}, height={height!r}"
        )
    width, height = int(width), int(height)  # a NumPy integer too
    if max(width, height) > MAX_IMAGE_SIDE:  # GL's framebuffer refuses it as "no backend"
        raise ValueError(
            f"image size must be at most {MAX_IMAGE_SIDE} pixels a side, got width={width}, "
            f"height={height}"
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
        if "framebuffer" in str(exc).lower():  # a context was made: the image is too large
            raise ValueError(
                f"an image of {width} x {height} pixels is too large for this OpenGL "
                f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}): "
                "draw a smaller one"
            ) from exc
        raise _no_gl_error(exc) from exc
    finally:
        # The framebuffer is allocated when the context is made; the model can be restored.
        global_vis.offwidth, global_vis.offheight = old_size


def no_display_why() -> str:
    """Why `has_display` says no, for the messages: both variables unset, or the display they
    name does not answer (a stale ``DISPLAY`` left by ``ssh -X`` or tmux: "are unset" misled).

    Returns:
        E.g. ``"DISPLAY and WAYLAND_DISPLAY are unset"`` or ``"DISPLAY=:99 does not answer"``.
    """
    named = [
        f"{key}={os.environ[key]}" for key in ("DISPLAY", "WAYLAND_DISPLAY") if os.environ.get(key)
    ]
    if not named:
        return "DISPLAY and WAYLAND_DISPLAY are unset"
    return f"{' and '.join(named)} {'does' if len(named) == 1 else 'do'} not answer"


def has_display() -> bool:
    """Whether an interactive window can open here: macOS and Windows always; elsewhere a
    ``WAYLAND_DISPLAY`` or ``DISPLAY`` that answers. A variable alone is not trusted: a stale
    ``DISPLAY`` (left by ``ssh -X``, tmux or screen) made rendering try GLFW, print its
    warnings and fail, where EGL would have drawn."""
    if sys.platform in ("darwin", "win32"):
        return True
    return _wayland_answers(os.environ.get("WAYLAND_DISPLAY")) or _x_answers(
        os.environ.get("DISPLAY")
    )


def _wayland_answers(name: str | None) -> bool:
    """The compositor's socket exists (absolute, or in ``XDG_RUNTIME_DIR``)."""
    if not name:
        return False
    path = Path(name) if os.path.isabs(name) else Path(os.environ.get("XDG_RUNTIME_DIR", "/"), name)
    return path.is_socket()


def _x_answers(display: str | None) -> bool:
    """An X server listens at ``display`` (``[host]:N[.S]``): the local socket of display N,
    or, for a host (``localhost:10.0``, as ``ssh -X`` sets it), TCP port 6000 + N."""
    if not display or ":" not in display:
        return False
    host, _, rest = display.rpartition(":")
    number = rest.partition(".")[0]
    if not number.isdigit():
        return False
    if host in ("", "unix") or host.startswith("/"):  # a local socket (a path: XQuartz's form)
        local = Path(host) if host.startswith("/") else Path(f"/tmp/.X11-unix/X{number}")
        return local.is_socket() or (host.startswith("/") and Path(display).is_socket())
    try:
        with socket.create_connection((host, 6000 + int(number)), timeout=0.5):
            return True
    except (OSError, ValueError, OverflowError):
        return False
