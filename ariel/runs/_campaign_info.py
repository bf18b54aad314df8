"""campaign.json's content for a new campaign (`run_campaign`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ariel.recording.store import now, run_path

if TYPE_CHECKING:
    from ariel.evolution import ExecutorConfig
    from ariel.runs._campaign import _Run
    from ariel.runs._campaign_file import CampaignSpec

__all__ = ["campaign_info"]


def campaign_info(
    spec: CampaignSpec,
    runs: Sequence[_Run],
    settings: ExecutorConfig,
    campaign_id: str,
    file_name: str,
) -> dict[str, Any]:
    """campaign.json of a new campaign: what resume and the readers need, no absolute path.
    ``spec``: the campaign file's `CampaignSpec`; ``runs``: its runs (``condition``, ``seed``,
    ``run_id``, ``config``); ``settings``: the executor's."""
    return {
        "campaign_id": campaign_id,
        "name": spec.name,
        "description": spec.description,
        "file": file_name,
        "base": spec.base_name,
        "seeds": spec.seeds,
        "seeding": spec.seeding,
        "conditions": [
            {
                "name": c.name,
                "set": c.set,
                "description": c.description,
                "seeds": spec.seeds_of(c.name),
            }
            for c in spec.conditions
        ],
        "runs": [
            {
                "condition": r.condition,
                "seed": r.seed,
                "path": run_path(r.condition, r.seed),
                "run_id": r.run_id,
                "config": r.config.to_plain(),
            }
            for r in runs
        ],
        "executor": {
            "kind": settings.kind,
            "workers": settings.workers,
            "address": settings.address,
        },
        "status": "created",
        "created": now(),
    }
