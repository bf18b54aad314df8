"""The commands ariel prints for the user to paste: ``.venv/bin/ariel view ...``.

A command printed at the end of a run, in an error message or in a hint must work when pasted
into a fresh shell in the same folder, where the virtual environment is not activated: so it
names the interpreter and the ``ariel`` script of the environment that runs now (relative to
the current folder when they lie below it, ``.venv/bin/ariel``), ``ariel`` only when that is
what the shell would find anyway.

Here, in `ariel.utils`, so that every layer can print such a command: the CLI's run summary
(`ariel.cli`), the run folder's and the recordings' error messages and hints.
"""

from __future__ import annotations

import os
import shlex
import shutil
import signal
import sys
from pathlib import Path

from ariel.utils.interrupts import exit_status

__all__ = [
    "ariel_command",
    "ariel_line",
    "load_run_command",
    "python_command",
    "report_interrupted",
]


def shell_quote(text: str) -> str:
    """``text`` as one word of a shell command line to paste: `shlex.quote`'s, or, where it
    holds a character that is not printable (a line break, ESC), bash's and zsh's ``$'...'``
    with that character escaped (a quoted line break is shown as ``\\n``: pasted, the shell
    would read two characters)."""
    if text.isprintable():
        return shlex.quote(text)
    escaped = ("\\" + c if c in "\\'" else c if c.isprintable() else repr(c)[1:-1] for c in text)
    return "$'" + "".join(escaped) + "'"


def shell_path(path: object) -> str:
    """``path`` for a POSIX shell command line: quoted where it needs it (`shell_quote`), and
    ``./`` before a name that starts with ``-`` (``ariel report -y`` would read it as an
    option) or ``=`` (zsh reads ``=ls`` as the path of the command ``ls``)."""
    text = str(path)
    return shell_quote(f".{os.sep}{text}" if text.startswith(("-", "=")) else text)


def ariel_line(*words: object) -> str:
    """An ``ariel`` command line to paste: `ariel_command` and ``words``, each quoted for a
    POSIX shell where it needs it (``ariel_line("resume", Path("data/runs/it's"))``); a path
    (``os.PathLike``) as `shell_path` writes it."""
    quoted = (shell_path(w) if isinstance(w, os.PathLike) else shell_quote(str(w)) for w in words)
    return " ".join([ariel_command(), *quoted])


def _shown(path: Path) -> str:
    """``path`` relative to the current folder when it lies below it (``.venv/bin/ariel``),
    else absolute; quoted for a POSIX shell."""
    try:
        relative = path.relative_to(Path.cwd())
    except ValueError:
        return shell_quote(str(path))
    text = str(relative)
    return shell_quote(text if os.sep in text else f".{os.sep}{text}")


def _environment_bin() -> Path | None:
    """The scripts folder of the virtual environment this interpreter runs in, if any."""
    if sys.prefix == sys.base_prefix:
        return None
    folder = Path(sys.prefix) / ("Scripts" if os.name == "nt" else "bin")
    return folder if folder.is_dir() else None


def _same_file(a: str | None, b: Path) -> bool:
    try:
        return a is not None and os.path.samefile(a, b)
    except OSError:
        return False


def ariel_command() -> str:
    """How to call ``ariel`` from a fresh shell here: ``ariel`` when the shell finds this
    environment's script without help, else the script's path (``.venv/bin/ariel``), else
    ``PYTHON -m ariel.cli``."""
    folder = _environment_bin()
    script = folder / "ariel" if folder is not None else None
    found = shutil.which("ariel")
    if script is not None and script.is_file():
        on_path = _same_file(found, script) and not _activated()
        return "ariel" if on_path else _shown(script)
    if found is not None:
        return "ariel"
    return f"{python_command()} -m ariel.cli"


def _activated() -> bool:
    """Whether this shell activated the environment (``VIRTUAL_ENV``, from ``activate``): then
    ``ariel`` is on its PATH, but not on a new shell's."""
    active = os.environ.get("VIRTUAL_ENV")
    try:
        return active is not None and os.path.samefile(active, sys.prefix)
    except OSError:
        return False


def python_command() -> str:
    """This interpreter, as a fresh shell here reaches it (``.venv/bin/python``)."""
    executable = sys.executable
    if not executable:
        return "python3"
    return _shown(Path(executable).absolute())


def load_run_command(path: Path | str, *, loader: str = "load_run", what: str = "") -> str:
    """A ``python -c`` line that loads ``path`` and prints ``what`` (an expression of ``r``)."""
    # A Python string literal: repr, not JSON, whose escapes of a character beyond U+FFFF
    # (an emoji) are two surrogates Python cannot encode ("emoji\ud83d\ude00")
    literal = repr(str(path))
    if literal.startswith("'") and '"' not in literal:  # "..." reads best inside the '...'
        literal = f'"{literal[1:-1]}"'  # the shell quotes the code in (no '"'"' escapes)
    code = f"from ariel.recording import {loader}; r = {loader}({literal}); print({what or 'r'})"
    return f"{python_command()} -c {shlex.quote(code)}"


def report_interrupted(exc: KeyboardInterrupt, folder: object, *resume: str) -> int:
    """Say on stderr that a command was interrupted and, where ``folder`` is known, the
    command that continues it (``ariel *resume folder``); returns the exit code to end with.

    Args:
        exc: The interrupt (Ctrl-C, another signal, or a `Stopped`).
        folder: The run or campaign folder to continue; None or "" when nothing was written.
            Where ``exc.finished`` is true (the signal came once the run had finished), no
            resume is suggested: the line says that it had finished.
        *resume: The ``ariel`` words before the folder, e.g. ``"resume"`` or
            ``"campaign", "resume"``.

    Returns:
        The exit code (`ariel.utils.interrupts.exit_status`).
    """
    hint = f"; continue it with: {ariel_line(*resume, Path(str(folder)))}" if folder else ""
    if folder and getattr(exc, "finished", False):  # the signal came as it ended (a resume
        # would be refused)
        hint = f" after it finished: {Path(str(folder))} is complete, nothing to resume"
    code, how = exit_status(exc)
    # After Ctrl-C on a terminal, a new line first: it has echoed ^C on this one (a SIGINT
    # from elsewhere, or stderr in a file, echoed nothing: the line alone).
    echoed = code == 128 + signal.SIGINT and getattr(sys.stderr, "isatty", bool)()
    lead = "\n" if echoed else ""
    print(f"{lead}interrupted{how}{hint}", file=sys.stderr)
    return code
