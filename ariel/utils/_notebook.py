"""Whether this process is a Jupyter (IPython) kernel: progress output and `ariel watch`'s
viewer choose their form by it."""

from __future__ import annotations

import sys

__all__ = ["in_notebook_kernel"]


def in_notebook_kernel() -> bool:
    """An IPython shell with a kernel runs this (Jupyter, VS Code, Colab); IPython is never
    imported here, only looked up when the process already has it."""
    get_ipython = getattr(sys.modules.get("IPython"), "get_ipython", None)
    try:
        shell = get_ipython() if callable(get_ipython) else None
    except Exception:  # a half-imported or odd IPython: not a notebook
        return False
    return getattr(shell, "kernel", None) is not None
