"""Local pool benchmark: ARIEL's `LocalPool` against CPython's `ProcessPoolExecutor`.

The ``local`` executor is a pool of ARIEL's own (``ariel.evaluation._pool.LocalPool``), written
so that a worker dying or hanging costs only its own call. This checks that it pays nothing for
that in speed, against the pool it replaced: a `concurrent.futures.ProcessPoolExecutor` set up
as ``make_executor("local")`` used to set it up (same ``forkserver`` context, same worker
count, same initializer with the one-thread BLAS environment).

Two workloads, each timed on both pools in every round (the order alternating), after one
untimed warm-up round that also starts every worker:

- ``tiny``: ``--calls`` calls of a function that returns at once (sums 10 random numbers):
  the pool's own cost per call (pickling, pipes, the driver thread, futures).
- ``batch``: ``--batches`` calls of ``evaluate_batch`` on ``--popsize`` evaluations of the
  gecko (NA-CPG, flat world, ``--duration`` simulated seconds), all submitted at once, as the
  co-evolution loop sends a CMA-ES generation.

The ratio of each workload is the median over rounds of (LocalPool calls/s) / (ProcessPool
calls/s) of the same round, so other processes' load hits both sides of a ratio alike; >= 1
means the new pool is not slower. Also reported (LocalPool only): ``recovery_s``, the seconds
from submitting a call whose worker is SIGKILLed mid-call to its result from a fresh worker.

Prints a table, then as the last line one JSON object with ``tiny_ratio``, ``batch_ratio``,
the per-call milliseconds of both pools, ``recovery_s`` and context.

    python experiments/benchmarks/pool.py [--workers N] [--calls 2000] [--batches 8]
        [--popsize 8] [--duration 2] [--repeats 5] [--quick]
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

# As in the other benchmarks: BLAS/OpenMP pools sized before numpy is imported.
one_blas_thread()

import argparse  # noqa: E402
import concurrent.futures as cf  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import os  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from contextlib import nullcontext  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from ariel.evaluation import (  # noqa: E402
    BodySpec,
    EvaluationTask,
    _selftest,
    build,
    evaluate_batch,
)
from ariel.evaluation._executor_local import _initialize_worker  # noqa: E402
from ariel.evaluation._pool import temporary_environ  # noqa: E402
from ariel.evaluation.builtin_plugins import NaCPGController  # noqa: E402
from ariel.evaluation.executors import (  # noqa: E402
    default_workers,
    make_executor,
    worker_environment,
)

QUICK = {"calls": 100, "batches": 2, "popsize": 2, "duration": 0.2, "repeats": 1}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=None, help="default: one per CPU")
    parser.add_argument("--calls", type=int, default=2000, help="tiny calls per round")
    parser.add_argument("--batches", type=int, default=8, help="evaluate_batch calls per round")
    parser.add_argument("--popsize", type=int, default=8, help="evaluations per batch")
    parser.add_argument("--duration", type=float, default=2.0, help="simulated seconds")
    parser.add_argument("--repeats", type=int, default=5, help="timed rounds")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    check_at_least(parser, args, 1, "calls", "batches", "popsize", "repeats", "workers")
    check_seconds(parser, args, "duration")
    return args


def process_pool(workers: int) -> cf.ProcessPoolExecutor:
    """CPython's pool as ``make_executor("local")`` set it up before `LocalPool`."""
    env = worker_environment(1, workers=workers)
    return cf.ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context("forkserver"),
        initializer=_initialize_worker,
        initargs=(env, 1, None, ()),
    )


def worker_pid() -> int:
    """Runs in a worker: its process id, held a moment so that each call finds a new worker."""
    time.sleep(0.05)
    return os.getpid()


def start_workers(executor: cf.Executor, workers: int) -> None:
    """Every worker of the pool up before anything is timed."""
    seen: set[int] = set()
    # ProcessPoolExecutor starts its workers in `submit`, in this thread: give them the same
    # environment as LocalPool's (which sets it itself, on its own thread).
    env = worker_environment(1, workers=workers)
    with temporary_environ(env) if isinstance(executor, cf.ProcessPoolExecutor) else nullcontext():
        while len(seen) < workers:
            seen.update(f.result() for f in [executor.submit(worker_pid) for _ in range(workers)])


def gecko_batches(args: argparse.Namespace) -> list[list[EvaluationTask]]:
    body = BodySpec("prebuilt", "gecko")
    model = build(EvaluationTask(body=body)).model
    rng = np.random.default_rng(0)
    params = NaCPGController().random_parameters(model, rng, args.batches * args.popsize)
    tasks = [
        EvaluationTask(body=body, params=p, duration=args.duration, seed=1, eval_id=f"e{i}")
        for i, p in enumerate(params)
    ]
    return [tasks[i : i + args.popsize] for i in range(0, len(tasks), args.popsize)]


def timed(fn: Callable[..., Any], *args: Any) -> float:
    start = time.perf_counter()
    fn(*args)
    return time.perf_counter() - start


def recovery_seconds(executor: cf.Executor) -> float:
    with tempfile.TemporaryDirectory() as folder:
        marker = str(Path(folder) / "killed")
        start = time.perf_counter()
        executor.submit(_selftest.die_once, marker).result()
        seconds = time.perf_counter() - start
        if not Path(marker).exists():
            raise RuntimeError("benchmark: the worker was not killed; recovery not measured")
    return seconds


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    workers = args.workers or default_workers()
    batches = gecko_batches(args)
    pools = {"LocalPool": make_executor("local", workers=workers), "ProcessPool": None}
    pools["ProcessPool"] = process_pool(workers)
    workloads = {
        "tiny": lambda ex: [
            f.result() for f in [ex.submit(_selftest.seeded_sum, s, 10) for s in range(args.calls)]
        ],
        "batch": lambda ex: [f.result() for f in [ex.submit(evaluate_batch, b) for b in batches]],
    }
    counts = {"tiny": args.calls, "batch": len(batches)}
    seconds: dict[str, dict[str, list[float]]] = {w: {p: [] for p in pools} for w in workloads}
    ratios: dict[str, list[float]] = {w: [] for w in workloads}
    load_before = load_average()
    try:
        for executor in pools.values():
            start_workers(executor, workers)
            for run in workloads.values():  # warm-up: imports, the gecko compiled per worker
                run(executor)
        for round_ in range(args.repeats):
            order = list(pools) if round_ % 2 == 0 else list(reversed(pools))
            for workload, run in workloads.items():
                for name in order:
                    seconds[workload][name].append(timed(run, pools[name]))
                new, old = seconds[workload]["LocalPool"][-1], seconds[workload]["ProcessPool"][-1]
                ratios[workload].append(old / new)  # calls/s of LocalPool over ProcessPool's
        recovery = recovery_seconds(pools["LocalPool"])
    finally:
        for executor in pools.values():
            executor.shutdown()

    def per_call_ms(workload: str, name: str) -> float:
        return round(statistics.median(seconds[workload][name]) / counts[workload] * 1e3, 4)

    print(f"{workers} workers, {args.repeats} rounds (medians)")
    print(f"{'workload':<10}{'LocalPool ms/call':>20}{'ProcessPool ms/call':>22}{'ratio':>8}")
    for workload in workloads:
        print(
            f"{workload:<10}{per_call_ms(workload, 'LocalPool'):>20.4f}"
            f"{per_call_ms(workload, 'ProcessPool'):>22.4f}"
            f"{statistics.median(ratios[workload]):>8.3f}"
        )
    print(f"a worker SIGKILLed mid-call: result from a fresh worker after {recovery:.2f} s")
    summary = {
        "tiny_ratio": round(statistics.median(ratios["tiny"]), 4),
        "batch_ratio": round(statistics.median(ratios["batch"]), 4),
        "tiny_ms_local_pool": per_call_ms("tiny", "LocalPool"),
        "tiny_ms_process_pool": per_call_ms("tiny", "ProcessPool"),
        "batch_ms_local_pool": per_call_ms("batch", "LocalPool"),
        "batch_ms_process_pool": per_call_ms("batch", "ProcessPool"),
        "recovery_s": round(recovery, 4),
        "tiny_ratios": [round(r, 4) for r in ratios["tiny"]],
        "batch_ratios": [round(r, 4) for r in ratios["batch"]],
        "workers": workers,
        "calls": args.calls,
        "batches": len(batches),
        "popsize": args.popsize,
        "duration_s": args.duration,
        "repeats": args.repeats,
        "loadavg_before": load_before,
        "loadavg_after": load_average(),
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
