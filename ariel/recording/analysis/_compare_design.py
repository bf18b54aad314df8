"""What `ariel compare` compares, checked and said.

- Runs measured differently are not compared: `check_comparable` refuses, in one line naming
  the first difference, runs of other fitness functions (``task.fitness`` and its options),
  episode lengths (``task.duration``), settling times (``task.settle``; a run made before it
  existed reads as 0) or worlds (``world.name`` and its options).
- One budget for all: each run is compared at the same number of evaluations, the smallest
  any run made (or ``--at-evaluations N``): its best fitness so far after its first N
  evaluations, in the order the loop made them (`evaluation_order`). `common_budget` says so
  where the runs made different numbers.
- `describe` writes down what was compared (runs, conditions and their overrides, base
  config, budget, seeds, tests, software, commit) for ``compare.html`` and its README.
"""

from __future__ import annotations

import contextlib
import json
import math
from collections import Counter
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ariel.errors import ArielError, ConfigError
from ariel.evolution import ExperimentConfig
from ariel.recording.store import archive_cell_count

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.analysis._compare_runs import RunCurve

__all__ = [
    "MEASURED_BY",
    "MEASURES",
    "QD_COLUMNS",
    "CompareError",
    "Source",
    "check_comparable",
    "common_budget",
    "condition_settings",
    "describe",
    "evaluation_order",
    "first_evaluations",
    "run_state_notes",
    "shared_settings",
    "whole_generations",
]

#: Measure name -> its column in `Comparison.runs`.
MEASURES = {"final best": "final_best", "AUC": "auc"}
#: Quality-diversity columns of `Run.generations` shown per condition where runs have them.
QD_COLUMNS = ("qd_score", "norm_qd_score", "coverage")


class CompareError(ArielError, ValueError):
    """Runs that cannot be compared (none, different fitness functions, ...): one line."""


#: The config keys that decide what a fitness value means, with the value a run.json config
#: without the key had (``task.settle`` came later: older runs did not settle).
MEASURED_BY: tuple[tuple[str, object], ...] = (
    ("task.fitness", "xy_displacement"),
    ("task.options", {}),
    ("task.duration", None),
    ("task.settle", 0.0),
    ("world.name", "flat"),
    ("world.options", {}),
)


def _value(config: Mapping[str, object], dotted: str, default: object) -> object:
    value: object = config
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            return default
        value = value[part]
    return value


def _shown(value: object) -> str:
    return json.dumps(value, sort_keys=True, default=str)


def check_comparable(configs: Sequence[tuple[str, Mapping[str, object]]]) -> None:
    """Refuse (`CompareError`, one line) runs whose ``(label, config)`` differ in a key of
    `MEASURED_BY`: the first such key, with the first run that differs from the first run."""
    if not configs:
        return
    first_label, first = configs[0]
    for key, default in MEASURED_BY:
        expected = _value(first, key, default)
        for label, config in configs[1:]:
            found = _value(config, key, default)
            if found != expected:
                raise CompareError(
                    f"the runs differ in {key}: {_shown(expected)} in {first_label}, "
                    f"{_shown(found)} in {label}; only runs measured the same way (fitness, "
                    "duration, settle, world) can be compared"
                )


# --------------------------------------------------------------------------------------------
# The budget
# --------------------------------------------------------------------------------------------


def evaluation_order(evaluations: pd.DataFrame) -> pd.DataFrame:
    """The evaluations in the order the loop made them: by generation, then eval id (body,
    iteration, candidate), as the best-so-far curves count them
    (`ariel.recording.store._curves`)."""
    return evaluations.sort_values(["generation", "eval_id"], kind="stable")


def first_evaluations(evaluations: pd.DataFrame, budget: int) -> pd.DataFrame:
    """The run's first ``budget`` evaluations, in `evaluation_order`."""
    return evaluation_order(evaluations).head(budget).reset_index(drop=True)


def whole_generations(evaluations: pd.DataFrame, budget: int) -> list[Hashable]:
    """The generations all of whose evaluations are among the run's first ``budget``
    (`first_evaluations`): those whose per-generation values (QD, lineage) count at it."""
    counts = evaluations["generation"].value_counts()
    within = first_evaluations(evaluations, budget)["generation"].value_counts()
    return [g for g, n in within.items() if counts.get(g) == n]


def common_budget(
    totals: Mapping[str, int], at_evaluations: int | None = None
) -> tuple[int, str | None]:
    """(the evaluations every run is compared at, a warning where the runs' ``totals`` differ).

    The smallest total, or ``at_evaluations`` (`CompareError` where it is below 1 or beyond a
    run's total)."""
    if not totals:
        raise CompareError("no run with a finished generation to compare")
    label, smallest = min(totals.items(), key=lambda item: item[1])
    largest = max(totals.values())
    if at_evaluations is not None:
        if at_evaluations < 1:
            raise CompareError(f"--at-evaluations must be at least 1, not {at_evaluations}")
        if at_evaluations > smallest:
            raise CompareError(
                f"--at-evaluations {at_evaluations:,} exceeds the {smallest:,} evaluations of "
                f"{label}; choose at most {smallest:,}"
            )
    budget = smallest if at_evaluations is None else at_evaluations
    if smallest == largest:
        return budget, None
    how = (
        "chosen with --at-evaluations"
        if at_evaluations is not None
        else ("the smallest common budget; choose another with --at-evaluations N")
    )
    return budget, (
        f"the runs made {smallest:,} to {largest:,} evaluations: compared at {budget:,} "
        f"evaluations per run ({how})"
    )


def run_state_notes(curves: Sequence[RunCurve]) -> list[str]:
    """Warnings about runs that are not what a finished comparison reads as: runs not finished
    (a campaign still going, or stopped; all at one generation, the budgets do not differ and
    nothing else says so), runs of which no evaluation succeeded (their fitness measures
    are missing from the tests), and archives of different sizes (coverage is a share of
    each run's own archive)."""
    notes = []
    label = {id(c): f"{c.condition} seed {c.seed}" for c in curves}
    # (a curve without run.json, `compare_runs` on tables of your own, has no status)
    unfinished = [c for c in curves if c.info.get("status", "finished") != "finished"]
    if unfinished:
        states = Counter(str(c.info.get("status"))[:20] for c in unfinished)
        said = ", ".join(f"{count} {state}" for state, count in sorted(states.items()))
        notes.append(
            f"{len(unfinished)} of {len(curves)} runs are not finished ({said}): compared at "
            "the generations they have finished; compare again once they finish"
        )
    failed = [c for c in curves if not any(map(math.isfinite, c.evaluations["fitness"]))]
    if failed:
        names = ", ".join(label[id(c)] for c in failed[:5]) + (", ..." if len(failed) > 5 else "")
        notes.append(
            f"{len(failed)} run(s) have no successful evaluation ({names}): their fitness "
            "measures are missing from the tests (their evaluations' status and error say why)"
        )
    sizes = sorted({n for c in curves if (n := _archive_cells(c.info)) is not None})
    if len(sizes) > 1:
        notes.append(
            f"the runs' archives differ in size ({', '.join(f'{n:,}' for n in sizes)} cells): "
            "coverage and norm_qd_score are shares of each run's own archive, not of one"
        )
    return notes


def _archive_cells(info: Mapping[str, Any]) -> int | None:
    """The cells of the archive run.json describes; None: no archive, or none readable."""
    archive = info.get("archive")
    if not isinstance(archive, Mapping) or archive.get("kind") not in ("grid", "cvt"):
        return None
    try:
        return archive_cell_count(archive)
    except (TypeError, ValueError, KeyError):  # damage: the run's own readers say so
        return None


# --------------------------------------------------------------------------------------------
# What was compared
# --------------------------------------------------------------------------------------------


@dataclass
class Source:
    """Where the runs came from (`compare` fills it in; `compare_runs` without it says less).

    ``what``: the campaign or the run list; ``overrides``: condition -> its settings (a
    campaign condition's ``set``; a condition not in it is named by its settings);
    ``base``: the base config's path or name."""

    what: str = ""
    overrides: dict[str, str] = field(default_factory=dict)
    base: str = ""


def _flat(config: Mapping[str, object], prefix: str = "") -> dict[str, str]:
    flat: dict[str, str] = {}
    for key, value in config.items():
        if isinstance(value, Mapping) and not key.endswith("options"):
            flat.update(_flat(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = _shown(value)
    return flat


#: The body loop's settings, which a brain-only run ignores: no condition of such runs.
BODY_LOOP = tuple(
    f"body.{key}"
    for key in (
        "optimizer",
        "optimizer_options",
        "population",
        "offspring",
        "survivors",
        "tournament",
        "crossover_rate",
    )
)


def condition_settings(config: Mapping[str, object], brain_only: bool = False) -> dict[str, str]:
    """A run config as dotted key -> JSON value (a plugin's ``options`` as one value), less
    what does not make a condition: seed, name, description and the executor, and in a
    brain-only run (``brain_only``) the body loop's settings it ignores (`BODY_LOOP`: two
    such runs that differed only there were two conditions of one experiment). Keys added
    since an older run was made read as they behaved then (`ExperimentConfig.from_plain`):
    an old run is not another condition for lacking ``task.settle``."""
    with contextlib.suppress(ConfigError, TypeError, ValueError):
        config = ExperimentConfig.from_plain(config).to_plain()
    ignored = BODY_LOOP if brain_only else ()
    return {
        k: v
        for k, v in _flat(config).items()
        if k not in ("seed", "name", "description", *ignored) and not k.startswith("executor.")
    }


def shared_settings(configs: Sequence[Mapping[str, object]]) -> dict[str, str]:
    """The `condition_settings` every run shares (the base config's resolved values)."""
    flats = [condition_settings(c) for c in configs]
    if not flats:
        return {}
    return {k: v for k, v in flats[0].items() if all(f.get(k) == v for f in flats[1:])}


def _seed_list(seeds: Sequence[int]) -> str:
    seeds = sorted(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(str(s) for s in seeds) or "none"


def _seeds_text(seeds: Mapping[str, Sequence[int]], paired: bool) -> str:
    sets = {tuple(sorted(s)) for s in seeds.values()}
    if len(sets) == 1:
        listed = f"{_seed_list(next(iter(sets)))} in every condition"
    else:
        listed = "; ".join(f"{name} {_seed_list(s)}" for name, s in seeds.items())
    if paired:
        return (
            f"shared, common random numbers (generation 0 is the same in every condition): "
            f"{listed}; runs paired by seed"
        )
    return f"not paired: {listed}"


def _budget_text(totals: Mapping[str, Sequence[int]], budget: int) -> str:
    parts = []
    for name, counts in totals.items():
        low, high = min(counts), max(counts)
        parts.append(f"{name} {low:,}" if low == high else f"{name} {low:,}-{high:,}")
    return f"evaluations per run: {', '.join(parts)}; compared at {budget:,} evaluations per run"


def _software(infos: Sequence[Mapping[str, Any]]) -> tuple[str, str]:
    """(the distinct software versions of the runs, their distinct git commits), each with
    its segments' (a resumed run's later software)."""
    versions: dict[str, int] = {}
    commits: dict[str, int] = {}
    for info in infos:
        parts = [info, *[s for s in info.get("segments") or [] if isinstance(s, Mapping)]]
        seen_versions = {
            ", ".join(f"{k} {v}" for k, v in (p.get("versions") or {}).items() if v)
            for p in parts
            if p.get("versions")
        }
        for text in seen_versions or {"not recorded"}:
            versions[text] = versions.get(text, 0) + 1
        seen_commits = {str(p["git_commit"]) for p in parts if p.get("git_commit")}
        for text in seen_commits or {"not recorded"}:
            commits[text] = commits.get(text, 0) + 1

    def joined(found: dict[str, int]) -> str:
        if len(found) == 1:
            return next(iter(found))
        return " | ".join(f"{text} ({n} runs)" for text, n in found.items())

    return joined(versions), joined(commits)


def describe(
    source: Source,
    *,
    seeds: Mapping[str, Sequence[int]],
    totals: Mapping[str, Sequence[int]],
    budget: int,
    tests: str,
    paired: bool,
    infos: Sequence[Mapping[str, Any]],
) -> list[tuple[str, str]]:
    """What was compared, as (label, text) lines: the runs, each condition's overrides, the
    base config, budget, seeds, tests, software versions and git commit."""
    lines = [("compared", source.what or f"{sum(len(s) for s in seeds.values())} runs")]
    conditions = "; ".join(
        f"{name}: {source.overrides[name] or 'no overrides'}" if name in source.overrides else name
        for name in seeds
    )
    lines.append(("conditions", conditions))
    if source.base:
        lines.append(("base config", source.base))
    lines += [
        ("budget", _budget_text(totals, budget)),
        ("seeds", _seeds_text(seeds, paired)),
        ("tests", tests),
    ]
    versions, commits = _software(infos)
    lines += [("software", versions), ("git commit", commits)]
    return lines
