"""Argument types the `ariel` command's parsers share (argparse's one-line errors)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

__all__ = ["integer_at_least", "poll_seconds", "port", "positive_int"]


def integer_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: a whole number >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be an integer >= {minimum}, not {text!r}"
            ) from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, not {value}")
        return value

    return parse


#: ``--workers``, ``--best``, ``--at-evaluations``: a whole number >= 1.
positive_int = integer_at_least(1)


def port(text: str) -> int:
    """A TCP port for argparse: 0..65535 (0: any free one)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a port 0..65535, not {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port 0..65535, not {value}")
    return value


def poll_seconds(text: str) -> float:
    """``--poll``: seconds between looks at a folder, 0.05 to 3600."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, not {text!r}") from None
    if not 0.05 <= value <= 3600:
        raise argparse.ArgumentTypeError(f"must be 0.05 to 3600 seconds, not {text}")
    return value
