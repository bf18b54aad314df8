"""A campaign folder: ``campaign.json`` and one normal run folder per condition and seed.

```
<campaign>/
  campaign.json                     conditions, seeds and seeding, each run's path and config,
                                    status
  campaign.rrd                      best-so-far fitness of every run (Rerun)
  runs/condition=<name>/seed=<n>/   a run folder, like any other
  compare/                          what `ariel compare` writes
```

The run paths are hive-style, so pyarrow, DuckDB and polars read every run's tables as one
dataset with ``condition`` and ``seed`` columns; `load_campaign` does it with pandas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from ariel.recording._files import atomic_write_json
from ariel.recording._load import Run, load_run
from ariel.recording._run_folder import NotARunError

__all__ = [
    "CAMPAIGN_FORMAT",
    "CAMPAIGN_JSON",
    "CAMPAIGN_RRD",
    "Campaign",
    "NotACampaignError",
    "fitness_maximise",
    "is_campaign",
    "load_campaign",
    "read_campaign_info",
    "run_path",
    "write_campaign_info",
]

CAMPAIGN_FORMAT = 1
CAMPAIGN_JSON = "campaign.json"
CAMPAIGN_RRD = "campaign.rrd"


class NotACampaignError(NotARunError):
    """A folder that is not a campaign folder (no readable campaign.json)."""


def run_path(condition: str, seed: int) -> str:
    """A run's folder inside its campaign, relative (hive-style: ``key=value`` parts)."""
    return f"runs/condition={condition}/seed={seed}"


def is_campaign(path: str | Path) -> bool:
    return (Path(path) / CAMPAIGN_JSON).is_file()


def read_campaign_info(path: str | Path) -> dict[str, Any]:
    """``campaign.json`` of the campaign in ``path``; `NotACampaignError` if there is none."""
    import json

    file = Path(path) / CAMPAIGN_JSON
    try:
        info = json.loads(file.read_text(encoding="utf-8"))
    except (FileNotFoundError, NotADirectoryError):
        raise NotACampaignError(
            f"{str(path)!r} is not an ariel campaign folder (no {CAMPAIGN_JSON})"
        ) from None
    except (OSError, ValueError) as exc:
        raise NotACampaignError(f"{file}: unreadable {CAMPAIGN_JSON} ({exc})") from None
    if not isinstance(info, dict) or info.get("format") != CAMPAIGN_FORMAT:
        raise NotACampaignError(f"{file}: not a {CAMPAIGN_JSON} of format {CAMPAIGN_FORMAT}")
    return info


def write_campaign_info(path: str | Path, info: dict[str, Any]) -> None:
    atomic_write_json(Path(path) / CAMPAIGN_JSON, {"format": CAMPAIGN_FORMAT, **info})


def fitness_maximise(info: dict[str, Any]) -> bool:
    """Whether a run's fitness is maximised: run.json's ``maximise``, else the fitness
    function named in its config, looked up in the registry."""
    if "maximise" in info:
        return bool(info["maximise"])
    from ariel.plugins import fitness_functions

    name = info.get("config", {}).get("task", {}).get("fitness", "xy_displacement")
    return bool(fitness_functions.get(name).maximise)


@dataclass
class Campaign:
    """A campaign's records: its runs (those with a run.json), and their tables joined, each
    row with the run's ``condition`` and ``seed``.

    Attributes:
        path: the campaign folder.
        info: ``campaign.json``.
        runs: (condition, seed) -> `Run`, in campaign.json's order.
    """

    path: Path
    info: dict[str, Any]
    runs: dict[tuple[str, int], Run] = field(default_factory=dict)

    @property
    def conditions(self) -> list[str]:
        return [c["name"] for c in self.info.get("conditions", [])]

    @property
    def seeds(self) -> list[int]:
        """The seeds as the campaign file gave them (a condition's own: `seeds_of`)."""
        return list(self.info.get("seeds", []))

    @property
    def seeding(self) -> str:
        """``"shared"`` (every condition runs the same seeds: common random numbers) or
        ``"independent"``; a campaign.json from before the key was recorded shared them."""
        return str(self.info.get("seeding", "shared"))

    def seeds_of(self, condition: str) -> list[int]:
        """The seeds of ``condition``'s runs, as campaign.json lists them."""
        return [int(r["seed"]) for r in self.info.get("runs", []) if r["condition"] == condition]

    @cached_property
    def maximise(self) -> bool:
        directions = {fitness_maximise(run.info) for run in self.runs.values()}
        return directions.pop() if len(directions) == 1 else True

    def _joined(self, table: str) -> Any:
        import pandas as pd

        frames = []
        for (condition, seed), run in self.runs.items():
            frame = getattr(run, table).copy()
            # The evaluations' own ``seed`` (each evaluation's, derived from the run's) would
            # clash with the run's: it is kept as ``eval_seed``.
            frame = frame.rename(columns={"seed": "eval_seed"})
            frame.insert(0, "seed", seed)
            frame.insert(0, "condition", condition)
            frames.append(frame)
        if not frames:
            return pd.DataFrame(columns=["condition", "seed"])
        return pd.concat(frames, ignore_index=True)

    @cached_property
    def evaluations(self) -> Any:
        """Every run's evaluations table, with ``condition`` and ``seed`` (the run's) columns;
        each evaluation's own seed is its ``eval_seed`` column here."""
        return self._joined("evaluations")

    @cached_property
    def bodies(self) -> Any:
        """Every run's bodies table, with ``condition`` and ``seed`` columns."""
        return self._joined("bodies")

    @cached_property
    def generations(self) -> Any:
        """Every run's per-generation summary (`Run.generations`), with ``condition`` and
        ``seed`` columns."""
        return self._joined("generations")

    def status(self) -> list[dict[str, Any]]:
        """One row per run of campaign.json: condition, seed, status, generations, best."""
        from ariel.recording._load import STOPPED
        from ariel.recording._lock import lock_is_free

        rows = []
        for entry in self.info.get("runs", []):
            key = (entry["condition"], int(entry["seed"]))
            run = self.runs.get(key)
            info = run.info if run is not None else {}
            status = info.get("status", "not started")
            if status == "running" and lock_is_free(self.path / entry["path"]):
                status = STOPPED
            best = info.get("best_fitness")
            rows.append(
                {
                    "condition": key[0],
                    "seed": key[1],
                    "path": entry["path"],
                    "status": status,
                    "generations_done": int(info.get("generations_done", 0)),
                    "generations": entry.get("config", {}).get("generations"),
                    "evaluations": int(info.get("evaluations_done", 0)),
                    "best_fitness": best if isinstance(best, float) else math.nan,
                }
            )
        return rows


def load_campaign(path: str | Path) -> Campaign:
    """The records of the campaign in ``path`` (a folder made by `ariel campaign run`)."""
    path = Path(path)
    info = read_campaign_info(path)
    campaign = Campaign(path=path, info=info)
    for entry in info.get("runs", []):
        try:
            run = load_run(path / entry["path"])
        except NotARunError:  # not created yet (a campaign killed while it was being made)
            continue
        campaign.runs[(entry["condition"], int(entry["seed"]))] = run
    return campaign
