"""Runs end to end: an experiment config -> its plugins -> a run folder -> the evolution driver
on an executor (`run_experiment`, `resume_experiment`); campaigns, conditions x seeds on one
executor (`run_campaign`, `resume_campaign`, `campaign_status`).

The layer above `ariel.recording` (the run folder, its writer) and `ariel.evolution` (the
driver, the optimizers, the scheduler), which know nothing of each other's insides.
Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.runs._campaign import (
        CampaignResult as CampaignResult,
        campaign_status as campaign_status,
        resume_campaign as resume_campaign,
        run_campaign as run_campaign,
    )
    from ariel.runs._experiment import (
        RunResult as RunResult,
        resume_experiment as resume_experiment,
        run_experiment as run_experiment,
    )

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "CampaignResult": "ariel.runs._campaign",
    "campaign_status": "ariel.runs._campaign",
    "resume_campaign": "ariel.runs._campaign",
    "run_campaign": "ariel.runs._campaign",
    "RunResult": "ariel.runs._experiment",
    "resume_experiment": "ariel.runs._experiment",
    "run_experiment": "ariel.runs._experiment",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'ariel.runs' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
