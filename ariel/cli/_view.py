"""``ariel view RUN_DIR [EVAL_ID]``: a run's Rerun recordings in the viewer, with its blueprint
(`ariel.recording.viewer`); ``--web`` serves the web viewer for an SSH tunnel, ``--screenshot``
draws it in a headless Chromium and saves a PNG.
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from ariel.cli._common import IntermixedParser, note_if_running
from ariel.cli._options import add_web_viewer_options
from ariel.cli._types import integer_at_least, positive_int
from ariel.recording import viewer
from ariel.recording.store import output_file_problem
from ariel.utils import path_argument

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_view_command"]


def _png_path(text: str) -> Path:
    path = path_argument("--screenshot", text)  # "~/shot.png": checked here, before main's turn
    if path.suffix.lower() != ".png":
        raise argparse.ArgumentTypeError(f"must be a .png file, not {text!r}")
    if not path.parent.is_dir():
        raise argparse.ArgumentTypeError(f"folder {str(path.parent)!r} does not exist")
    if not os.access(path.parent, os.W_OK):  # a read-only file system: said before drawing
        raise argparse.ArgumentTypeError(f"folder {str(path.parent)!r} cannot be written")
    problem = output_file_problem(path)  # a FIFO, a folder, a run's report/fitness.png
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    return path


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)x(\d+)", text)
    width, height = (int(g) for g in match.groups()) if match else (0, 0)
    if not (320 <= width <= 7680 and 240 <= height <= 4320):
        raise argparse.ArgumentTypeError(
            f"must be WIDTHxHEIGHT, 320x240 to 7680x4320 pixels, not {text!r}"
        )
    return width, height


def add_view_command(sub: SubParsers) -> None:
    """Add ``ariel view`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "view",
        help="open a run's Rerun recordings in the viewer (--web: serve it for an SSH tunnel)",
        description="Open Rerun recordings of a run with its blueprint: by default run.rrd and "
        "the best evaluation's recording.",
    )
    p.__class__ = IntermixedParser  # EVAL_ID may follow the options
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument("eval_id", nargs="?", metavar="EVAL_ID", help="one evaluation")
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--best",
        type=positive_int,
        metavar="K",
        help="the K best evaluations of the run (default, without EVAL_ID or --generation: "
        "the best one)",
    )
    which.add_argument(
        "--generation",
        type=integer_at_least(0),
        metavar="G",
        help="every evaluation of generation G (its evaluations.rrd)",
    )
    add_web_viewer_options(p, "the gRPC proxy the web viewer reads the recordings from")
    p.add_argument(
        "--screenshot",
        type=_png_path,
        metavar="FILE.png",
        help="instead of serving: draw the web viewer in a headless Chromium, save it, stop",
    )
    p.add_argument(
        "--size",
        type=_size,
        default=(1600, 900),
        metavar="WxH",
        help="screenshot size in pixels (default 1600x900)",
    )
    p.set_defaults(func=_cmd_view)


def _cmd_view(args: argparse.Namespace) -> int:
    if args.screenshot is not None:
        note_if_running(args.run_dir, "the picture shows the generations finished so far")
    return viewer.view(
        args.run_dir,
        best=args.best,
        generation=args.generation,
        eval_id=args.eval_id,
        web=args.web,
        port=args.port,
        grpc_port=args.grpc_port,
        screenshot=args.screenshot,
        size=args.size,
    )
