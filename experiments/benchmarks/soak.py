"""Soak benchmark: a long co-evolution run with recording on; speed, memory and file handles.

One run of the default experiment (``experiments/coevolve_flat.toml``: 10 generations of 8 + 8
NDE bodies, 8 x 6 CMA-ES evaluations of 8 simulated seconds each = 3,840 evaluations, Rerun
recordings of every evaluation; 1.5-2 minutes on 2 CPUs) on its ``local`` executor, into a
temporary folder deleted afterwards (or ``--out``). ``--generations``, ``--population``,
``--offspring``, ``--popsize``, ``--iterations`` and ``--duration`` change its size;
``--quick`` is a smoke run (two tiny generations, one worker).

What is watched, and how:

* Throughput per generation (after an untimed tiny serial run that pays the driver's one-time
  imports): the loop's ``Progress.start_generation`` / ``end_generation`` are wrapped to note
  the time (a generation ends after its tables, recordings and checkpoint are written); its
  evaluations are counted in the run's ``evaluations`` table. Generation 0 also
  pays the workers' start-up (about 1 s). A slowdown of the run (records that grow, caches,
  leaks) would show as falling evaluations/s; other load on a shared machine does too, so two
  load-independent figures sit beside it: the CPU time of the driver and its workers per
  evaluation (psutil), and raw ``mujoco.rollout`` evaluations/s of the gecko measured in this
  process just before and just after the run (if the raw rate fell as much, the machine got
  busier, not the run slower). Also the workers' busy share: the evaluations' own time (their
  ``wall_seconds``) over the generation's time x workers; overhead that grew in the driver
  would lower it, slower physics on a busier machine does not.
* Memory: a thread samples the driver and every descendant process (psutil) every
  ``--interval`` seconds: resident memory (RSS), peak RSS (``VmHWM`` from ``/proc``, so peaks
  between samples count), open file descriptors, threads and CPU time. Each generation's end
  also takes a reading. Growth compares the reading at the end of the last generation with the
  one at the end of the first (target: within 10 %), and for the driver also with the one at
  the end of the middle generation (caches that fill up stop growing; a leak does not).
  Workers (the pool's processes; not the forkserver or the resource tracker) are compared pid
  by pid. Target for a worker's peak: under 250 MiB.
* File handles: the driver's open descriptors at the end of the first and last generations
  (target: no growth) and their maximum over the run.

Prints a table per generation and a summary, then as the last line one JSON object with
``evals_per_s_first``, ``evals_per_s_last``, ``driver_rss_growth``, ``worker_rss_max_mib``,
``driver_fds_first``, ``driver_fds_last`` and more.

    python experiments/benchmarks/soak.py [--generations 10] [--population 8] [--offspring 8]
        [--popsize 4] [--iterations 12] [--duration 8] [--bodies all] [--executor local]
        [--workers N] [--seed 1] [--interval 1.0] [--out DIR] [--quick]
"""

from __future__ import annotations

from _common import (
    add_quick_option,
    add_run_options,
    apply_quick,
    check_at_least,
    check_seconds,
    check_seed,
    load_average,
    one_blas_thread,
    run_overrides,
)

# As the other benchmarks: BLAS/OpenMP pools sized before numpy is imported (the loop's
# workers get the same limits from the executor).
one_blas_thread()

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import TYPE_CHECKING, Any  # noqa: E402
from unittest import mock  # noqa: E402

# The pool's workers import this script (forkserver and spawn load the main module), so it
# imports only the standard library at the top: a worker then holds what a worker of
# `ariel run` holds, and its memory is the figure this benchmark is after. The rest is
# imported where it is used, in the driver only.
if TYPE_CHECKING:
    from ariel.evolution import ExperimentConfig

CONFIG = Path(__file__).resolve().parents[1] / "coevolve_flat.toml"
GROWTH_LIMIT = 0.10  # memory at the end within 10 % of memory after the first generation
WORKER_LIMIT_MIB = 250.0
SLOWDOWN_LIMIT = 0.90  # last generation's evaluations/s at least 90 % of the first's
MIB = 2**20
QUICK = {
    "generations": 2,
    "population": 2,
    "offspring": 2,
    "popsize": 3,
    "iterations": 1,
    "duration": 0.5,
    "workers": 1,
    "interval": 0.2,
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_options(parser)
    parser.add_argument("--seed", type=int, default=None, help="default: the config's (1)")
    parser.add_argument(
        "--interval", type=float, default=1.0, help="seconds between process samples"
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="run folder to keep (default: temporary)"
    )
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    if args.generations is not None and args.generations < 2:
        parser.error(
            f"--generations must be an integer >= 2 (first and last), got {args.generations}"
        )
    check_at_least(parser, args, 1, "population", "offspring", "iterations")
    check_at_least(parser, args, 2, "popsize")
    check_at_least(parser, args, 1, "workers")
    check_seconds(parser, args, "duration", "interval")
    check_seed(parser, args)
    if args.out is not None and args.out.exists():
        parser.error(f"--out {args.out} exists already; give a new folder")
    return args


def experiment_config(args: argparse.Namespace) -> ExperimentConfig:
    from ariel.evolution import load_config

    return load_config(CONFIG, ["record.rerun=true", *run_overrides(args)])


# --------------------------------------------------------------------------------------------
# The process tree: driver and workers
# --------------------------------------------------------------------------------------------


def peak_rss(pid: int) -> int | None:
    """The process's peak resident bytes so far (Linux ``VmHWM``), None where unknown."""
    try:
        with open(f"/proc/{pid}/status") as file:
            for line in file:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


class ProcessSampler:
    """Readings of this process (the driver) and its descendants, now and every ``interval``.

    A descendant is a worker unless it is one of multiprocessing's helpers (the forkserver,
    whose forks are the workers, or the resource tracker), told apart by their command lines.
    """

    def __init__(self, psutil: Any, interval: float) -> None:
        self.psutil = psutil
        self.interval = interval
        self.me = psutil.Process()
        self.roles: dict[int, str] = {}
        self.cpu: dict[tuple[int, float], float] = {}  # last CPU seconds of every process seen
        self.peak: dict[int, float] = {}  # per worker pid: highest RSS or VmHWM seen (bytes)
        self.driver_fds_max = 0
        self.samples = 0
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="soak-sampler", daemon=True)

    def _role(self, process: Any) -> str:
        pid = process.pid
        if pid not in self.roles:
            try:
                command = " ".join(process.cmdline())
                parent = process.ppid()
            except self.psutil.Error:
                return "gone"
            helper = parent == self.me.pid and (
                "forkserver" in command or "resource_tracker" in command
            )
            self.roles[pid] = "helper" if helper else "worker"
        return self.roles[pid]

    def reading(self, files: bool = False) -> dict[str, Any]:
        """One reading of every process: RSS, descriptors, threads; CPU and peaks kept."""
        with self._lock:
            me = self.me
            with me.oneshot():
                times = me.cpu_times()
                driver = {
                    "rss": me.memory_info().rss,
                    "fds": me.num_fds() if hasattr(me, "num_fds") else None,
                    "threads": me.num_threads(),
                }
            if files:
                driver["files"] = len(me.open_files())
            self.cpu[(me.pid, me.create_time())] = times.user + times.system
            self.driver_fds_max = max(self.driver_fds_max, driver["fds"] or 0)
            workers: dict[int, dict[str, Any]] = {}
            for child in me.children(recursive=True):
                with contextlib.suppress(self.psutil.Error):
                    role = self._role(child)
                    with child.oneshot():
                        times = child.cpu_times()
                        rss = child.memory_info().rss
                        fds = child.num_fds() if hasattr(child, "num_fds") else None
                    self.cpu[(child.pid, child.create_time())] = times.user + times.system
                    if role != "worker":
                        continue
                    peak = max(rss, peak_rss(child.pid) or 0, self.peak.get(child.pid, 0))
                    self.peak[child.pid] = peak
                    workers[child.pid] = {"rss": rss, "fds": fds}
            self.samples += 1
            return {
                "time": time.perf_counter(),
                "driver": driver,
                "workers": workers,
                "cpu": sum(self.cpu.values()),
            }

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            with contextlib.suppress(self.psutil.Error):
                self.reading()

    def __enter__(self) -> ProcessSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


class GenerationClock:
    """Wraps the loop's `Progress` hooks: each generation's start and end, with readings."""

    def __init__(self, sampler: ProcessSampler) -> None:
        from ariel.evolution._progress import Progress

        self.progress_class = Progress
        self.sampler = sampler
        self.starts: dict[int, dict[str, Any]] = {}
        self.ends: dict[int, dict[str, Any]] = {}
        self._start = Progress.start_generation
        self._end = Progress.end_generation

    def patches(self) -> contextlib.ExitStack:
        clock, progress_class = self, self.progress_class

        def start_generation(progress: Any, generation: int, *args: Any, **kw: Any) -> Any:
            clock.starts[generation] = clock.sampler.reading()
            return clock._start(progress, generation, *args, **kw)

        def end_generation(progress: Any, generation: int, *args: Any, **kw: Any) -> Any:
            result = clock._end(progress, generation, *args, **kw)
            clock.ends[generation] = clock.sampler.reading(files=True)
            return result

        stack = contextlib.ExitStack()
        for name, wrapper in (
            ("start_generation", start_generation),
            ("end_generation", end_generation),
        ):
            stack.enter_context(mock.patch.object(progress_class, name, wrapper))
        return stack


# --------------------------------------------------------------------------------------------
# The load gauge: raw MuJoCo, before and after
# --------------------------------------------------------------------------------------------


def raw_rate(config: ExperimentConfig, threads: int, batch: int) -> float:
    """Evaluations/s of a raw ``Rollout(nthread=threads)`` of the gecko: random controls shaped
    as the engine's, precomputed; ``batch`` evaluations of the task's duration per call, best
    of three calls."""
    import mujoco
    import numpy as np
    from mujoco import rollout

    from ariel.evaluation import BodySpec, build
    from ariel.evaluation._engine import control_sequence, num_steps
    from ariel.evolution._tasks import evaluation_task

    task = evaluation_task(config, BodySpec("prebuilt", "gecko"))  # the run's world and timing
    built = build(task)
    model = built.model
    nstep = num_steps(task, model)
    period = config.brain.control_period
    rng = np.random.default_rng(0)
    calls = math.ceil(nstep / period)
    targets = rng.uniform(built.low, built.high, size=(batch, calls, model.nu))
    controls = control_sequence(
        targets, nstep, period, config.brain.smoothing, built.low, built.high
    )
    datas = [mujoco.MjData(model) for _ in range(threads)]
    initial = built.initial_state[None, :]
    states = np.empty((batch, nstep, initial.shape[1]))
    best = math.inf
    mujoco.set_mjcb_control(None)
    pool = rollout.Rollout(nthread=threads)
    try:
        for _ in range(3):
            start = time.perf_counter()
            pool.rollout(model, datas, initial, controls, nstep=nstep, state=states)
            best = min(best, time.perf_counter() - start)
    finally:
        pool.close()
    return batch / best


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def growth(first: float, last: float) -> float:
    return last / first - 1.0 if first > 0 else math.nan


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        import psutil
    except ImportError:
        print("soak benchmark: needs psutil (pip install psutil)", file=sys.stderr)
        return 2
    import mujoco
    import numpy as np

    from ariel.evaluation.executors import default_workers
    from ariel.evolution import run_experiment
    from ariel.recording import load_run

    config = experiment_config(args)
    c = config
    workers = 1 if c.executor.kind == "serial" else args.workers or default_workers()
    print(
        f"ARIEL soak benchmark: {CONFIG.name}, {c.generations} generations, "
        f"{c.body.population} + {c.body.offspring} bodies, {c.brain.iterations} x popsize "
        f"{c.brain.popsize} brain evaluations of {c.task.duration:g} s; Rerun recordings on "
        f"(bodies {args.bodies})"
    )
    load_before = load_average()
    print(
        f"mujoco {mujoco.__version__}, numpy {np.__version__}, python "
        f"{platform.python_version()}, {default_workers()} CPUs, {c.executor.kind} executor, "
        f"{workers} workers; samples every {args.interval:g} s; load average {load_before}"
    )
    raw_batch = max(2, c.brain.popsize)
    raw_before = raw_rate(config, workers, raw_batch)

    sampler = ProcessSampler(psutil, args.interval)
    clock = GenerationClock(sampler)
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="ariel-soak-")))
        # Warm-up, untimed: a tiny serial run pays the driver's one-time imports (torch for
        # the NDE, rerun, pyarrow: seconds), which a run of days pays once, not per generation.
        tiny = argparse.Namespace(**{**vars(args), **QUICK, "executor": "serial"})
        run_experiment(experiment_config(tiny), out=tmp / "warm-up", progress=False)
        out = tmp / "run" if args.out is None else args.out
        with sampler, clock.patches():
            start = time.perf_counter()
            result = run_experiment(config, out=out, workers=args.workers, progress=False)
            seconds = time.perf_counter() - start
        if result.status != "finished":
            raise RuntimeError(f"soak benchmark: the run ended {result.status!r}")
        evaluations = load_run(out).evaluations
        folder_bytes = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    raw_after = raw_rate(config, workers, raw_batch)
    load_after = load_average()
    driver_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux

    generations = sorted(clock.ends)
    if generations != list(range(c.generations)) or sorted(clock.starts) != generations:
        raise RuntimeError(f"soak benchmark: saw generations {generations} end")
    counts = evaluations.groupby("generation").size()
    engine_seconds = evaluations.groupby("generation")["wall_seconds"].sum()
    rows = []
    for g in generations:
        begin, end = clock.starts[g], clock.ends[g]
        span = end["time"] - begin["time"]
        n = int(counts.get(g, 0))
        worker_rss = [w["rss"] for w in end["workers"].values()]
        rows.append(
            {
                "generation": g,
                "evaluations": n,
                "seconds": span,
                "evals_per_s": n / span,
                "cpu_ms_per_eval": (end["cpu"] - begin["cpu"]) / n * 1e3 if n else math.nan,
                "busy": float(engine_seconds.get(g, 0.0)) / (span * workers),
                "driver_rss": end["driver"]["rss"],
                "worker_rss_max": max(worker_rss) if worker_rss else 0,
                "driver_fds": end["driver"]["fds"],
                "driver_files": end["driver"]["files"],
                "driver_threads": end["driver"]["threads"],
            }
        )
    first, last = clock.ends[generations[0]], clock.ends[generations[-1]]
    both = sorted(set(first["workers"]) & set(last["workers"]))
    worker_growths = [
        growth(first["workers"][pid]["rss"], last["workers"][pid]["rss"]) for pid in both
    ]
    worker_rss_max = max(sampler.peak.values()) if sampler.peak else 0
    worker_fds = [w["fds"] for r in clock.ends.values() for w in r["workers"].values() if w["fds"]]
    driver_growth = growth(first["driver"]["rss"], last["driver"]["rss"])
    # From the middle generation on: a warm-up (caches filling) stops, a leak goes on.
    middle = clock.ends[generations[len(generations) // 2]]
    driver_growth_late = growth(middle["driver"]["rss"], last["driver"]["rss"])
    worker_growth = max(worker_growths) if worker_growths else math.nan
    fd_growth = (last["driver"]["fds"] or 0) - (first["driver"]["fds"] or 0)
    rate_first, rate_last = rows[0]["evals_per_s"], rows[-1]["evals_per_s"]

    print()
    print(
        f"{'gen':>4}{'evals':>7}{'s':>8}{'evals/s':>9}{'CPU ms/eval':>12}{'busy':>6}"
        f"{'driver MiB':>11}{'worker MiB':>11}{'fds':>5}{'files':>6}{'threads':>8}"
    )
    for r in rows:
        print(
            f"{r['generation']:>4}{r['evaluations']:>7}{r['seconds']:>8.2f}"
            f"{r['evals_per_s']:>9.2f}{r['cpu_ms_per_eval']:>12.1f}{r['busy']:>6.2f}"
            f"{r['driver_rss'] / MIB:>11.1f}{r['worker_rss_max'] / MIB:>11.1f}"
            f"{r['driver_fds']!s:>5}{r['driver_files']:>6}{r['driver_threads']:>8}"
        )

    def verdict(ok: bool) -> str:
        return "ok" if ok else "MISSED"

    print()
    print(f"{'figure':<52}{'value':>14}  target")
    print("-" * 78)
    print(f"{'evaluations (whole run, s)':<52}{result.evaluations:>8} {seconds:>5.1f}")
    print(f"{'evals/s, first generation':<52}{rate_first:>14.2f}")
    ratio = rate_last / rate_first
    print(
        f"{'evals/s, last generation (ratio to first)':<52}{rate_last:>14.2f}  "
        f"{ratio:.3f} >= {SLOWDOWN_LIMIT:g}  {verdict(ratio >= SLOWDOWN_LIMIT)}"
    )
    print(
        f"{'CPU ms per evaluation, first / last generation':<52}"
        f"{rows[0]['cpu_ms_per_eval']:>7.1f} /{rows[-1]['cpu_ms_per_eval']:>5.1f}"
    )
    print(
        f"{'raw mujoco.rollout evals/s, before / after (load)':<52}"
        f"{raw_before:>7.1f} /{raw_after:>5.1f}"
    )
    print(
        f"{'driver RSS after first / last generation (MiB)':<52}"
        f"{first['driver']['rss'] / MIB:>7.1f} /{last['driver']['rss'] / MIB:>5.1f}  "
        f"growth {driver_growth:+.1%} <= {GROWTH_LIMIT:.0%}  "
        f"{verdict(driver_growth <= GROWTH_LIMIT)}"
    )
    print(
        f"{'  the same from generation ' + str(len(generations) // 2):<52}"
        f"{driver_growth_late:>+14.1%}"
    )
    print(f"{'driver peak RSS (MiB)':<52}{driver_peak / MIB:>14.1f}")
    print(
        f"{'worker RSS growth, worst worker':<52}{worker_growth:>+14.1%}  "
        f"<= {GROWTH_LIMIT:.0%}  {verdict(worker_growth <= GROWTH_LIMIT)}"
    )
    print(
        f"{'worker peak RSS, highest (MiB)':<52}{worker_rss_max / MIB:>14.1f}  "
        f"< {WORKER_LIMIT_MIB:g}  {verdict(0 < worker_rss_max / MIB < WORKER_LIMIT_MIB)}"
    )
    print(
        f"{'driver open descriptors, first / last (max)':<52}"
        f"{first['driver']['fds']!s:>7} /{last['driver']['fds']!s:>5} ({sampler.driver_fds_max})"
        f"  no growth  {verdict(fd_growth <= 0)}"
    )
    print(f"{'run folder bytes':<52}{folder_bytes:>14,}")
    print(
        f"worker processes seen: {len(sampler.peak)}; {sampler.samples} readings; "
        f"best {result.best_eval_id} fitness {result.best_fitness!r}; load average after "
        f"{load_after}"
    )

    summary = {
        "evals_per_s_first": round(rate_first, 4),
        "evals_per_s_last": round(rate_last, 4),
        "evals_per_s_ratio": round(ratio, 4),
        "evals_per_s": [round(r["evals_per_s"], 4) for r in rows],
        "busy_first": round(rows[0]["busy"], 4),
        "busy_last": round(rows[-1]["busy"], 4),
        "cpu_ms_per_eval_first": round(rows[0]["cpu_ms_per_eval"], 3),
        "cpu_ms_per_eval_last": round(rows[-1]["cpu_ms_per_eval"], 3),
        "raw_evals_per_s_before": round(raw_before, 3),
        "raw_evals_per_s_after": round(raw_after, 3),
        "driver_rss_first_mib": round(first["driver"]["rss"] / MIB, 2),
        "driver_rss_last_mib": round(last["driver"]["rss"] / MIB, 2),
        "driver_rss_growth": round(driver_growth, 4),
        "driver_rss_growth_late": round(driver_growth_late, 4),
        "driver_rss_peak_mib": round(driver_peak / MIB, 2),
        "driver_rss_mib": [round(r["driver_rss"] / MIB, 2) for r in rows],
        "worker_rss_max_mib": round(worker_rss_max / MIB, 2),
        "worker_rss_growth": None if math.isnan(worker_growth) else round(worker_growth, 4),
        "worker_rss_mib": [round(r["worker_rss_max"] / MIB, 2) for r in rows],
        "workers_seen": len(sampler.peak),
        "driver_fds_first": first["driver"]["fds"],
        "driver_fds_last": last["driver"]["fds"],
        "driver_fds_max": sampler.driver_fds_max,
        "driver_fd_growth": fd_growth,
        "driver_files_last": last["driver"]["files"],
        "driver_threads_first": first["driver"]["threads"],
        "driver_threads_last": last["driver"]["threads"],
        "worker_fds_max": max(worker_fds) if worker_fds else None,
        "evaluations": result.evaluations,
        "seconds": round(seconds, 3),
        "folder_bytes": folder_bytes,
        "best_eval_id": result.best_eval_id,
        "best_fitness": result.best_fitness,
        "samples": sampler.samples,
        "generations": c.generations,
        "population": c.body.population,
        "offspring": c.body.offspring,
        "popsize": c.brain.popsize,
        "iterations": c.brain.iterations,
        "duration_s": c.task.duration,
        "bodies": args.bodies,
        "executor": c.executor.kind,
        "workers": workers,
        "seed": c.seed,
        "cpus": os.cpu_count(),
        "mujoco": mujoco.__version__,
        "loadavg_before": load_before,
        "loadavg_after": load_after,
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
