"""The ``ariel`` command.

Sub-commands grow with the project; each imports what it needs only when it runs, so
``ariel --help`` stays instant.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ariel import __version__


def _cmd_plugins(args: argparse.Namespace) -> int:
    from ariel.plugins import REGISTRIES

    for kind, registry in REGISTRIES.items():
        print(f"{kind}: {', '.join(registry.names())}")
    return 0


def _cmd_quickstart(args: argparse.Namespace) -> int:
    import runpy
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "experiments" / "quickstart.py"
    if not script.exists():
        print(f"error: {script} not found (run from a source checkout)", file=sys.stderr)
        return 2
    sys.argv = [str(script), *args.rest]
    runpy.run_path(str(script), run_name="__main__")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ariel", description="ARIEL workbench: evolve modular robots in MuJoCo."
    )
    parser.add_argument("--version", action="version", version=f"ariel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    p = sub.add_parser("plugins", help="list the registered plugins of every kind")
    p.set_defaults(func=_cmd_plugins)
    p = sub.add_parser("quickstart", help="run the quick-start tutorial flow as a script")
    p.add_argument("rest", nargs=argparse.REMAINDER, help="arguments for the script")
    p.set_defaults(func=_cmd_quickstart)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    return int(args.func(args))


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
