"""MuJoCo's own warnings while ariel simulates: neither a file nor the console.

MuJoCo writes a warning (an unstable simulation: "Nan, Inf or huge value in QACC") to
``MUJOCO_LOG.TXT`` in the current folder, and, with that off, to the console: a run left the
file in whatever folder it was started from, and a worker's console lines would cut through
the progress display. The evaluation records the same thing in its result (status
``unstable``), so while ariel builds and steps bodies MuJoCo logs nowhere; the user's setting
is back when the last thread leaves (`SharedSetting`).
"""

from __future__ import annotations

import mujoco

from ariel.utils import SharedSetting

__all__ = ["MUJOCO_LOG_OFF"]


def _get() -> tuple[bool, bool]:
    config = mujoco.MjLogConfig.get()
    return bool(config.logto_file), bool(config.logto_console)


def _put(value: tuple[bool, bool]) -> None:
    config = mujoco.MjLogConfig.get()
    config.logto_file, config.logto_console = value
    config.set()


#: ``with MUJOCO_LOG_OFF.held():`` MuJoCo writes no log file and prints no warning.
MUJOCO_LOG_OFF = SharedSetting(_get, _put, (False, False))
