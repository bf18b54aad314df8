"""MuJoCo Warp benchmark: gecko evaluations per second on a device against all CPU cores.

The gecko on the flat world, ``--duration`` simulated seconds (15 s = 7,500 steps of 0.002 s),
NA-CPG brains with random parameters, frames recorded at ``--rate-hz`` (10 Hz), fitness
``xy_displacement``. Three figures, in one process on one machine:

1. warp, per world count in ``--worlds``: one call of ``WarpEvaluator(device).evaluate_batch``
   on that many tasks: the CPG controls on the host (overlapping the device's stepping), the
   stepping, the recorded frames copied back, kinematics, fitness and results. The first call
   of each size is untimed (kernel compilation in a fresh process, graph capture for a new
   world count) and reported; then the best of ``--repeats`` calls.
2. bare, per world count: the same worlds stepping the same controls (uploaded beforehand) with
   the same captured graphs, nothing else: no CPG, no frames, no results. ``warp / bare`` is
   what the evaluator adds to the stepping (the issue's target: within 20 %).
3. cpu: ``mujoco.rollout.Rollout(nthread=T)`` on T = all CPUs this process may use, of
   ``--cpu-evals`` evaluations with the same kind of controls (the engine's CPG, computed outside
   the timed region): the reference. The engine's own ``evaluate_batch`` on T threads (CPG and
   recording included) is reported beside it.

``speedup`` = warp evaluations/s at the largest world count / cpu evaluations/s. The last line of
output is one JSON object: ``gpu_evals_per_s``, ``cpu_evals_per_s``, ``speedup``, ``device``,
``worlds``, ``steps`` and the per-size figures, compile times, threads, versions, load average.

    python experiments/benchmarks/gpu.py [--worlds 1024,4096,16384] [--device cuda|cpu]
        [--duration 15] [--repeats 2] [--cpu-evals 64] [--rate-hz 10] [--seed 0] [--quick]

Without a GPU: ``--device cpu --worlds 16,64 --duration 2`` (Warp's CPU device; slow).
``--quick`` is a smoke run (Warp's CPU device, 2 and 4 worlds of 0.2 s, 4 CPU evaluations).
"""

from __future__ import annotations

from _common import check_at_least, check_seconds, load_average, one_blas_thread

# One BLAS/OpenMP thread, as in the engine's workers, so that library threads do not compete
# with MuJoCo's rollout threads (set before numpy is imported).
one_blas_thread()

import argparse  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from mujoco import rollout  # noqa: E402

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch  # noqa: E402
from ariel.evaluation._engine import (  # noqa: E402
    control_sequence,
    num_steps,
    open_loop_targets,
)
from ariel.evaluation.builtin_plugins import NaCPGController  # noqa: E402
from ariel.evaluation.executors import default_workers  # noqa: E402

GECKO = BodySpec("prebuilt", "gecko")
SEED = 3  # the evaluation seed: every candidate's CPG starts from the same state (one batch)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="1024,4096,16384", help="world counts, e.g. 16,64")
    parser.add_argument("--device", choices=("cuda", "cpu"), default="cuda")
    parser.add_argument("--duration", type=float, default=15.0, help="simulated seconds")
    parser.add_argument("--repeats", type=int, default=2, help="timed calls per world count")
    parser.add_argument("--cpu-evals", type=int, default=64, help="evaluations of the CPU figure")
    parser.add_argument("--rate-hz", type=float, default=10.0, help="recorded frames per second")
    parser.add_argument("--seed", type=int, default=0, help="seeds the random parameters")
    parser.add_argument("--quick", action="store_true", help="smoke run on Warp's CPU device")
    args = parser.parse_args(argv)
    if args.quick:
        args.device, args.worlds, args.duration = "cpu", "2,4", 0.2
        args.repeats, args.cpu_evals = 1, 4
    try:
        args.worlds = [int(w) for w in str(args.worlds).split(",")]
    except ValueError:
        parser.error(f"--worlds must be comma-separated integers, got {args.worlds!r}")
    if not args.worlds or min(args.worlds) < 1:
        parser.error(f"--worlds must be integers >= 1, got {args.worlds}")
    check_at_least(parser, args, 1, "repeats", "cpu_evals")
    check_seconds(parser, args, "duration")
    if not args.rate_hz > 0:
        parser.error(f"--rate-hz must be > 0, got {args.rate_hz}")
    return args


def gecko_tasks(n: int, args: argparse.Namespace) -> list[EvaluationTask]:
    model = build(EvaluationTask(body=GECKO)).model
    rng = np.random.default_rng(args.seed)
    params = NaCPGController().random_parameters(model, rng, n)
    record_every = max(1, round(1.0 / (args.rate_hz * model.opt.timestep)))
    return [
        EvaluationTask(
            body=GECKO,
            params=p,
            duration=args.duration,
            record_every=record_every,
            record_bodies=False,
            seed=SEED,
            eval_id=f"c{i:05d}",
        )
        for i, p in enumerate(params)
    ]


def engine_controls(tasks: list[EvaluationTask]) -> np.ndarray:
    """Per-step controls ``(B, nstep, nu)`` of the tasks, as the CPU engine computes them."""
    built = build(tasks[0])
    model = built.model
    head = tasks[0]
    nstep = num_steps(head, model)
    call_times = np.arange(0, nstep, head.control_period) * model.opt.timestep
    params = np.array([t.params for t in tasks])
    targets = open_loop_targets(NaCPGController(), params, [SEED] * len(tasks), call_times, model)
    period, smoothing = head.control_period, head.smoothing
    return control_sequence(targets, nstep, period, smoothing, built.low, built.high)


def best_of(repeats: int, sample: Any) -> float:
    times = []
    for _ in range(repeats):
        gc.collect()
        times.append(sample())
    return min(times)


def warp_figures(args: argparse.Namespace, worlds: int, evaluator: Any) -> dict[str, Any]:
    """The evaluator on ``worlds`` tasks (first call untimed) and bare stepping of the same."""
    tasks = gecko_tasks(worlds, args)
    start = time.perf_counter()
    results = evaluator.evaluate_batch(tasks)
    first = time.perf_counter() - start
    unstable = sum(r.status != "ok" for r in results)

    def full() -> float:
        start = time.perf_counter()
        evaluator.evaluate_batch(tasks)
        return time.perf_counter() - start

    full_s = best_of(args.repeats, full)
    bare_s = best_of(args.repeats, bare_sampler(evaluator, tasks))
    return {
        "worlds": worlds,
        "evals_per_s": worlds / full_s,
        "bare_evals_per_s": worlds / bare_s,
        "overhead_ratio": full_s / bare_s,
        "steps_per_s": worlds * num_steps(tasks[0], build(tasks[0]).model) / full_s,
        "seconds": full_s,
        "bare_seconds": bare_s,
        "first_call_s": first,
        "not_ok": unstable,
    }


def bare_sampler(evaluator: Any, tasks: list[EvaluationTask]) -> Any:
    """Step the evaluator's worlds with these tasks' controls and its graphs: nothing else."""
    from ariel.evaluation._engine import held_controls
    from ariel.evaluation._warp import warp_modules

    wp, mjw = warp_modules()
    built = build(tasks[0])
    model = built.model
    head = tasks[0]
    nstep, period = num_steps(head, model), head.control_period
    body = evaluator._device_body(head, built)
    call_times = np.arange(0, nstep, period) * model.opt.timestep
    params = np.array([t.params for t in tasks])
    targets = open_loop_targets(NaCPGController(), params, [SEED] * len(tasks), call_times, model)
    held = held_controls(targets, head.smoothing, built.low, built.high)
    with wp.ScopedDevice(evaluator.device):
        worlds = evaluator._worlds(body, len(tasks))
        controls = wp.array(np.ascontiguousarray(held.transpose(1, 0, 2)), dtype=wp.float32)

    def sample() -> float:
        with wp.ScopedDevice(evaluator.device):
            wp.synchronize()
            start = time.perf_counter()
            mjw.reset_data(body.model, worlds.data)
            for call, k in enumerate(range(0, nstep, period)):
                wp.copy(worlds.data.ctrl, controls[call])
                steps = min(period, nstep - k)
                wp.capture_launch(evaluator._graph(worlds, body.model, steps))
            wp.synchronize()
            return time.perf_counter() - start

    return sample


def cpu_figures(args: argparse.Namespace, threads: int) -> dict[str, float]:
    tasks = gecko_tasks(args.cpu_evals, args)
    built = build(tasks[0])
    model = built.model
    controls = engine_controls(tasks)
    nstep = controls.shape[1]
    pool = rollout.Rollout(nthread=threads)
    datas = [mujoco.MjData(model) for _ in range(threads)]
    initial = built.initial_state[None, :]
    states = np.empty((len(tasks), nstep, initial.shape[1]))

    def raw() -> float:
        start = time.perf_counter()
        pool.rollout(model, datas, initial, controls, nstep=nstep, state=states)
        return time.perf_counter() - start

    def engine() -> float:
        start = time.perf_counter()
        evaluate_batch(tasks, nthread=threads)
        return time.perf_counter() - start

    raw(), engine()  # warm-up
    raw_s = best_of(args.repeats, raw)
    engine_s = best_of(args.repeats, engine)
    pool.close()
    return {
        "evals_per_s": len(tasks) / raw_s,
        "engine_evals_per_s": len(tasks) / engine_s,
        "seconds": raw_s,
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    from ariel.evaluation._warp import WarpEvaluator, WarpUnavailableError, warp_modules

    try:
        wp, mjw = warp_modules()
        evaluator = WarpEvaluator(args.device)
    except WarpUnavailableError as exc:
        print(f"gpu.py: {exc}", file=sys.stderr)
        return 2
    threads = default_workers()
    model = build(EvaluationTask(body=GECKO)).model
    nstep = max(1, round(args.duration / model.opt.timestep))
    load_before = load_average()
    device_name = wp.get_device(args.device).name
    print(
        f"MuJoCo Warp benchmark: gecko, flat world, {args.duration:g} s = {nstep} steps, frames at "
        f"{args.rate_hz:g} Hz; warp on {args.device} ({device_name}), worlds {args.worlds}; cpu: "
        f"Rollout(nthread={threads}) of {args.cpu_evals}; best of {args.repeats}; "
        f"load average {load_before}"
    )
    sizes = []
    for worlds in args.worlds:
        figures = warp_figures(args, worlds, evaluator)
        sizes.append(figures)
        print(
            f"warp {worlds:>6} worlds: {figures['evals_per_s']:9.1f} evals/s "
            f"({figures['steps_per_s'] / 1e6:.3f} M steps/s), bare stepping "
            f"{figures['bare_evals_per_s']:9.1f} evals/s, warp/bare "
            f"{figures['overhead_ratio']:.2f}; first call {figures['first_call_s']:.1f} s"
            + (f"; {figures['not_ok']} not ok" if figures["not_ok"] else "")
        )
    cpu = cpu_figures(args, threads)
    print(
        f"cpu  {threads:>6} threads: {cpu['evals_per_s']:9.1f} evals/s (mujoco.rollout), "
        f"engine evaluate_batch {cpu['engine_evals_per_s']:.1f} evals/s"
    )
    largest = max(sizes, key=lambda f: f["worlds"])
    speedup = largest["evals_per_s"] / cpu["evals_per_s"]
    print(f"speedup at {largest['worlds']} worlds: {speedup:.2f}x all {threads} CPU threads")
    summary = {
        "gpu_evals_per_s": largest["evals_per_s"],
        "cpu_evals_per_s": cpu["evals_per_s"],
        "speedup": speedup,
        "device": args.device,
        "device_name": device_name,
        "worlds": args.worlds,
        "steps": nstep,
        "duration": args.duration,
        "rate_hz": args.rate_hz,
        "per_worlds": sizes,
        "first_compile_s": sizes[0]["first_call_s"],
        "cpu_engine_evals_per_s": cpu["engine_evals_per_s"],
        "cpu_evals": args.cpu_evals,
        "threads": threads,
        "repeats": args.repeats,
        "versions": {
            "python": platform.python_version(),
            "mujoco": mujoco.__version__,
            "mujoco_warp": getattr(mjw, "__version__", "?"),
            "warp": wp.config.version,
        },
        "load_average": {"before": load_before, "after": load_average()},
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
