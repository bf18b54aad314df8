"""What the commands of ``ariel`` share: the parser whose usage errors are one line, the exit
code of bad input and the one line that says what is wrong, where run folders go by default,
and choosing an off-screen GL backend before a command that renders imports mujoco.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
from typing import TYPE_CHECKING, NoReturn, TypeAlias

from ariel.errors import ArielError
from ariel.recording.store import RunFolder, holder_gone, terminal_text
from ariel.utils import ensure_headless_gl, has_display

__all__ = [
    "DEFAULT_RUNS",
    "EXIT_USAGE",
    "IntermixedParser",
    "Parser",
    "fail",
    "fail_with",
    "headless_unless_display",
    "path_error",
]

EXIT_USAGE = 2
#: Where `ariel run` puts run folders and `ariel runs` looks by default.
DEFAULT_RUNS = "data/runs"


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the message and where to get help)."""

    def error(self, message: str) -> NoReturn:
        self.exit(
            EXIT_USAGE,
            f"{self.prog}: error: {message}{_dash_path_hint()} (see {self.prog} --help)\n",
        )


def _dash_path_hint() -> str:
    """``; '-x' was read as an option: write ./-x for the folder`` where a word of the command
    line starting with ``-`` names a file or folder here (``ariel verify -x`` said "the
    following arguments are required: RUN_DIR", though the user gave it)."""
    for word in sys.argv[1:]:
        if word.startswith("-") and word not in ("-", "--") and os.path.lexists(word):
            return f"; {word!r} was read as an option: write ./{word} for the file or folder"
    return ""


class IntermixedParser(Parser):
    """Options and positionals in any order: argparse (Python 3.11, 3.12) binds an optional
    positional (``EVAL_ID``) too early, and ``ariel view RUN --web EVAL_ID`` or ``ariel export
    RUN --lineage FILE EVAL_ID DIR`` would fail. A sub-command becomes one by
    ``parser.__class__ = IntermixedParser``."""

    _inner = False

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        if self._inner:  # parse_known_intermixed_args calls back here
            return super().parse_known_args(args, namespace)
        self._inner = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        finally:
            self._inner = False


if TYPE_CHECKING:
    #: The ``ariel`` parser's sub-command parsers, where each command adds its own.
    SubParsers: TypeAlias = argparse._SubParsersAction[Parser]


#: The longest error line shown: a message that echoes its input (a 3,000,000-number array in a
#: TOML file) is cut, with its length.
MAX_ERROR_CHARACTERS = 2000


#: Of a line cut, the characters kept from its end: what is wrong and what to do come last
#: (after a path of 2,000 characters, cutting the end left no reason at all).
KEPT_END = 600


def fail(message: str) -> int:
    """Print ``message`` as the one error line, escaped for the terminal (a name from a folder
    may hold control characters or line breaks) and cut in the middle to
    `MAX_ERROR_CHARACTERS`, its end kept (`KEPT_END`)."""
    line = terminal_text(message)
    if len(line) > MAX_ERROR_CHARACTERS:
        cut = f" ... ({len(line):,} characters in all) ... "
        head = MAX_ERROR_CHARACTERS - KEPT_END - len(cut)
        line = f"{line[:head]}{cut}{line[-KEPT_END:]}"
    print(f"ariel: error: {line}", file=sys.stderr)
    return EXIT_USAGE


def note_if_running(run_dir: str | os.PathLike[str], what: str) -> None:
    """A note on stderr where the run in ``run_dir`` is still running (its lock held): what a
    reader shows of it (``what``: "'best' is the best so far") is not its end. Nothing for a
    folder that is no run: that is the command's own line to say."""
    try:
        info = RunFolder(run_dir).read_info()
        if info.get("status") != "running" or holder_gone(run_dir):
            return
    except (ArielError, OSError, ValueError):
        return
    config = info.get("config")
    total = config.get("generations") if isinstance(config, dict) else None
    done = f"{info.get('generations_done')}/{total}" if isinstance(total, int) else "some"
    print(
        terminal_text(f"note: {run_dir} is still running ({done} generations finished): {what}"),
        file=sys.stderr,
    )


def fail_with(exc: BaseException) -> int:
    return fail(str(exc) or type(exc).__name__)


#: Errors that say a path cannot name a file at all, whatever the folder holds.
_PATH_ERRNOS = {errno.ENAMETOOLONG, errno.ELOOP, errno.EILSEQ}  # EILSEQ: a path not UTF-8


def path_error(exc: OSError) -> str | None:
    """One line for an `OSError` about a path no file system takes (a name over 255 bytes, a
    loop of links), wherever the path came from (an argument, a folder's file); else None."""
    if exc.errno not in _PATH_ERRNOS:
        return None
    name = os.fsdecode(exc.filename) if exc.filename is not None else "a path"
    limit = _name_limit(name) if exc.errno == errno.ENAMETOOLONG else ""
    if len(name) > 80:
        name = f"{name[:60]}...{name[-16:]} ({len(os.fsencode(name))} bytes)"
    said = exc.strerror if exc.errno == errno.EILSEQ else os.strerror(exc.errno)  # ours
    return f"{name!r}: {said}{limit}"


def _name_limit(name: str) -> str:
    """Which limit a name too long broke: one of its parts over 255 bytes, else (every part
    short) the whole path, the current folder's included, over PATH_MAX."""
    parts = os.fsencode(name).split(b"/")
    if name == "a path" or any(len(part) > 255 for part in parts):
        return " (a file or folder name has at most 255 bytes)"
    most = 4096  # Linux's PATH_MAX, the terminating NUL included
    with contextlib.suppress(OSError, ValueError, AttributeError):
        name = os.path.abspath(name)
        most = os.pathconf("/", "PC_PATH_MAX")
    return (
        f" (a whole path has at most {most} bytes; this one, from /, "
        f"{len(os.fsencode(name))}: run from a shallower folder, or choose a shorter --out)"
    )


def headless_unless_display(without: str) -> None:
    """Render off-screen (EGL) where no window can open. Only for commands that render, and
    before mujoco is imported: a command that draws nothing must not load a GL library (EGL
    missing would fail its ``import mujoco``). ``without``: how to run without rendering."""
    if not has_display():
        ensure_headless_gl(without=without)
