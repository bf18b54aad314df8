"""``ariel plugins``: the registered plugins of every kind (`ariel.plugins`); ``--check`` runs
the plugin checkers on each of them (exit 1 when one fails).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_plugins_command"]


def add_plugins_command(sub: SubParsers) -> None:
    """Add ``ariel plugins`` to the sub-command parsers ``sub``."""
    p = sub.add_parser("plugins", help="list the registered plugins of every kind")
    p.add_argument(
        "--check", action="store_true", help="run the plugin checkers on every registered plugin"
    )
    p.set_defaults(func=_cmd_plugins)


def _cmd_plugins(args: argparse.Namespace) -> int:
    # lazy: start-up of every `ariel` command (~20 ms; this module is imported for its parser)
    from ariel import evaluation, plugins

    if not args.check:
        for kind, registry in plugins.REGISTRIES.items():
            print(f"{kind}: {', '.join(registry.names())}")
        print(f"executor: {evaluation.known_kinds()}")  # --executor KIND, [executor] kind
        return 0
    failures = 0
    for kind, name, problem in plugins.check_all():
        print(f"{'FAIL' if problem else 'ok  '} {kind} {name}{': ' + problem if problem else ''}")
        failures += problem is not None
    print(f"{failures} plugin(s) failed their checks" if failures else "all plugins pass")
    return 1 if failures else 0
