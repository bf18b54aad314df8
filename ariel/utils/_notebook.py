"""Whether this process is a Jupyter (IPython) kernel, and whether a stream is a terminal:
progress output and `ariel watch`'s viewer choose their form by them."""

from __future__ import annotations

import sys

__all__ = ["in_notebook_kernel", "is_terminal"]


def in_notebook_kernel() -> bool:
    """An IPython shell with a kernel runs this (Jupyter, VS Code, Colab); IPython is never
    imported here, only looked up when the process already has it."""
    get_ipython = getattr(sys.modules.get("IPython"), "get_ipython", None)
    try:
        shell = get_ipython() if callable(get_ipython) else None
    except Exception:  # a half-imported or odd IPython: not a notebook
        return False
    return getattr(shell, "kernel", None) is not None


def is_terminal(stream: object) -> bool:
    """Whether ``stream`` is a terminal: False for None (a script started with stdout closed,
    ``>&-``), a closed stream, or a stand-in without ``isatty``."""
    try:
        return bool(stream.isatty())  # type: ignore[attr-defined]
    except (AttributeError, ValueError, OSError):
        return False
