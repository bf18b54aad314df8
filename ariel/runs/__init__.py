"""Runs end to end: an experiment config -> its plugins -> a run folder -> the evolution driver
on an executor (`run_experiment`, `resume_experiment`); campaigns, conditions x seeds on one
executor (`run_campaign`, `resume_campaign`, `campaign_status`).

The layer above `ariel.recording` (the run folder, its writer) and `ariel.evolution` (the
driver, the optimizers, the scheduler), which know nothing of each other's insides.
Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

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

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.runs._campaign_file import (
        load_campaign_file as load_campaign_file,
    )
    from ariel.runs._campaign_folder import (
        new_campaign_id as new_campaign_id,
    )
    from ariel.runs._campaign_plan import (
        campaign_plan as campaign_plan,
        plan_text as plan_text,
    )
    from ariel.runs._experiment import (
        load_config as load_config,
        new_run_id as new_run_id,
    )
    from ariel.runs._session import (
        resumable as resumable,
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


# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "campaign_plan": "ariel.runs._campaign_plan",
    "load_campaign_file": "ariel.runs._campaign_file",
    "load_config": "ariel.runs._experiment",
    "new_campaign_id": "ariel.runs._campaign_folder",
    "new_run_id": "ariel.runs._experiment",
    "plan_text": "ariel.runs._campaign_plan",
    "resumable": "ariel.runs._session",
}

__getattr__, __dir__ = lazy_face(__name__, _LAZY, _INTERNAL)
