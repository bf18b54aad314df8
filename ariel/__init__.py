"""ARIEL workbench: evolve modular robots (body and brain) in MuJoCo.

Importing this package does nothing else: no folders, no logging set-up, no RNG seeding, and no
heavy imports (torch, matplotlib and rerun load only where they are used). `run_experiment`
loads the co-evolution loop on first use; `console` (upstream ARIEL's shared rich `Console`,
``from ariel import console``) is made on first use.
"""

import random
from typing import TYPE_CHECKING, Any

from ariel._version import __version__

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from rich.console import Console

    from ariel.runs import run_experiment as run_experiment

    console: Console
    """Upstream ARIEL's shared rich console (``from ariel import console``), made on first use."""

__all__ = ["__version__", "console", "run_experiment"]


def __getattr__(name: str) -> Any:
    if name == "run_experiment":
        # lazy: `import ariel` stays light (ariel.runs loads the evolution driver, numpy, pydantic)
        from ariel.runs import run_experiment

        return run_experiment
    if name == "console":
        state = random.getstate()  # rich draws from `random` as it loads: the caller's draws
        try:  # stay theirs (`ariel.utils.lazy.keeping_random_state`, not imported by `ariel`)
            from rich.console import Console  # lazy: `import ariel` stays light (rich: ~0.1 s)
        finally:
            random.setstate(state)

        console = globals()["console"] = Console()  # one shared console, as upstream's
        return console
    raise AttributeError(f"module 'ariel' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The loaded names and the lazy ones (`run_experiment`, `console`): tab completion."""
    return sorted({*globals(), *__all__})
