"""``ariel quickstart [OPTIONS]``: the quick-start tutorial flow, ``experiments/quickstart.py``
of a source checkout, run with every option handed on to the script's own ``main()``.
"""

from __future__ import annotations

import argparse
import runpy
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ariel.cli._common import fail

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_quickstart_command", "cmd_quickstart"]


def add_quickstart_command(sub: SubParsers) -> None:
    """Add ``ariel quickstart`` to the sub-command parsers ``sub``."""
    # Every option (--seed, --duration, --out, ..., --help) is the script's: main() hands them on.
    p = sub.add_parser(
        "quickstart",
        help="run the quick-start tutorial flow (experiments/quickstart.py; its options: "
        "ariel quickstart --help)",
        add_help=False,
    )
    p.set_defaults(func=cmd_quickstart, rest=[])


def cmd_quickstart(args: argparse.Namespace) -> int:
    """Run the script's ``main(args.rest)`` (`ariel.cli.main` puts the script's options in
    ``rest``); its exit status."""
    script = Path(__file__).resolve().parents[2] / "experiments" / "quickstart.py"
    if not script.exists():
        return fail(f"{script} not found (run from a source checkout)")
    script_globals = runpy.run_path(str(script), run_name="ariel_quickstart")  # defines main()
    saved = sys.argv
    sys.argv = ["ariel quickstart", *args.rest]  # the script's usage line names this command
    try:
        return int(script_globals["main"](list(args.rest)) or 0)
    finally:
        sys.argv = saved
