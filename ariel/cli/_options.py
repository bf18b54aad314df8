"""Options several commands share: where evaluations run, and the live view."""

from __future__ import annotations

import argparse

from ariel.cli._types import port, positive_int

__all__ = [
    "add_executor_options",
    "add_live_options",
    "add_set_option",
    "add_web_viewer_options",
]


def add_set_option(p: argparse.ArgumentParser, help_text: str) -> None:
    """``--set KEY=VALUE``, repeatable: the config overrides, in order (``args.set``)."""
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=help_text)


class _OneAddress(argparse.Action):
    """``--address``, refusing its old name ``--scheduler`` beside it: which of two addresses
    was meant cannot be guessed (argparse would silently take the last)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        first = getattr(namespace, "_address_option", None)
        if first is not None and first != option_string:
            parser.error("--address and --scheduler (its old name) name one setting: give one")
        namespace._address_option = option_string
        setattr(namespace, self.dest, values)


def add_executor_options(p: argparse.ArgumentParser) -> None:
    """``--executor``, ``--workers``, ``--address``, ``--quiet``, and the live view's
    ``--live`` and ``--web`` (the commands that run evolution take both)."""
    p.add_argument(
        "--executor",
        metavar="KIND",
        help="where evaluations run: local, dask, serial, gpu or a registered executor kind "
        "(default: the config's executor.kind)",
    )
    p.add_argument("--workers", type=positive_int, help="worker processes (default: all CPUs)")
    p.add_argument(
        "--address",
        "--scheduler",  # its old name, still accepted
        dest="address",
        action=_OneAddress,
        metavar="ADDRESS",
        help="the address of a running Dask scheduler, e.g. tcp://host:8786 (with --executor "
        "dask; --scheduler is its old name)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    add_live_options(p)


def add_live_options(p: argparse.ArgumentParser) -> None:
    """``--live`` and ``--web`` (`ariel.cli._live.LiveView`)."""
    p.add_argument(
        "--live",
        action="store_true",
        help="watch it live: start `ariel watch` on the folder beside the run (a Rerun viewer "
        "that only reads the folder; the run never waits for it)",
    )
    p.add_argument(
        "--web",
        action="store_true",
        help="the live view in the web viewer, served on 127.0.0.1 (implies --live; its "
        "address and an SSH tunnel line are printed)",
    )


def add_web_viewer_options(p: argparse.ArgumentParser, grpc_help: str) -> None:
    """``--web``, ``--port`` and ``--grpc-port`` of the commands that serve Rerun's web viewer
    (`ariel view`, `ariel watch`); ``grpc_help`` says what the gRPC server carries."""
    p.add_argument(
        "--web",
        action="store_true",
        help="serve the web viewer on 127.0.0.1 (no browser is opened; prints the SSH tunnel)",
    )
    p.add_argument(
        "--port", type=port, metavar="PORT", help="web viewer port (default 9090; 0: any free)"
    )
    p.add_argument(
        "--grpc-port",
        type=port,
        metavar="PORT",
        help=f"port of {grpc_help} (default 9876; 0: any free)",
    )
