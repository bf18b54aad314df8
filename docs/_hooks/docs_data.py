"""The data the site's notebooks show: one small co-evolution run and one small campaign,
made by the code itself at build time (under .cache/docs/, reused while they are finished).

Small so that `make docs` stays within minutes on 2 cores; real, so that every figure in the
tutorials is one the code draws today.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from dataclasses import dataclass
from pathlib import Path

#: The default experiment, shortened: 4 generations of 6 + 6 bodies, 4 s gaits.
RUN_OVERRIDES = [
    "generations=4",
    "body.population=6",
    "body.offspring=6",
    "brain.iterations=4",
    "task.duration=4.0",
    "record.rerun=false",
]

#: The tutorials' campaign file (the campaign tutorial runs it too).
CAMPAIGN_FILE = Path(__file__).resolve().parents[1] / "tutorials" / "demo_campaign.toml"


@dataclass(frozen=True)
class DocsData:
    """Where the site's run and campaign are."""

    run: Path
    campaign: Path


def _finished(folder: Path, info: str) -> bool:
    try:
        return json.loads((folder / info).read_text(encoding="utf-8"))["status"] == "finished"
    except (OSError, ValueError, KeyError):
        return False


def prepare(cache: Path) -> DocsData:
    """Make the run and the campaign under ``cache`` unless they are there and finished.

    Their folders are named by a hash of what makes them (the campaign file, the run's
    overrides), so a change makes new ones; `make clean` removes the old.
    """
    from ariel.runs import run_campaign, run_experiment

    cache.mkdir(parents=True, exist_ok=True)
    # Named by what made them, so that a changed file or setting makes them afresh.
    key = hashlib.sha256((CAMPAIGN_FILE.read_text(encoding="utf-8") + repr(RUN_OVERRIDES)).encode())
    data = DocsData(
        cache / f"run-{key.hexdigest()[:10]}", cache / f"campaign-{key.hexdigest()[:10]}"
    )
    if not _finished(data.run, "run.json"):
        print(f"docs: making the site's example run in {data.run}", flush=True)
        run_experiment(None, out=data.run, overwrite=True, overrides=RUN_OVERRIDES)
    if not _finished(data.campaign, "campaign.json"):
        print(f"docs: making the site's example campaign in {data.campaign}", flush=True)
        shutil.rmtree(data.campaign, ignore_errors=True)  # ours alone, under the cache
        run_campaign(CAMPAIGN_FILE, out=data.campaign, progress=False)
    return data
