"""The ``ariel`` command's entry point (``[project.scripts]``): `ariel.cli.main`, imported here
inside a ``try`` so that a Ctrl-C while the commands load (about a second: the command modules
and what they import) is one line and exit code 130, as at any later moment, not an import
traceback."""

from __future__ import annotations

from collections.abc import Callable

from ariel.utils import report_interrupted  # the interrupt's one line, as every command's

_run: Callable[[], int] | None
try:
    from ariel.cli import main as _run
except KeyboardInterrupt:  # pressed while loading: `main` says so
    _run = None


def main() -> int:
    """Run the command in ``sys.argv`` (`ariel.cli.main`)."""
    if _run is None:
        return report_interrupted(KeyboardInterrupt(), None)
    return _run()
