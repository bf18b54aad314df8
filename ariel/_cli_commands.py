"""The commands the CLI prints for the user to paste (``.venv/bin/ariel view ...``): the
helpers live in `ariel.utils._commands`, a low layer, so that the recording and run code can
print pasteable hints too (their error messages and notes)."""

from __future__ import annotations

from ariel.utils._commands import ariel_command, ariel_line, load_run_command, python_command

__all__ = ["ariel_command", "ariel_line", "load_run_command", "python_command"]
