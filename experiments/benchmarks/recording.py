"""Recording benchmark: what Rerun recordings cost a run, in time and in bytes.

The same experiment runs twice per round, into temporary folders deleted afterwards: with
``record.rerun = false`` and with ``record.rerun = true`` (``record.bodies`` from
``--bodies``, default the config's ``elites``: every generation's evaluations in one
``evaluations.rrd``, a 3D replay of each body's new bests). Default: the default experiment
(``experiments/coevolve_flat.toml``: 10 generations, 8 + 8 bodies, 8 x 6 brain evaluations of
8 simulated seconds = 3,840 evaluations, about 3-4 minutes a run on 2 CPUs) on its ``local``
executor; ``--generations``, ``--population``, ``--offspring``, ``--popsize``,
``--iterations`` and ``--duration`` scale it down. ``--quick`` is a smoke run (one tiny
generation).

What is timed: the whole ``run_experiment`` call, ``time.perf_counter`` around it (config,
folder, pool start-up and shutdown, every evaluation, Parquet tables, checkpoints, and with
recording on every ``.rrd``, ``run.rrd`` and the layouts). Both runs of a round have the same
seed, so they evaluate exactly the same bodies and brains (checked: identical fitness
columns): the difference is the recording. Rounds alternate which run goes first;
``gc.collect()`` runs before each. A tiny untimed run of each kind first pays the process's
one-time imports (rerun's about 0.5 s among them), as a long run pays them once. The overhead
ratio is the median over rounds of (time with recording) / (time without); target <= 1.10.

Bytes (from the recording run's folder): ``evaluations.rrd`` bytes per evaluation (target
<= 10 kB; every evaluation is in it, and a non-elite is nowhere else), the elites' own
recordings (count, bytes each), all ``.rrd`` and all Parquet bytes per evaluation, and the
whole folder, projected to the default run's 3,840 evaluations for a scaled-down run (target
<= 60 MB). The recorder's own cost, in thread CPU time of the driver (`RerunRecorder`
patched in place): non-elite evaluations kept and written per CPU second (target >= 1,000:
a GPU run is not held back by its records) and CPU ms per elite recording.

Prints a table, then as the last line one JSON object with ``recording_overhead_ratio``,
``shared_rrd_bytes_per_eval``, ``recorder_evals_per_cpu_s``,
``projected_default_folder_bytes`` and context.

    python experiments/benchmarks/recording.py [--generations 10] [--population 8]
        [--offspring 8] [--popsize 4] [--iterations 12] [--duration 8] [--bodies elites]
        [--workers N] [--repeats 1] [--seed 1] [--quick]
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
import gc  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402
from unittest import mock  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

import ariel.recording.rerun._generation_rrd as generation_rrd  # noqa: E402
from ariel.evaluation.executors import default_workers  # noqa: E402
from ariel.evolution import ExperimentConfig, load_config, run_experiment  # noqa: E402
from ariel.recording import load_run  # noqa: E402
from ariel.recording.rerun._recorder import RerunRecorder  # noqa: E402
from ariel.recording.store._tables import GENERATION_RECORDING  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "coevolve_flat.toml"
DEFAULT_EVALUATIONS = 3840  # the default experiment's budget
TARGET = 1.10  # recording_overhead_ratio <= TARGET
SHARED_TARGET = 10_000  # bytes of evaluations.rrd per evaluation
FOLDER_TARGET = 60e6  # the default run's folder, bytes
RATE_TARGET = 1_000  # non-elite evaluations the recorder keeps and writes per CPU second
QUICK = {
    "generations": 1,
    "population": 2,
    "offspring": 2,
    "popsize": 3,
    "iterations": 1,
    "duration": 0.5,
    "repeats": 1,
    "executor": "serial",
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_options(parser)
    parser.add_argument("--repeats", type=int, default=1, help="rounds (each: off and on)")
    parser.add_argument("--seed", type=int, default=None, help="default: the config's (1)")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    names = ("generations", "population", "offspring", "iterations", "repeats")
    check_at_least(parser, args, 1, *names)
    check_at_least(parser, args, 2, "popsize")
    check_at_least(parser, args, 1, "workers")
    check_seconds(parser, args, "duration")
    check_seed(parser, args)
    return args


def experiment_config(args: argparse.Namespace, record: bool) -> ExperimentConfig:
    rerun = f"record.rerun={'true' if record else 'false'}"
    return load_config(CONFIG, [rerun, *run_overrides(args)])


def folder_bytes(folder: Path, pattern: str = "*") -> int:
    return sum(p.stat().st_size for p in folder.rglob(pattern) if p.is_file())


class RecorderTimer:
    """Thread CPU seconds the driver spends in the recorder (`RerunRecorder`, patched in
    place): in ``evaluation`` calls that write an elite's own recording, in those that only
    keep an evaluation for its generation's recording, and in writing the generations'
    ``evaluations.rrd`` (``write_generation_recording``). CPU time of the calling thread, so
    the figure is what the recorder costs one core, whatever else runs on the machine."""

    def __init__(self) -> None:
        self.elite: list[float] = []
        self.kept: list[float] = []
        self.generation_files: list[float] = []
        self._evaluation = RerunRecorder.evaluation
        self._generation_file = generation_rrd.write_generation_recording

    def evaluation(self, recorder: Any, *args: Any, **kwargs: Any) -> Path | None:
        start = time.thread_time()
        written = self._evaluation(recorder, *args, **kwargs)
        (self.kept if written is None else self.elite).append(time.thread_time() - start)
        return written

    def generation_file(self, *args: Any, **kwargs: Any) -> Path:
        start = time.thread_time()
        try:
            return self._generation_file(*args, **kwargs)
        finally:
            self.generation_files.append(time.thread_time() - start)

    def patches(self) -> contextlib.ExitStack:
        timer = self
        stack = contextlib.ExitStack()

        def evaluation(recorder: Any, *args: Any, **kwargs: Any) -> Path | None:
            return timer.evaluation(recorder, *args, **kwargs)

        stack.enter_context(mock.patch.object(RerunRecorder, "evaluation", evaluation))
        stack.enter_context(
            mock.patch.object(generation_rrd, "write_generation_recording", self.generation_file)
        )
        return stack


class CpuMeter:
    """CPU seconds of this process and its descendants (the pool's workers) over a block.

    Workers are polled every 0.2 s (psutil) and their last reading kept, since they exit
    before the block ends; this process's own time comes from ``time.process_time``. Unlike
    wall time, CPU time hardly changes with other processes' load on a shared machine.
    None when psutil is missing.
    """

    def __init__(self) -> None:
        try:
            import psutil
        except ImportError:
            self._psutil = None
        else:
            self._psutil = psutil
        self._last: dict[tuple[int, float], float] = {}
        self._stop = threading.Event()
        self.seconds: float | None = None

    def _poll(self) -> None:
        me = self._psutil.Process()
        while True:
            for child in me.children(recursive=True):
                with contextlib.suppress(self._psutil.Error):
                    times = child.cpu_times()
                    self._last[(child.pid, child.create_time())] = times.user + times.system
            if self._stop.wait(0.2):
                return

    def __enter__(self) -> CpuMeter:
        self._start = time.process_time()
        if self._psutil is not None:
            self._thread = threading.Thread(target=self._poll, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        own = time.process_time() - self._start
        if self._psutil is not None:
            self._stop.set()
            self._thread.join()
            self.seconds = own + sum(self._last.values())


def one_run(config: ExperimentConfig, out: Path, workers: int | None) -> dict[str, Any]:
    timer = RecorderTimer()
    gc.collect()
    with timer.patches(), CpuMeter() as cpu:
        start = time.perf_counter()
        result = run_experiment(config, out=out, workers=workers, progress=False)
        seconds = time.perf_counter() - start
    if result.status != "finished":
        raise RuntimeError(f"benchmark: the run ended {result.status!r}")
    run = load_run(out)
    shared = sorted((out / "recordings").glob(f"gen-*/{GENERATION_RECORDING}"))
    own = sorted(
        p for p in (out / "recordings").glob("gen-*/*.rrd") if p.name != GENERATION_RECORDING
    )
    ran = int((run.evaluations["status"] != "error").sum())
    if config.record.rerun and (
        len(shared) != config.generations or len(timer.kept) + len(timer.elite) != ran
    ):
        raise RuntimeError(f"benchmark: {len(shared)} generation recordings, {ran} evaluations")
    return {
        "seconds": seconds,
        "cpu_seconds": cpu.seconds,
        "evaluations": result.evaluations,
        "fitness": run.evaluations.set_index("eval_id")["fitness"].sort_index(),
        "own_rrd": len(own),
        "own_rrd_bytes": sum(p.stat().st_size for p in own),
        "shared_rrd_bytes": sum(p.stat().st_size for p in shared),
        "recorded": ran,
        "timer": timer,
        "run_rrd_bytes": folder_bytes(out, "run.rrd"),
        "blueprint_bytes": folder_bytes(out, "blueprint.rbl"),
        "parquet_bytes": folder_bytes(out, "*.parquet"),
        "folder_bytes": folder_bytes(out),
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    off_config = experiment_config(args, record=False)
    on_config = experiment_config(args, record=True)
    c = on_config
    workers = 1 if c.executor.kind == "serial" else args.workers or default_workers()
    print(
        f"ARIEL recording benchmark: {CONFIG.name}, {c.generations} generations, "
        f"{c.body.population} + {c.body.offspring} bodies, {c.brain.iterations} x popsize "
        f"{c.brain.popsize} brain evaluations of {c.task.duration:g} s at {c.record.rate_hz:g} Hz; "
        f"record.bodies = {c.record.bodies}"
    )
    print(
        f"mujoco {mujoco.__version__}, numpy {np.__version__}, python "
        f"{platform.python_version()}, {default_workers()} CPUs, {c.executor.kind} executor, "
        f"{workers} workers; "
        f"{args.repeats} round(s) of (off, on); load average {load_average()}"
    )
    offs: list[dict[str, Any]] = []
    ons: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="ariel-recording-bench-") as tmp:
        # Warm-up, untimed: a tiny run of each kind pays this process's one-time imports
        # (pycma, pyarrow, networkx; rerun for the recording run: ~0.5 s, once per process).
        tiny = argparse.Namespace(**{**vars(args), **QUICK})
        for record in (False, True):
            one_run(experiment_config(tiny, record), Path(tmp) / f"warm-{record}", None)
        for round_ in range(args.repeats):
            order = [("off", off_config, offs), ("on", on_config, ons)]
            for label, config, samples in order if round_ % 2 == 0 else order[::-1]:
                out = Path(tmp) / f"{label}-{round_}"
                samples.append(one_run(config, out, args.workers))
                print(f"  round {round_ + 1}, recording {label}: {samples[-1]['seconds']:.2f} s")
    load_after = load_average()
    for off, on in zip(offs, ons):
        if not off["fitness"].equals(on["fitness"]):
            raise RuntimeError("benchmark: the runs with and without recording differ")

    ratios = [on["seconds"] / off["seconds"] for off, on in zip(offs, ons)]
    ratio = statistics.median(ratios)
    measured = [(off, on) for off, on in zip(offs, ons) if off["cpu_seconds"] and on["cpu_seconds"]]
    cpu_ratio = (
        statistics.median(on["cpu_seconds"] / off["cpu_seconds"] for off, on in measured)
        if measured
        else None
    )
    last = ons[-1]
    evaluations = last["evaluations"]
    rrd_per_eval = (last["own_rrd_bytes"] + last["shared_rrd_bytes"]) / evaluations
    shared_per_eval = last["shared_rrd_bytes"] / max(last["recorded"], 1)
    elite_bytes = last["own_rrd_bytes"] / max(last["own_rrd"], 1)
    parquet_per_eval = last["parquet_bytes"] / evaluations
    kept = [x for on in ons for x in on["timer"].kept]
    files = [x for on in ons for x in on["timer"].generation_files]
    elite_s = [x for on in ons for x in on["timer"].elite]
    # Non-elite evaluations per CPU second of the recorder: keeping them, then writing them.
    recorder_rate = len(kept) / (sum(kept) + sum(files)) if kept else math.inf
    elite_ms = statistics.median(elite_s) * 1e3 if elite_s else 0.0
    projected = last["folder_bytes"] / evaluations * DEFAULT_EVALUATIONS
    off_seconds = statistics.median(o["seconds"] for o in offs)
    on_seconds = statistics.median(o["seconds"] for o in ons)

    def row(label: str, value: str, target: str = "", ok: bool | None = None) -> None:
        verdict = "" if ok is None else ("ok" if ok else "MISSED")
        print(f"{label:<52}{value:>16}  {target} {verdict}".rstrip())

    print()
    print(f"{'figure':<52}{'value':>16}  target")
    print("-" * 78)
    row("run without recording (median)", f"{off_seconds:.2f} s")
    row("run with recording (median)", f"{on_seconds:.2f} s")
    row("recording_overhead_ratio (on / off)", f"{ratio:.3f}", f"<= {TARGET:g}", ratio <= TARGET)
    if cpu_ratio is not None:
        row("  CPU time ratio, driver + workers (on / off)", f"{cpu_ratio:.3f}")
    row(
        "evaluations.rrd bytes per evaluation (non-elite)",
        f"{shared_per_eval:,.0f}",
        f"<= {SHARED_TARGET:,}",
        shared_per_eval <= SHARED_TARGET,
    )
    row(f"own recordings (3D replays): {last['own_rrd']}, bytes each", f"{elite_bytes:,.0f}")
    row(".rrd bytes per evaluation, all", f"{rrd_per_eval:,.0f}")
    row("Parquet bytes per evaluation (all tables)", f"{parquet_per_eval:,.0f}")
    row("run.rrd + blueprints bytes", f"{last['run_rrd_bytes'] + last['blueprint_bytes']:,}")
    row(f"run folder bytes ({evaluations} evaluations)", f"{last['folder_bytes']:,}")
    row(
        f"  projected to {DEFAULT_EVALUATIONS} evaluations",
        f"{projected:,.0f}",
        f"<= {FOLDER_TARGET / 1e6:g} MB",
        projected <= FOLDER_TARGET,
    )
    row(
        "recorder: non-elite evaluations per CPU second",
        f"{recorder_rate:,.0f}",
        f">= {RATE_TARGET:,}",
        recorder_rate >= RATE_TARGET,
    )
    row("recorder: CPU ms per elite recording (median)", f"{elite_ms:.2f} ms")
    print()
    print(
        "per round: "
        + "; ".join(
            f"off {o['seconds']:.2f} s, on {n['seconds']:.2f} s, ratio {r:.3f}"
            + (
                f" (CPU {o['cpu_seconds']:.1f} / {n['cpu_seconds']:.1f} s)"
                if o["cpu_seconds"] and n["cpu_seconds"]
                else ""
            )
            for o, n, r in zip(offs, ons, ratios)
        )
    )
    print(f"load average after {load_after}")

    summary = {
        "recording_overhead_ratio": round(ratio, 4),
        "recording_cpu_ratio": None if cpu_ratio is None else round(cpu_ratio, 4),
        "rrd_bytes_per_eval": round(rrd_per_eval, 1),
        "shared_rrd_bytes_per_eval": round(shared_per_eval, 1),
        "own_recordings": last["own_rrd"],
        "own_recording_bytes": round(elite_bytes),
        "recorder_evals_per_cpu_s": round(recorder_rate, 1),
        "elite_recording_cpu_ms": round(elite_ms, 3),
        "parquet_bytes_per_eval": round(parquet_per_eval, 1),
        "evaluations": evaluations,
        "off_s": [round(o["seconds"], 3) for o in offs],
        "on_s": [round(o["seconds"], 3) for o in ons],
        "off_cpu_s": [o["cpu_seconds"] and round(o["cpu_seconds"], 2) for o in offs],
        "on_cpu_s": [o["cpu_seconds"] and round(o["cpu_seconds"], 2) for o in ons],
        "ratios": [round(r, 4) for r in ratios],
        "run_rrd_bytes": last["run_rrd_bytes"],
        "blueprint_bytes": last["blueprint_bytes"],
        "folder_bytes": last["folder_bytes"],
        "folder_bytes_off": offs[-1]["folder_bytes"],
        "projected_default_folder_bytes": round(projected),
        "bodies": c.record.bodies,
        "generations": c.generations,
        "population": c.body.population,
        "offspring": c.body.offspring,
        "popsize": c.brain.popsize,
        "iterations": c.brain.iterations,
        "duration_s": c.task.duration,
        "rate_hz": c.record.rate_hz,
        "executor": c.executor.kind,
        "workers": workers,
        "repeats": args.repeats,
        "cpus": os.cpu_count(),
        "mujoco": mujoco.__version__,
        "loadavg_after": load_after,
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
