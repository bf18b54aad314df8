"""``ariel watch DIR``: a live view of a running (or finished) run or campaign in the Rerun
viewer (`ariel.recording.watch`), read from its folder alone.

Like every command, it reaches `ariel.recording.viewer` through its lazy face (`ariel.cli`).
Bad input (a folder that is not a run, a busy port, no display for the native viewer) is one
line and exit code 2, through `ariel.cli.main`.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from typing import TYPE_CHECKING

from ariel.cli._common import EXIT_USAGE
from ariel.cli._live import WATCHER_NICENESS
from ariel.cli._options import add_web_viewer_options
from ariel.cli._types import poll_seconds
from ariel.errors import ViewError
from ariel.recording import viewer
from ariel.recording.store import terminal_text
from ariel.utils import ariel_line, has_display, no_display_why

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers
    from ariel.recording.viewer import Watcher

__all__ = ["add_watch_command"]


def add_watch_command(sub: SubParsers) -> None:
    """Add ``ariel watch`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "watch",
        help="a live view of a running (or finished) run or campaign in the Rerun viewer "
        "(--web: serve it for an SSH tunnel)",
        description="Follow a run or campaign folder while it runs, reading it only (from "
        "another terminal, or another machine over a shared file system): fitness, diversity "
        "and morphology per generation, progress, the best body so far walking in 3D, the "
        "lineage, a MAP-Elites archive. Every server binds 127.0.0.1 only.",
    )
    p.add_argument("folder", metavar="DIR", help="a run or campaign folder")
    add_web_viewer_options(p, "the viewer's gRPC server the live data is streamed to")
    p.add_argument("--save", metavar="FILE.rrd", help="also write the live recording to FILE.rrd")
    p.add_argument(
        "--no-viewer", action="store_true", help="start no viewer (with --save: a file only)"
    )
    p.add_argument(
        "--poll",
        type=poll_seconds,
        default=0.5,
        metavar="S",
        help="seconds between looks at the folder (default 0.5)",
    )
    p.add_argument(
        "--until-finished",
        action="store_true",
        help="exit once the run or campaign has ended and all of it is shown (else: until "
        "Ctrl-C, or the native viewer's window is closed)",
    )
    p.set_defaults(func=_cmd_watch)


def _web_line(args: argparse.Namespace) -> str:
    """This command with ``--web``, the user's other options kept (the API's hint, which
    knows none of them, dropped ``--poll``, ``--save`` and ``--until-finished``)."""
    words: list[object] = ["watch", args.folder, "--web"]
    for option, value in (
        ("--port", args.port),
        ("--grpc-port", args.grpc_port),
        ("--save", args.save),
        ("--poll", None if args.poll == 0.5 else f"{args.poll:g}"),
    ):
        if value is not None:
            words += [option, value]
    return ariel_line(*words, *(["--until-finished"] if args.until_finished else []))


def _announce(watcher: Watcher, args: argparse.Namespace) -> None:
    folder = terminal_text(watcher.source.path)  # a folder's name may hold control characters
    saving = terminal_text(f", saving it to {args.save}") if args.save else ""
    if "web" in watcher.urls:
        print(
            f"Rerun web viewer: live view of {folder}{saving}\n"
            f"  open  {watcher.urls['web']}\n"
            "From another computer (this one being a cluster node), tunnel both ports first:\n"
            f"  {viewer.tunnel_command(watcher.ports)}\n"
            "  (add -J user@login-node when this node is reached through a login node)\n"
            f"The server listens on {viewer.LOCALHOST} only. Ctrl-C stops it.",
            flush=True,
        )
    elif watcher.urls:
        print(
            f"Rerun viewer: live view of {folder}{saving} (Ctrl-C, or closing its window, "
            "stops it)",
            flush=True,
        )
    else:
        print(f"watching {folder}{saving} (Ctrl-C stops it)", flush=True)


def _cmd_watch(args: argparse.Namespace) -> int:
    if args.no_viewer and (args.web or args.port is not None or args.grpc_port is not None):
        print("ariel: error: --no-viewer starts no viewer: no --web or ports", file=sys.stderr)
        return EXIT_USAGE
    kind = "none" if args.no_viewer else "web" if args.web else "native"
    with viewer.stop_on_signals():
        try:
            try:
                watcher = viewer.watch(
                    args.folder,
                    viewer=kind,
                    port=args.port,
                    grpc_port=args.grpc_port,
                    save=args.save,
                    poll_s=args.poll,
                )
            except ViewError as exc:  # the API's hint knows none of the command's options
                if kind != "native" or has_display() or not str(exc).startswith("no display"):
                    raise
                raise ViewError(
                    f"no display to open the Rerun viewer on ({no_display_why()}); serve it to "
                    f"a browser instead: {_web_line(args)}"
                ) from None
            if hasattr(os, "nice"):  # an onlooker: on a busy machine the run watched goes first
                with contextlib.suppress(OSError):
                    os.nice(WATCHER_NICENESS)
            with watcher:
                _announce(watcher, args)
                why = watcher.follow(until_finished=args.until_finished)
            ended = (
                "it has ended and all of it is shown" if why == "finished" else "the viewer closed"
            )
            print(terminal_text(f"stopped watching {watcher.source.path}: {ended}"), flush=True)
            return 0
        except KeyboardInterrupt:
            print("\nstopped watching", file=sys.stderr)
            return 0
        except viewer.ViewerStopped as stop:
            return 128 + stop.signum
