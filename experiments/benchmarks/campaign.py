"""Campaign benchmark: evaluations per second of a whole campaign against raw MuJoCo.

The campaign: 2 conditions x 3 seeds of ``experiments/gecko_gait.toml`` (brain-only: CMA-ES
over the NA-CPG of the fixed gecko on flat ground; the conditions differ in ``brain.sigma0``,
0.5 and 1.0; Rerun recordings off), ``--generations`` x ``--iterations`` x ``--popsize``
evaluations of ``--duration`` simulated seconds per run, all six runs side by side on ONE
``local`` executor (one worker process per CPU, or ``--workers``) through
``ariel.runs.run_campaign``. The six runs' brain batches interleave on the pool, so workers
stay busy while a run's driver tells CMA-ES and writes its generation.

What is timed: the whole ``run_campaign`` call (the campaign file's validation, every run
folder, every driver's work, every generation's tables and checkpoint, campaign.rrd), except
the process pool's start, as in ``coevolution.py``: a pool is started, all its workers seen
alive, and handed to the campaign (``ariel.evaluation.make_executor`` is replaced for the
call; the campaign must ask for it exactly once).

The reference: raw threaded ``mujoco.rollout`` of the same number of evaluations of the same
model and length (``coevolution.raw_sampler``: ``Rollout(nthread=CPUs)``, precomputed controls
in batches of ``popsize``), timed in the same process, rounds alternating with the campaign.
The ratio is the median over rounds of (campaign evaluations/s) / (raw evaluations/s).

Also reported: the workers' busy share, the time the workers spent in evaluations (the
evaluations' ``wall_seconds``) over the campaign's wall time x workers.

Prints a table, then as the last line one JSON object with ``campaign_vs_raw_ratio``,
``busy_share``, ``campaign_evals_per_s``, ``raw_evals_per_s`` and context.

    python experiments/benchmarks/campaign.py [--generations 2] [--popsize 16]
        [--iterations 2] [--duration 15] [--workers N] [--repeats 3] [--quick]
"""

from __future__ import annotations

from _common import (
    add_quick_option,
    apply_quick,
    check_at_least,
    check_seconds,
    load_average,
    one_blas_thread,
)

one_blas_thread()  # before numpy: the pools read the thread limits once

import argparse  # noqa: E402
import contextlib  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import mujoco  # noqa: E402
from coevolution import prestarted_executor, raw_sampler, started_pool  # noqa: E402

from ariel.evaluation.executors import default_workers  # noqa: E402
from ariel.evolution import load_config  # noqa: E402
from ariel.runs import run_campaign  # noqa: E402

BASE = Path(__file__).resolve().parents[1] / "gecko_gait.toml"
TARGET = 0.85  # campaign_vs_raw_ratio >= TARGET
CONDITIONS = {"sigma-0.5": 0.5, "sigma-1.0": 1.0}
SEEDS = (1, 2, 3)
QUICK = {"generations": 1, "popsize": 4, "iterations": 1, "duration": 0.5, "repeats": 1}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--generations", type=int, default=2, help="generations per run")
    parser.add_argument("--popsize", type=int, default=16, help="CMA-ES population size")
    parser.add_argument("--iterations", type=int, default=2, help="CMA-ES iterations/generation")
    parser.add_argument("--duration", type=float, default=15.0, help="simulated seconds")
    parser.add_argument("--workers", type=int, default=None, help="default: one per CPU")
    parser.add_argument("--repeats", type=int, default=3, help="timed rounds")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    check_at_least(parser, args, 1, "generations", "iterations", "repeats", "workers")
    check_at_least(parser, args, 2, "popsize")
    check_seconds(parser, args, "duration")
    return args


def campaign_file(args: argparse.Namespace, folder: Path) -> Path:
    settings = {
        "generations": args.generations,
        "brain.popsize": args.popsize,
        "brain.iterations": args.iterations,
        "task.duration": args.duration,
        "record.rerun": False,
        "executor.kind": "local",
    }
    lines = [
        'name = "benchmark"',
        f"base = {json.dumps(str(BASE))}",
        f"seeds = {list(SEEDS)}",
        "set = { " + ", ".join(f'"{k}" = {json.dumps(v)}' for k, v in settings.items()) + " }",
    ]
    for name, sigma in CONDITIONS.items():
        lines += ["[[condition]]", f'name = "{name}"', f'set = {{ "brain.sigma0" = {sigma} }}']
    path = folder / "campaign.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def campaign_sampler(
    file: Path, workers: int | None, folder: Path, expected: int, info: dict[str, list[float]]
) -> Callable[[], float]:
    """One timed ``run_campaign`` on a fresh, prestarted pool; returns its seconds."""
    counter = iter(range(1_000_000))

    def sample() -> float:
        out = folder / f"campaign-{next(counter):03d}"
        executor, pool_seconds = started_pool(workers)
        try:
            with prestarted_executor(executor, workers):
                gc.collect()
                start = time.perf_counter()
                result = run_campaign(file, out=out, workers=workers)
                seconds = time.perf_counter() - start
        finally:
            executor.shutdown(wait=True)
        evaluations = result.load().evaluations
        if result.status != "finished" or len(evaluations) != expected:
            raise RuntimeError(f"benchmark: the campaign ended {result.status!r}, incomplete")
        if (evaluations["status"] != "ok").any():
            raise RuntimeError("benchmark: some evaluations failed")
        info.setdefault("pool_start", []).append(pool_seconds)
        info.setdefault("busy", []).append(result.busy_share)
        return seconds

    return sample


def report(
    args: argparse.Namespace,
    info: dict[str, list[float]],
    campaign_seconds: list[float],
    raw_seconds: list[float],
) -> dict[str, Any]:
    """Print the table; return the JSON summary (without the load averages)."""
    per_run = args.generations * args.iterations * args.popsize
    evaluations = per_run * len(CONDITIONS) * len(SEEDS)
    threads = default_workers()
    workers = args.workers or threads
    ratios = [r / c for c, r in zip(campaign_seconds, raw_seconds)]  # rates: inverse times
    ratio = statistics.median(ratios)
    campaign_rate = evaluations / statistics.median(campaign_seconds)
    raw_rate = evaluations / statistics.median(raw_seconds)
    busy = statistics.median(info["busy"])
    print()
    print(f"{'figure':<48}{'evals/s':>9}{'ratio':>8}  target")
    print("-" * 78)
    print(f"{'raw mujoco.rollout (reference)':<48}{raw_rate:>9.2f}{1:>8.2f}")
    verdict = "ok" if ratio >= TARGET else "MISSED"
    figures = f"{campaign_rate:>9.2f}{ratio:>8.3f}"
    print(f"{'campaign, run_campaign':<48}{figures}  >= {TARGET} {verdict}")
    print(f"workers busy {busy:.0%} of the campaign's wall time x {workers} workers")
    print(
        "per round: "
        + "; ".join(
            f"campaign {c:.2f} s, raw {r:.2f} s, ratio {q:.3f}"
            for c, r, q in zip(campaign_seconds, raw_seconds, ratios)
        )
    )
    return {
        "campaign_vs_raw_ratio": round(ratio, 4),
        "busy_share": round(busy, 4),
        "campaign_evals_per_s": round(campaign_rate, 3),
        "raw_evals_per_s": round(raw_rate, 3),
        "evaluations": evaluations,
        "runs": len(CONDITIONS) * len(SEEDS),
        "threads": threads,
        "workers": workers,
        "ratios": [round(r, 4) for r in ratios],
        "campaign_s": [round(s, 3) for s in campaign_seconds],
        "raw_s": [round(s, 3) for s in raw_seconds],
        "pool_start_s": round(statistics.median(info["pool_start"]), 3),
        "generations": args.generations,
        "iterations": args.iterations,
        "popsize": args.popsize,
        "duration_s": args.duration,
        "repeats": args.repeats,
        "cpus": os.cpu_count(),
        "mujoco": mujoco.__version__,
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    per_run = args.generations * args.iterations * args.popsize
    evaluations = per_run * len(CONDITIONS) * len(SEEDS)
    threads = default_workers()
    workers = args.workers or threads
    load_before = load_average()
    print(
        f"ARIEL campaign benchmark: {len(CONDITIONS)} conditions x {len(SEEDS)} seeds of "
        f"{BASE.name} (brain-only gecko), {per_run} evaluations per run, {evaluations} in all, "
        f"{args.duration:g} s simulated each; one local executor of {workers} workers; raw: "
        f"Rollout(nthread={threads}); median of {args.repeats} rounds; load {load_before}"
    )
    info: dict[str, list[float]] = {}
    campaign_seconds: list[float] = []
    raw_seconds: list[float] = []
    with (
        tempfile.TemporaryDirectory(prefix="ariel-campaign-bench-") as tmp,
        contextlib.ExitStack() as stack,
    ):
        file = campaign_file(args, Path(tmp))
        config = load_config(
            BASE,
            [
                f"brain.popsize={args.popsize}",
                f"task.duration={args.duration!r}",
                'executor.kind="local"',
            ],
        )
        raw = raw_sampler(config, evaluations, threads, stack)
        campaign = campaign_sampler(file, args.workers, Path(tmp), evaluations, info)
        raw()  # warm-ups, untimed (the first campaign pays the driver's one-time imports)
        campaign()
        info.clear()
        for round_ in range(args.repeats):
            order = [(raw, raw_seconds), (campaign, campaign_seconds)]
            for sample, seconds in order if round_ % 2 == 0 else order[::-1]:
                gc.collect()
                seconds.append(sample())
    load_after = load_average()

    summary = report(args, info, campaign_seconds, raw_seconds)
    summary.update(loadavg_before=load_before, loadavg_after=load_after)
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
