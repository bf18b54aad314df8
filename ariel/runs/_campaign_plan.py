"""`ariel campaign run FILE --dry-run`: what a campaign will do, and roughly how long, before it
starts. Nothing is written.

The estimate times real evaluations here: for each condition, one batch (the brain's popsize)
of random brains on a few random bodies of its encoder (the fixed body of a brain-only run), on
this process's threads, and scales each condition's evaluations by it over the workers. It
leaves out what a run adds to the physics (CMA-ES, records, Rerun, shipping to workers: the
ratio `experiments/benchmarks/coevolution.py` measures) and how the bodies evolve (bigger
or smaller bodies simulate slower or faster), so it is a figure to plan with, not a promise.
Where other work keeps the machine busy (its load average), a second line scales it to that
load (`busy_factor`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ariel.errors import BodyBuildError
from ariel.evaluation import default_workers
from ariel.evaluation.executors import planned_workers
from ariel.evolution import (
    body_spec,
    evaluation_task,
)
from ariel.runs._campaign_file import load_campaign_file
from ariel.runs._prepare import PreparedRun, executor_settings, prepare_run

__all__ = ["CampaignPlan", "campaign_plan"]

_BODIES = 3  # random bodies timed per condition (their sizes vary)
#: The most conditions timed (about a second each): a grid of 1,000 took a quarter of an hour
#: to plan; the others count at the timed ones' mean, and the plan says so.
MOST_TIMED = 24


@dataclass
class CampaignPlan:
    """``rows``: per condition, its seeds, evaluations per run and simulated seconds per
    evaluation, and (where timed) seconds per evaluation here; ``workers``: the executor's."""

    name: str
    workers: int
    rows: list[dict[str, Any]] = field(default_factory=list)
    local: bool = True  # the workers run on this machine (its load says how busy they are)

    @property
    def runs(self) -> int:
        return sum(len(row["seeds"]) for row in self.rows)

    @property
    def evaluations(self) -> int:
        return sum(len(row["seeds"]) * row["evaluations"] for row in self.rows)

    @property
    def estimate_seconds(self) -> float | None:
        """Wall seconds on ``workers`` processes, from the timed evaluations (None: not timed)."""
        if any(row.get("seconds_per_evaluation") is None for row in self.rows):
            return None
        busy = sum(
            len(row["seeds"]) * row["evaluations"] * row["seconds_per_evaluation"]
            for row in self.rows
        )
        return busy / max(1, self.workers)


def campaign_plan(
    file: str | Path,
    overrides: tuple[str, ...] = (),
    *,
    executor: str | None = None,
    workers: int | None = None,
    timed: bool = True,
    on_timing: Callable[[], None] | None = None,
) -> CampaignPlan:
    """The campaign ``file`` (with ``overrides`` on its base) as conditions x seeds x
    evaluations, each condition timed here unless ``timed`` is False (``on_timing`` is called
    before the timing starts). Raises what `run_campaign` would for a bad file, before timing
    anything."""
    spec = load_campaign_file(file, overrides)
    first = next(iter(spec.configs.values()))
    settings = executor_settings(first, kind=executor, workers=workers)
    workers, here = planned_workers(settings)
    plan = CampaignPlan(spec.name, workers, local=here)
    prepared = {key: prepare_run(config, settings) for key, config in spec.configs.items()}
    if timed and on_timing is not None:
        on_timing()
    seen: dict[str, dict[str, Any]] = {}
    for (condition, seed), run in prepared.items():
        if condition in seen:
            seen[condition]["seeds"].append(seed)
            continue
        row: dict[str, Any] = {
            "condition": condition,
            "seeds": [seed],
            "evaluations": run.budget,
            "simulated_seconds": run.config.task.duration,
        }
        if timed and len(seen) < MOST_TIMED:
            row["seconds_per_evaluation"] = _seconds_per_evaluation(run)
        seen[condition] = row
        plan.rows.append(row)
    timed_rows = [row for row in plan.rows if "seconds_per_evaluation" in row]
    # per simulated second: a grid over task.duration scales with it
    rate = sum(r["seconds_per_evaluation"] / r["simulated_seconds"] for r in timed_rows)
    for row in plan.rows[MOST_TIMED:] if timed else []:  # the timed ones' mean
        row["seconds_per_evaluation"] = rate / len(timed_rows) * row["simulated_seconds"]
        row["at_mean"] = True
    return plan


def _seconds_per_evaluation(run: PreparedRun) -> float:
    """CPU seconds per evaluation of a batch of random brains on random bodies, here, on one
    thread (as a worker process of the local pool runs it; CPU time, so that other work on the
    machine does not inflate it)."""
    # lazy: the engine imports mujoco (slow, and it reads MUJOCO_GL): only a timed plan needs it
    from ariel.evaluation import build, evaluate_batch

    config, plugins = run.config, run.plugins
    rng = np.random.default_rng(0)
    seconds, count = 0.0, 0
    for _ in range(1 if run.brain_only else _BODIES):
        genotype = run.genotype if run.brain_only else plugins.encoder.random_genotype(rng)
        spec = body_spec(config, genotype)
        try:
            model = build(evaluation_task(config, spec)).model
        except BodyBuildError:
            continue
        n_params = int(plugins.controller.num_parameters(model))
        batch = max(1, config.brain.popsize if n_params else 1)
        tasks = [
            evaluation_task(config, spec, rng.normal(0.0, 0.5, n_params), seed=i)
            for i in range(batch)
        ]
        begin = time.process_time()  # this process's CPU: what a worker of its own would take
        evaluate_batch(tasks, nthread=1)
        seconds, count = seconds + time.process_time() - begin, count + batch
    return seconds / count if count else 0.0


def plan_text(plan: CampaignPlan) -> list[str]:
    """The lines `ariel campaign run --dry-run` prints."""
    count = f"{len(plan.rows)} condition{'' if len(plan.rows) == 1 else 's'}"
    lines = [f"campaign {plan.name}: {count}, {plan.runs} runs (dry run)"]
    for row in plan.rows:
        seeds = row["seeds"]
        shown = (
            f"{seeds[0]}..{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else seeds
        )
        per = row.get("seconds_per_evaluation")
        timing = f", {per * 1000:.0f} ms per evaluation here" if per is not None else ""
        timing += " (the timed conditions' mean)" if row.get("at_mean") else ""
        lines.append(
            f"  {row['condition']}: seeds {shown} ({len(seeds)} runs) x {row['evaluations']} "
            f"evaluations of {row['simulated_seconds']:g} s{timing}"
        )
    workers = f"{plan.workers} worker{'' if plan.workers == 1 else 's'}"
    lines.append(f"total: {plan.evaluations} evaluations on {workers}")
    if any(row.get("at_mean") for row in plan.rows):
        lines.append(
            f"  (the first {MOST_TIMED} of {len(plan.rows)} conditions timed; the others "
            "counted at their mean)"
        )
    seconds = plan.estimate_seconds
    if seconds is not None:
        lines.append(
            f"estimate: about {_duration(seconds)} with the cores to itself (from the physics of "
            "random bodies timed here; other work on the machine, the loop and records add to "
            "it, evolved bodies may be slower or faster)"
        )
        busy = busy_factor(plan.workers) if plan.local else None
        if busy is not None:
            load, cores, factor = busy
            lines.append(
                f"  this machine is busy now (load {load:.1f} on {cores} cores): at this load, "
                f"about {_duration(seconds * factor)}"
            )
    return lines


def busy_factor(workers: int) -> tuple[float, int, float] | None:
    """(load, cores, how many times longer) where the machine's other work (the 1-minute load
    average) leaves ``workers`` processes at least a fifth less CPU than they would get on
    their own, else None (no load average on this system, or room for them). Each gets
    cores / (load + workers) of a core, at most one; on their own, cores / workers. The
    timing the dry run has just done adds to the load: a slight overstatement."""
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # Windows; a system that does not say
        return None
    cores = default_workers()  # the CPUs this process may use (its affinity mask)
    alone = min(1.0, cores / workers)
    shared = min(1.0, cores / (load + workers))
    factor = alone / shared
    return (load, cores, factor) if factor > 1.2 else None


def _duration(seconds: float) -> str:
    minutes = seconds / 60
    if seconds < 1:  # "about 0 s" for a tiny campaign
        return "a second"
    if minutes < 1:
        return f"{seconds:.0f} s"
    return f"{minutes:.0f} min" if minutes < 120 else f"{minutes / 60:.1f} h"
