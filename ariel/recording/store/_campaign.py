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
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TypeGuard

import pandas as pd

from ariel.plugins import fitness_functions
from ariel.recording.store._escape import short_ascii
from ariel.recording.store._files import atomic_write_json, format_problem
from ariel.recording.store._ids import CAMPAIGN_ID, RUN_ID, RUN_ID_RULE
from ariel.recording.store._lineage import campaign_lineages
from ariel.recording.store._list_runs import STOPPED
from ariel.recording.store._load import Run, load_run
from ariel.recording.store._lock import CAMPAIGN_JSON, holder_gone
from ariel.recording.store._run_folder import JsonObject, NotARunError, json_file
from ariel.utils import path_argument

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
CAMPAIGN_RRD = "campaign.rrd"

#: `Campaign.status` of a run whose folder holds a run.json that does not load (damaged).
DAMAGED = "damaged"


class NotACampaignError(NotARunError):
    """A folder that is not a campaign folder (no readable campaign.json)."""


def run_path(condition: str, seed: int) -> str:
    """A run's folder inside its campaign, relative (hive-style: ``key=value`` parts)."""
    return f"runs/condition={condition}/seed={seed}"


def is_campaign(path: str | Path) -> bool:
    """Whether ``path`` holds a campaign.json (whatever it is: `read_campaign_info` says
    in one line when it is not one, a FIFO or a folder included)."""
    return os.path.lexists(Path(path) / CAMPAIGN_JSON)


def read_campaign_info(path: str | Path) -> JsonObject:
    """``campaign.json`` of the campaign in ``path``; `NotACampaignError` if there is none, or
    if it is not what a campaign writes: a run elsewhere than at its own
    ``runs/condition=<name>/seed=<n>`` (or through a symbolic link), a seed that is not an
    integer, a condition name that is not one or not among its conditions, a run without a
    config, an id that is not one (`ariel.recording.store._ids`): one line naming the entry."""
    file = Path(path) / CAMPAIGN_JSON
    try:
        info = json_file(file)
    except (FileNotFoundError, NotADirectoryError):
        raise NotACampaignError(
            f"{str(path)!r} is not an ariel campaign folder (no {CAMPAIGN_JSON})"
        ) from None
    except (OSError, ValueError) as exc:
        raise NotACampaignError(f"{file}: unreadable {CAMPAIGN_JSON} ({exc})") from None
    problem = format_problem(CAMPAIGN_JSON, info, CAMPAIGN_FORMAT)
    if problem is not None or not isinstance(info, dict):
        raise NotACampaignError(f"{file}: {problem}")
    campaign_id = info.get("campaign_id")
    if not isinstance(campaign_id, str) or not CAMPAIGN_ID.fullmatch(campaign_id):
        shown = short_ascii(campaign_id)
        raise NotACampaignError(
            f"{file}: its campaign_id {shown} is not a campaign id ({RUN_ID_RULE}; at most 255 "
            "characters)"
        )
    _check_conditions(file, info)
    if info.get("seeding", "shared") not in _SEEDINGS:
        shown = short_ascii(info.get("seeding"))
        raise NotACampaignError(f"{file}: seeding {shown} is not one of {', '.join(_SEEDINGS)}")
    _check_runs(Path(path), file, info)
    return info


#: How a campaign's conditions take their seeds (`Campaign.seeding`).
_SEEDINGS = ("shared", "independent")

# A condition's name, as the campaign file allows it: one path component, never "." or "..".
_CONDITION = re.compile(r"[A-Za-z0-9_.-]+")
#: The longest condition name: its folder ``condition=<name>`` is one file name, and a file
#: system allows at most 255 bytes (ENAMETOOLONG).
MAX_CONDITION_NAME = 255 - len("condition=")
_CONDITION_RULE = f"letters, digits, _ . -; at most {MAX_CONDITION_NAME} characters"


def _is_seed(value: object) -> TypeGuard[int]:
    """A seed as the experiment's ``seed`` allows it: an integer (not a bool, a float or a
    string), 0 <= seed < 2**63."""
    return type(value) is int and 0 <= value < 2**63


def _is_condition(value: object) -> TypeGuard[str]:
    if not isinstance(value, str):
        return False
    return len(value) <= MAX_CONDITION_NAME and _CONDITION.fullmatch(value) is not None


def _check_conditions(file: Path, info: Mapping[str, object]) -> None:
    """The names and seeds campaign.json gives its conditions, and its seeds: `NotACampaignError`
    unless they are names and seeds a campaign file can give."""
    seeds = info.get("seeds", [])
    if not isinstance(seeds, list) or not all(_is_seed(s) for s in seeds):
        raise NotACampaignError(
            f"{file}: seeds {short_ascii(seeds)} is not a list of seeds (0, 1, ...)"
        )
    conditions = info.get("conditions", [])
    if not isinstance(conditions, list):
        raise NotACampaignError(f"{file}: conditions is not a list")
    for index, condition in enumerate(conditions):
        where = f"{file}: conditions[{index}]"
        if not isinstance(condition, dict) or not _is_condition(condition.get("name")):
            name = condition.get("name") if isinstance(condition, dict) else condition
            raise NotACampaignError(
                f"{where}: {short_ascii(name)} is not a condition name ({_CONDITION_RULE})"
            )
        if any(c.get("name") == condition["name"] for c in conditions[:index]):
            raise NotACampaignError(f"{where}: condition {condition['name']!r} is listed twice")
        own = condition.get("seeds", [])
        if not isinstance(own, list) or not all(_is_seed(s) for s in own):
            raise NotACampaignError(
                f"{where}: seeds {short_ascii(own)} is not a list of seeds (0, 1, ...)"
            )


def _check_runs(path: Path, file: Path, info: Mapping[str, object]) -> None:
    """campaign.json's runs: `NotACampaignError`, naming the entry, unless each is a condition
    and a seed at exactly ``runs/condition=<name>/seed=<n>``, once, with no symbolic link and
    nothing but folders on the way (a folder not made yet is made as a real one), with a config
    (an object) and a run id (a string), which resume needs. A campaign
    folder is data: its runs never lie outside it, nor at a path it chose."""
    runs = info.get("runs")
    if not isinstance(runs, list) or not runs:
        raise NotACampaignError(f"{file}: lists no runs (its 'runs' is {short_ascii(runs)})")
    seen: set[tuple[str, int]] = set()
    conditions = info.get("conditions")
    listed = conditions if isinstance(conditions, list) else []
    named = {str(c.get("name")) for c in listed if isinstance(c, dict)}
    for index, entry in enumerate(runs):
        where = f"{file}: runs[{index}]"
        if not isinstance(entry, dict):
            raise NotACampaignError(f"{where}: {short_ascii(entry)} is not a run (an object)")
        condition, seed = entry.get("condition"), entry.get("seed")
        if not _is_condition(condition):
            raise NotACampaignError(
                f"{where}: condition {short_ascii(condition)} is not a condition name "
                f"({_CONDITION_RULE})"
            )
        if not _is_seed(seed):
            raise NotACampaignError(
                f"{where}: seed {short_ascii(seed)} is not a seed (an integer, 0 <= seed < 2**63)"
            )
        where = f"{where} (condition {condition}, seed {seed})"
        expected = run_path(condition, seed)
        if entry.get("path") != expected:
            raise NotACampaignError(
                f"{where}: refusing path {short_ascii(entry.get('path'))}: a campaign's run lies "
                f"at {expected!r} inside the campaign folder, nowhere else"
            )
        if (condition, seed) in seen:
            raise NotACampaignError(f"{where}: listed twice")
        if not isinstance(entry.get("config"), dict):
            raise NotACampaignError(
                f"{where}: its config {short_ascii(entry.get('config'))} is not a config "
                "(an object)"
            )
        run_id = entry.get("run_id")
        if not isinstance(run_id, str) or not RUN_ID.fullmatch(run_id):
            raise NotACampaignError(
                f"{where}: its run_id {short_ascii(run_id)} is not a run id ({RUN_ID_RULE})"
            )
        if condition not in named:
            raise NotACampaignError(
                f"{where}: its condition is not among the campaign's conditions "
                f"({short_ascii(sorted(named))})"
            )
        seen.add((condition, seed))
        _check_folders(path, expected, where)


def _check_folders(path: Path, relative: str, where: str) -> None:
    """``runs/``, ``condition=<name>/`` and ``seed=<n>/`` under ``path``: each a real folder
    (not a symbolic link, not a file) or not there yet."""
    folder = path
    for part in relative.split("/"):
        folder = folder / part
        if folder.is_symlink():
            raise NotACampaignError(
                f"{where}: refusing {str(folder)!r}: a symbolic link (a campaign's runs lie "
                "inside its folder, never through a link); remove the link"
            )
        if not folder.exists():
            return
        if not folder.is_dir():
            raise NotACampaignError(f"{where}: {str(folder)!r} is not a folder")


def write_campaign_info(path: str | Path, info: Mapping[str, object]) -> None:
    """Write campaign.json: ``info`` (as read, or new) in this ariel's format, first."""
    rest = {key: value for key, value in info.items() if key != "format"}
    atomic_write_json(Path(path) / CAMPAIGN_JSON, {"format": CAMPAIGN_FORMAT, **rest})


def fitness_maximise(info: JsonObject) -> bool:
    """Whether a run's fitness is maximised: run.json's ``maximise``, else the fitness
    function named in its config, looked up in the registry."""
    if "maximise" in info:
        return bool(info["maximise"])
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
        damaged: (condition, seed) -> the one line `load_run` refused that run with (its
            folder has a run.json, unlike a run not made yet); what reads every run (``ariel
            compare``) names it rather than leave it out.
    """

    path: Path
    info: JsonObject
    runs: dict[tuple[str, int], Run] = field(default_factory=dict)
    damaged: dict[tuple[str, int], str] = field(default_factory=dict)

    def __repr__(self) -> str:  # one line, as Run's (campaign.json is in ``info``)
        name, damaged = self.path.name, f", {len(self.damaged)} damaged" * bool(self.damaged)
        return (
            f"<Campaign {name}: {len(self.conditions)} conditions x {len(self.seeds)} seeds, "
            f"{len(self.runs)} runs loaded{damaged}>"
        )

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

    def _joined(self, table: str) -> pd.DataFrame:
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
    def evaluations(self) -> pd.DataFrame:
        """Every run's evaluations table, with ``condition`` and ``seed`` (the run's) columns;
        each evaluation's own seed is its ``eval_seed`` column here."""
        return self._joined("evaluations")

    @cached_property
    def bodies(self) -> pd.DataFrame:
        """Every run's bodies table, with ``condition`` and ``seed`` columns."""
        return self._joined("bodies")

    @cached_property
    def generations(self) -> pd.DataFrame:
        """Every run's per-generation summary (`Run.generations`), with ``condition`` and
        ``seed`` columns."""
        return self._joined("generations")

    def lineages(self) -> dict[str, pd.DataFrame]:
        """Every run's lineage in the ALife phylogeny format (`Run.lineage`), by run id.

        `ariel.recording.lineage_statistics_by_run` turns them into one table of surviving
        lineages and best-body ancestry depth per run and generation.

        Returns:
            Run id (run.json's ``run_id``, else the run folder's name) -> that run's lineage
            (a DataFrame), in the campaign's order.

        Raises:
            DamagedRunError: When a run's bodies table holds a body id that is not one, or a
                parent that is no body of the run.
        """
        return campaign_lineages(self)

    def records_pending(self, rows: list[dict[str, object]] | None = None) -> bool:
        """Whether every run finished but not the campaign's own records (campaign.rrd and
        campaign.json's ``finished``): stopped after its last run, `campaign resume` writes
        them. ``rows``: `status`'s, where already at hand."""
        rows = self.status() if rows is None else rows
        finished = bool(rows) and all(row["status"] == "finished" for row in rows)
        return finished and self.info.get("status") != "finished"

    def status(self) -> list[dict[str, object]]:
        """One row per run of campaign.json: condition, seed, status, generations, best.
        ``status``: run.json's, `STOPPED` for a killed run, ``"not started"`` for a run not
        made yet, `DAMAGED` for one whose folder does not load (`load_campaign` leaves it out;
        ``ariel verify`` it)."""
        rows = []
        for entry in self.info.get("runs", []):
            key = (entry["condition"], int(entry["seed"]))
            run = self.runs.get(key)
            info = run.info if run is not None else {}
            status = info.get("status", "not started")
            if run is None and key in self.damaged:
                status = DAMAGED  # load_campaign left it out: `ariel verify` it
            if status == "running" and holder_gone(self.path / entry["path"]):
                status = STOPPED
            best = info.get("best_fitness")
            evaluations = info.get("evaluations_done", 0)
            rows.append(
                {
                    "condition": key[0],
                    "seed": key[1],
                    "path": entry["path"],
                    "status": status,
                    "generations_done": run.generations_done if run is not None else 0,
                    "generations": entry.get("config", {}).get("generations"),
                    "evaluations": evaluations if type(evaluations) is int else 0,
                    "best_fitness": best if isinstance(best, float) else math.nan,
                }
            )
        return rows


def load_campaign(path: str | Path) -> Campaign:
    """The records of the campaign in ``path`` (a folder made by `ariel campaign run`).

    A run whose folder has no run.json yet (a campaign killed while it was being made), or
    whose folder does not load (damaged: its line in ``Campaign.damaged``), is left out of
    ``Campaign.runs``; `Campaign.status` still lists it.

    Args:
        path: The campaign folder.

    Returns:
        The campaign: its ``campaign.json`` and its runs' records, with the joined
        ``evaluations``, ``bodies`` and ``generations`` tables (columns ``condition`` and
        ``seed`` first).

    Raises:
        NotACampaignError: When ``path`` has no readable ``campaign.json``, or one that no
            campaign writes.
        TypeError: When ``path`` is not a path.
    """
    path = path_argument("path", path, function="load_campaign")
    info = read_campaign_info(path)
    campaign = Campaign(path=path, info=info)
    for entry in info.get("runs", []):
        key = (entry["condition"], int(entry["seed"]))
        try:
            campaign.runs[key] = load_run(path / entry["path"])
        except NotARunError as exc:
            folder = path / entry["path"]
            if os.path.lexists(folder / "run.json"):
                campaign.damaged[key] = str(exc)  # else not made yet (a campaign killed early)
            elif any(os.path.lexists(folder / name) for name in _WRITTEN_AFTER_RUN_JSON):
                campaign.damaged[key] = (  # it was "not started", and resume refused it
                    f"run folder {str(folder)!r} is damaged: it holds tables but no run.json; "
                    "restore the folder from a copy"
                )
    return campaign


#: What a run writes only after its run.json: a folder holding one of them had a run.json.
_WRITTEN_AFTER_RUN_JSON = ("evaluations", "bodies", "manifests", "checkpoints")
