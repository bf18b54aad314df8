"""What the commands of ``ariel`` share: the parser whose usage errors are one line, the exit
code of bad input and the one line that says what is wrong, where run folders go by default,
and choosing an off-screen GL backend before a command that renders imports mujoco.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, NoReturn, TypeAlias

from ariel.utils import ensure_headless_gl, has_display

__all__ = [
    "DEFAULT_RUNS",
    "EXIT_USAGE",
    "Parser",
    "fail",
    "fail_with",
    "headless_unless_display",
]

EXIT_USAGE = 2
#: Where `ariel run` puts run folders and `ariel runs` looks by default.
DEFAULT_RUNS = "data/runs"


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the message and where to get help)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


if TYPE_CHECKING:
    #: The ``ariel`` parser's sub-command parsers, where each command adds its own.
    SubParsers: TypeAlias = argparse._SubParsersAction[Parser]


def fail(message: str) -> int:
    print(f"ariel: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def fail_with(exc: BaseException) -> int:
    return fail(str(exc) or type(exc).__name__)


def headless_unless_display(without: str) -> None:
    """Render off-screen (EGL) where no window can open. Only for commands that render, and
    before mujoco is imported: a command that draws nothing must not load a GL library (EGL
    missing would fail its ``import mujoco``). ``without``: how to run without rendering."""
    if not has_display():
        ensure_headless_gl(without=without)
