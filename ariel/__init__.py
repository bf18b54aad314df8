"""ARIEL workbench: evolve modular robots (body and brain) in MuJoCo.

Importing this package does nothing else: no folders, no logging set-up, no RNG seeding, and no
heavy imports (torch, matplotlib and rerun load only where they are used). `run_experiment`
loads the co-evolution loop on first use; `console` (upstream ARIEL's shared rich `Console`,
``from ariel import console``) is made on first use.
"""

from typing import Any

from ariel._version import __version__

__all__ = ["__version__", "console", "run_experiment"]


def __getattr__(name: str) -> Any:
    if name == "run_experiment":
        from ariel.runs import run_experiment

        return run_experiment
    if name == "console":
        from rich.console import Console

        console = globals()["console"] = Console()  # one shared console, as upstream's
        return console
    raise AttributeError(f"module 'ariel' has no attribute {name!r}")
