"""Argument types the `ariel` command's parsers share (argparse's one-line errors)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

__all__ = ["integer_at_least", "positive_int"]


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
