"""MuJoCo Warp, imported on demand, and the device the evaluator runs on.

`warp_modules` imports `warp` and `mujoco_warp` (quietly: Warp's initialisation notes stay off
stderr) or raises `WarpUnavailableError` naming the extra to install; `check_device` checks a
device name and that a CUDA device is there. Nothing here imports Warp before it is called.
Re-exported by `ariel.evaluation._warp`.
"""

from __future__ import annotations

import functools
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

from ariel.errors import WarpUnavailableError
from ariel.utils import python_command, shell_path

__all__ = [
    "BACKEND",
    "DEVICES",
    "INSTALL_HINT",
    "check_device",
    "cuda_available",
    "install_hint",
    "warp_modules",
]

BACKEND = "mujoco-warp"
#: Devices the evaluator runs on: "cuda" (an NVIDIA GPU), "cpu" (Warp's CPU device: slow,
#: for tests and machines without a GPU).
DEVICES: tuple[str, ...] = ("cuda", "cpu")
INSTALL_HINT = "pip install 'ariel[gpu]'"


def install_hint() -> str:
    """How to install the GPU extra, as pasted into a fresh shell here: ``make gpu`` in the
    repository this ariel runs from (an editable checkout), else this interpreter's pip (a
    bare ``pip`` is the system's, not the virtual environment's)."""
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "Makefile").is_file() and (checkout / "pyproject.toml").is_file():
        here = Path.cwd().resolve()
        return "make gpu" if checkout == here else f"make -C {shell_path(checkout)} gpu"
    return f"{python_command()} -m {INSTALL_HINT}"


def warp_modules() -> tuple[Any, Any]:
    """``(warp, mujoco_warp)``, imported now; `WarpUnavailableError` naming the extra if not.

    Typed `Any`, as everything of Warp's here: it is imported on first use only."""
    try:
        import mujoco_warp  # lazy: heavy optional library (the gpu extra)
        import warp  # lazy: heavy optional library (the gpu extra)
    except ImportError as exc:
        raise WarpUnavailableError(
            f"the gpu backend needs MuJoCo Warp ({exc.name} is not installed): {install_hint()}"
        ) from None
    if warp.config.log_level < warp.LOG_WARNING:
        # Warp logs one line per kernel module it loads (hundreds on a first compile).
        warp.config.log_level = warp.LOG_WARNING
    _init_quietly(warp)
    return warp, mujoco_warp


# What Warp's native library prints on a machine without an NVIDIA driver, at initialisation;
# the device check says it in its own words (one line), and the CPU device works without it.
_NO_DRIVER_NOTE = b"Could not find or load the NVIDIA CUDA driver"


@functools.cache
def _init_quietly(wp: Any) -> None:
    """``wp.init()`` with the native no-driver note dropped from stderr (the rest kept)."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            captured.seek(0)
            kept = [line for line in captured.readlines() if _NO_DRIVER_NOTE not in line]
    if kept:
        sys.stderr.write(b"".join(kept).decode(errors="replace"))


def cuda_available() -> bool:
    """Whether Warp sees a CUDA device here (imports Warp)."""
    wp, _ = warp_modules()
    return bool(wp.is_cuda_available())


def check_device(device: str) -> str:
    """``device`` if the evaluator can run there; `WarpUnavailableError` (one line) if not."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {', '.join(DEVICES)}, not {device!r}")
    if device == "cuda" and not cuda_available():
        raise WarpUnavailableError(
            "the gpu executor found no CUDA device (no NVIDIA GPU or driver visible to Warp): "
            "run on the CPU engine instead (--executor local), or MuJoCo Warp on the CPU (slow; "
            'for tests: executor.device = "cpu" in the config, --set executor.device=cpu for '
            "ariel run)"
        )
    return device
