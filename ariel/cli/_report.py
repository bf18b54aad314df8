"""``ariel report RUN_DIR``: a run's per-generation table and figures (`ariel.recording.analysis`),
with a rendered image of the best body unless ``--no-render``.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ariel.cli._common import headless_unless_display
from ariel.recording import analysis

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_report_command"]


def add_report_command(sub: SubParsers) -> None:
    """Add ``ariel report`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "report", help="per-generation table and figures of a run (PNGs in RUN_DIR/report/)"
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument(
        "--no-render", action="store_true", help="leave out the rendered image of the best body"
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="write the figures into DIR instead of RUN_DIR/report (e.g. for a read-only run): "
        "a new or empty folder, or an earlier report's, outside every run and campaign folder",
    )
    p.set_defaults(func=_cmd_report)


def _cmd_report(args: argparse.Namespace) -> int:
    if not args.no_render:  # loading the run imports mujoco (body descriptors) before it renders
        headless_unless_display("run with --no-render")
    report = analysis.make_report(
        args.run_dir, render=not args.no_render, announce=_say, out=args.out
    )
    analysis.print_report(report, written=False)
    return 0


def _say(line: str) -> None:
    """As it happens: a report of many generations takes a while."""
    print(line, flush=True)
