"""Co-evolution loop benchmark: evaluations per second of the whole loop against raw MuJoCo.

The loop: ``ariel.evolution.run_experiment(config, out=<temporary folder>, progress=False)`` on
``experiments/gecko_gait.toml`` (brain-only: CMA-ES over the NA-CPG of the fixed gecko on the
flat world, the config's record rate; Rerun recordings off, ``record.rerun = false``: their
cost is what ``recording.py`` measures) with ``--generations``, ``--popsize`` and
``--iterations`` CMA-ES iterations per generation, ``--duration`` simulated seconds per
evaluation, on the default ``local`` executor (one worker process per CPU, or ``--workers``).
That is ``generations x iterations x popsize`` evaluations.

What the loop figure times: the whole ``run_experiment`` call, ``time.perf_counter`` around it,
i.e. everything a user pays per run: config validation, the run folder, the driver's compile of
the body, every CMA-ES ask/tell, building the tasks, shipping them to the workers, each worker's
own compile of the body (with the imports its first build needs), CPG controls, physics,
kinematics and fitness, the results' way back (pickling), the Parquet tables and checkpoint of
every generation, and the pool's shutdown. One thing only is excluded: starting the worker
processes (the forkserver, interpreter start-up, and the imports of the main module, which
every forkserver/spawn worker runs: here this script, which imports the engine). That is a
fixed cost per run, independent of the run's length (0.3 to 1 s here), which a real run of
minutes to hours pays once, while in a benchmark of a few seconds it would dominate. To
exclude it, a fresh pool from ``make_executor("local", workers=...)`` (the very pool the loop
would make) is started and all its workers are seen alive before the clock starts, and the
loop is handed that pool: the benchmark replaces ``ariel.evaluation.make_executor`` for the
call (checked: the loop must ask for it exactly once, with the same kind and workers). Its
time is reported (``pool_start_s``), and so is the ratio that includes it
(``end_to_end_ratio``).

The reference: a raw threaded ``mujoco.rollout`` of the same number of evaluations on the same
model (the gecko in the flat world, compiled by ``ariel.evaluation.build`` as the loop's
workers compile it), with one ``Rollout(nthread=N)`` pool, N = the number of CPUs this process
may use, in batches of ``popsize`` (one CMA-ES generation each) of the same number of steps.
The controls are precomputed outside the timed region: random targets, uniform in the actuator
ranges, one per controller call, held for ``control_period`` steps with the engine's smoothing
(``control_sequence``), as the engine's controls are shaped (a random gait costs the solver
about what a CPG gait does). Output arrays are preallocated once: only ``rollout`` calls are
timed.

Each round times one reference and one loop run (alternating which goes first), after one
untimed warm-up of each; ``gc.collect()`` runs before every sample, untimed. The loop's warm-up
is the first ``run_experiment`` of this process: it also pays the driver's one-time imports
(pycma, pyarrow, networkx, ...; about 0.5 s), start-up cost of the driver process as the pool
start-up is of the workers'. It is reported (``first_run_ratio``), not part of the ratio.
The ratio is the median over rounds of (loop evaluations/s) / (reference evaluations/s) of the
same round, so load from other processes on a shared machine hits both sides of a ratio alike;
the evaluations/s figures are medians too.

Also reported: the engine's own controls + physics time per evaluation in the loop's workers
(the evaluations' ``wall_seconds``) beside the reference's physics time per evaluation and
thread, so one can see that both sides do the same physics work, and the share of the workers'
time spent in it.

Prints a table, then as the last line one JSON object with ``loop_vs_raw_ratio``,
``loop_evals_per_s``, ``raw_evals_per_s``, ``evaluations``, ``threads`` and context.

    python experiments/benchmarks/coevolution.py [--generations 3] [--popsize 16]
        [--iterations 4] [--duration 15] [--workers N] [--repeats 3] [--seed 3] [--quick]
"""

from __future__ import annotations

from _common import (
    add_quick_option,
    apply_quick,
    check_at_least,
    check_seconds,
    check_seed,
    load_average,
    one_blas_thread,
)

# As in evaluation.py: BLAS/OpenMP pools are sized before numpy is imported (the loop's workers
# get the same limits from the executor, and the driver limits its own BLAS around pycma).
one_blas_thread()

import argparse  # noqa: E402
import concurrent.futures as cf  # noqa: E402
import contextlib  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402
from unittest import mock  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from mujoco import rollout  # noqa: E402

import ariel.evaluation  # noqa: E402
from ariel.evaluation import build  # noqa: E402
from ariel.evaluation._engine import control_sequence, num_steps  # noqa: E402
from ariel.evaluation.executors import default_workers  # noqa: E402
from ariel.evolution import ExperimentConfig, load_config, run_experiment  # noqa: E402
from ariel.evolution._tasks import body_spec, evaluation_task  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "gecko_gait.toml"
TARGET = 0.85  # loop_vs_raw_ratio >= TARGET
QUICK = {
    "generations": 1,
    "popsize": 4,
    "iterations": 1,
    "duration": 0.5,
    "repeats": 1,
    "coevolve_generations": 1,
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--generations", type=int, default=3, help="loop generations")
    parser.add_argument("--popsize", type=int, default=16, help="CMA-ES population size")
    parser.add_argument(
        "--iterations", type=int, default=4, help="CMA-ES iterations per generation"
    )
    parser.add_argument("--duration", type=float, default=15.0, help="simulated seconds")
    parser.add_argument(
        "--workers", type=int, default=None, help="loop worker processes (default: one per CPU)"
    )
    parser.add_argument("--repeats", type=int, default=3, help="timed rounds")
    parser.add_argument(
        "--coevolve-generations",
        type=int,
        default=2,
        help="generations of the co-evolution rows (ga, map_elites, novelty, map_elites_cvt;"
        " _optimizer_rows.py)",
    )
    parser.add_argument("--seed", type=int, default=3, help="experiment seed (the config's: 3)")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    check_at_least(parser, args, 1, "generations", "iterations", "repeats", "coevolve_generations")
    check_at_least(parser, args, 2, "popsize")
    check_at_least(parser, args, 1, "workers")
    check_seconds(parser, args, "duration")
    check_seed(parser, args)
    return args


def experiment_config(args: argparse.Namespace) -> ExperimentConfig:
    return load_config(
        CONFIG,
        [
            f"seed={args.seed}",
            f"generations={args.generations}",
            f"brain.popsize={args.popsize}",
            f"brain.iterations={args.iterations}",
            f"task.duration={args.duration!r}",
            'executor.kind="local"',
            "record.rerun=false",  # recordings: experiments/benchmarks/recording.py
        ],
    )


# --------------------------------------------------------------------------------------------
# The loop, with its process pool started outside the timed region
# --------------------------------------------------------------------------------------------


def worker_pid() -> int:
    """Runs in a pool worker: its process id (held briefly, so each call finds a new worker)."""
    time.sleep(0.05)
    return os.getpid()


def started_pool(workers: int | None) -> tuple[cf.Executor, float]:
    """``make_executor("local", workers=workers)`` with every worker process up, and seconds.

    The pool starts a worker per submitted call while none is idle: calls that each hold their
    worker a moment are submitted until every one of the pool's processes has answered.
    """
    count = workers or default_workers()
    start = time.perf_counter()
    executor = ariel.evaluation.make_executor("local", workers=workers)
    seen: set[int] = set()
    while len(seen) < count:
        seen.update(f.result() for f in [executor.submit(worker_pid) for _ in range(count)])
    return executor, time.perf_counter() - start


@contextlib.contextmanager
def prestarted_executor(executor: cf.Executor, workers: int | None) -> Iterator[None]:
    """While open, the loop's ``make_executor("local", workers=workers)`` returns ``executor``.

    Raises if the loop does not ask for it exactly once with that kind and workers: then the
    benchmark would not be timing what it says.
    """
    from ariel.evaluation.executors import settings_options

    calls: list[tuple[str, dict[str, Any]]] = []

    def factory(kind: Any = "local", **options: Any) -> cf.Executor:
        if not isinstance(kind, str):  # the loop passes its config's [executor] section
            kind, options = kind.kind, settings_options(kind)
        calls.append((kind, options))
        if kind != "local" or options.get("workers") != workers or len(calls) > 1:
            raise RuntimeError(
                f"benchmark: the loop asked for executor {kind!r} with {options} (call "
                f"{len(calls)}); the prestarted pool is local with workers={workers}"
            )
        return executor

    with mock.patch.object(ariel.evaluation, "make_executor", factory):
        yield
    if len(calls) != 1:
        raise RuntimeError(
            "benchmark: run_experiment did not take its executor from "
            "ariel.evaluation.make_executor; the prestarted pool was not used"
        )


def loop_sampler(
    config: ExperimentConfig, workers: int | None, folder: Path, info: dict[str, list[float]]
) -> Callable[[], float]:
    """One timed ``run_experiment`` on a fresh, prestarted pool; returns its seconds.

    Appends per-sample context to ``info``: pool start-up seconds, and the engine's own time
    (controls + physics, the evaluations' summed ``wall_seconds``) from the run's records.
    """
    expected = config.generations * config.brain.iterations * config.brain.popsize
    runs = iter(range(1_000_000))

    def sample() -> float:
        out = folder / f"run-{next(runs):03d}"
        executor, pool_seconds = started_pool(workers)
        try:
            with prestarted_executor(executor, workers):
                gc.collect()
                start = time.perf_counter()
                result = run_experiment(config, out=out, workers=workers, progress=False)
                seconds = time.perf_counter() - start
        finally:
            executor.shutdown(wait=True)  # already shut down by the loop: a no-op
        if result.status != "finished" or result.evaluations != expected:
            raise RuntimeError(
                f"benchmark: the loop ended {result.status!r} after {result.evaluations} "
                f"evaluations; expected {expected}"
            )
        evaluations = result.load().evaluations
        if len(evaluations) != expected or (evaluations["status"] != "ok").any():
            raise RuntimeError("benchmark: the run's evaluations table is incomplete or failed")
        info.setdefault("pool_start", []).append(pool_seconds)
        info.setdefault("engine", []).append(float(evaluations["wall_seconds"].sum()))
        return seconds

    return sample


# --------------------------------------------------------------------------------------------
# The reference: raw threaded rollouts of precomputed controls
# --------------------------------------------------------------------------------------------


def raw_sampler(
    config: ExperimentConfig, evaluations: int, threads: int, stack: contextlib.ExitStack
) -> Callable[[], float]:
    """Raw ``Rollout(nthread=threads)`` of ``evaluations`` runs in batches of ``popsize``."""
    task = evaluation_task(config, body_spec(config, config.body.genotype))
    built = build(task)
    model = built.model
    nstep = num_steps(task, model)
    period = config.brain.control_period
    popsize = config.brain.popsize
    rng = np.random.default_rng(config.seed)
    calls = math.ceil(nstep / period)
    batches = [  # a few distinct batches, reused in turn (memory: popsize x nstep x nu each)
        control_sequence(
            rng.uniform(built.low, built.high, size=(popsize, calls, model.nu)),
            nstep,
            period,
            config.brain.smoothing,
            built.low,
            built.high,
        )
        for _ in range(min(4, math.ceil(evaluations / popsize)))
    ]
    sizes = [popsize] * (evaluations // popsize) + (
        [evaluations % popsize] if evaluations % popsize else []
    )
    pool = rollout.Rollout(nthread=threads)
    stack.callback(pool.close)
    datas = [mujoco.MjData(model) for _ in range(threads)]
    initial = built.initial_state[None, :]
    states = np.empty((popsize, nstep, initial.shape[1]))

    def sample() -> float:
        mujoco.set_mjcb_control(None)
        start = time.perf_counter()
        for k, size in enumerate(sizes):
            controls = batches[k % len(batches)][:size]
            pool.rollout(model, datas, initial, controls, nstep=nstep, state=states[:size])
        return time.perf_counter() - start

    return sample


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    config = experiment_config(args)
    evaluations = args.generations * args.iterations * args.popsize
    threads = default_workers()
    workers = args.workers or threads
    load_before = load_average()
    print(
        f"ARIEL co-evolution loop benchmark: brain-only gecko ({CONFIG.name}), "
        f"{args.generations} generations x {args.iterations} CMA-ES iterations x popsize "
        f"{args.popsize} = {evaluations} evaluations of {args.duration:g} s simulated"
    )
    print(
        f"mujoco {mujoco.__version__}, numpy {np.__version__}, python "
        f"{platform.python_version()}, {threads} CPUs; loop: local executor, {workers} workers; "
        f"raw: Rollout(nthread={threads}); median of {args.repeats} rounds after a warm-up; "
        f"load average {load_before}"
    )

    info: dict[str, list[float]] = {}
    loop_seconds: list[float] = []
    raw_seconds: list[float] = []
    with (
        tempfile.TemporaryDirectory(prefix="ariel-coevolution-bench-") as tmp,
        contextlib.ExitStack() as stack,
    ):
        raw = raw_sampler(config, evaluations, threads, stack)
        loop = loop_sampler(config, args.workers, Path(tmp), info)
        raw()  # warm-ups, untimed
        first_loop = loop()  # the first run in this process pays its one-time imports
        info.clear()
        for round_ in range(args.repeats):
            order = [(raw, raw_seconds), (loop, loop_seconds)]
            for sample, seconds in order if round_ % 2 == 0 else order[::-1]:
                gc.collect()
                seconds.append(sample())

        def timed_loop(experiment: ExperimentConfig, out: Path) -> float:
            executor, _ = started_pool(args.workers)
            try:
                with prestarted_executor(executor, args.workers):
                    gc.collect()
                    start = time.perf_counter()
                    run_experiment(experiment, out=out, workers=args.workers, progress=False)
                    return time.perf_counter() - start
            finally:
                executor.shutdown(wait=True)

        from _optimizer_rows import optimizer_rows

        optimizers = optimizer_rows(args, args.workers, threads, Path(tmp), timed_loop)
    load_after = load_average()

    loop_rates = [evaluations / s for s in loop_seconds]
    raw_rates = [evaluations / s for s in raw_seconds]
    ratios = [lr / rr for lr, rr in zip(loop_rates, raw_rates)]
    end_to_end = [
        evaluations / (s + p) / rr for s, p, rr in zip(loop_seconds, info["pool_start"], raw_rates)
    ]
    # Share of the loop's worker time spent in the engine's controls + physics, and that time
    # per evaluation (against the reference's physics per evaluation and thread: the same work?)
    busy = [e / (s * workers) for e, s in zip(info["engine"], loop_seconds)]
    # An evaluation's wall_seconds is its batch's time / batch size, on each worker's share of
    # the CPUs (as evaluation_threads gives it): times that share is thread time.
    worker_threads = max(1, threads // workers)
    engine_ms = statistics.median(info["engine"]) * worker_threads / evaluations * 1e3
    raw_thread_ms = statistics.median(raw_seconds) * threads / evaluations * 1e3
    ratio = statistics.median(ratios)
    loop_rate = statistics.median(loop_rates)
    raw_rate = statistics.median(raw_rates)
    first_ratio = evaluations / first_loop / raw_rate

    print()
    print(f"{'figure':<52}{'evals/s':>9}{'ratio':>8}  target")
    print("-" * 82)
    print(
        f"{'raw mujoco.rollout, ' + str(threads) + ' threads (reference)':<52}"
        f"{raw_rate:>9.2f}{1:>8.2f}"
    )
    print(
        f"{'co-evolution loop, run_experiment':<52}{loop_rate:>9.2f}{ratio:>8.3f}  "
        f">= {TARGET:g}  {'ok' if ratio >= TARGET else 'MISSED'}"
    )
    for name, row in optimizers.items():
        print(
            f"{'co-evolution, body optimizer ' + name + ' (' + str(row['evaluations']) + ')':<52}"
            f"{row['loop_evals_per_s']:>9.2f}{row['ratio']:>8.3f}  >= {TARGET:g}  "
            f"{'ok' if row['ratio'] >= TARGET else 'MISSED'}  (raw {row['raw_evals_per_s']:.2f})"
        )
    print(
        f"{'  incl. process-pool start-up (info)':<52}{'':>9}{statistics.median(end_to_end):>8.3f}"
    )
    print(
        f"{'  first run in this process, untimed warm-up (info)':<52}"
        f"{evaluations / first_loop:>9.2f}{first_ratio:>8.3f}"
    )
    print()
    print(
        "per round: "
        + "; ".join(
            f"loop {ls:.2f} s, raw {rs:.2f} s, ratio {r:.3f}"
            for ls, rs, r in zip(loop_seconds, raw_seconds, ratios)
        )
    )
    print(
        f"loop per evaluation: {statistics.median(loop_seconds) / evaluations * 1e3:.1f} ms, raw "
        f"{statistics.median(raw_seconds) / evaluations * 1e3:.1f} ms; pool start-up (excluded) "
        f"{statistics.median(info['pool_start']):.2f} s"
    )
    print(
        f"loop workers: engine controls + physics {engine_ms:.1f} ms per evaluation and thread "
        f"(raw physics {raw_thread_ms:.1f} ms), busy {statistics.median(busy):.0%} "
        f"of the workers' time; load average after {load_after}"
    )

    summary = {
        "loop_vs_raw_ratio": round(ratio, 4),
        **{f"{name}_vs_raw_ratio": round(row["ratio"], 4) for name, row in optimizers.items()},
        **{
            f"{name}_loop_evals_per_s": round(row["loop_evals_per_s"], 3)
            for name, row in optimizers.items()
        },
        **{f"{name}_ratios": row["ratios"] for name, row in optimizers.items()},
        "loop_evals_per_s": round(loop_rate, 3),
        "raw_evals_per_s": round(raw_rate, 3),
        "evaluations": evaluations,
        "threads": threads,
        "workers": workers,
        "end_to_end_ratio": round(statistics.median(end_to_end), 4),
        "ratios": [round(r, 4) for r in ratios],
        "loop_s": [round(s, 3) for s in loop_seconds],
        "raw_s": [round(s, 3) for s in raw_seconds],
        "pool_start_s": round(statistics.median(info["pool_start"]), 3),
        "engine_busy_fraction": round(statistics.median(busy), 4),
        "engine_thread_ms_per_eval": round(engine_ms, 3),
        "raw_thread_ms_per_eval": round(raw_thread_ms, 3),
        "first_run_ratio": round(first_ratio, 4),
        "generations": args.generations,
        "iterations": args.iterations,
        "popsize": args.popsize,
        "duration_s": args.duration,
        "repeats": args.repeats,
        "cpus": os.cpu_count(),
        "mujoco": mujoco.__version__,
        "numpy": np.__version__,
        "loadavg_before": load_before,
        "loadavg_after": load_after,
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
