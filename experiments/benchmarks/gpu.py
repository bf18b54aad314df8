"""MuJoCo Warp benchmark: gecko evaluations per second on a device against all CPU cores.

The gecko on the flat world, ``--duration`` simulated seconds (15 s = 7,500 steps of 0.002 s),
NA-CPG brains with random parameters, frames at ``--rate-hz`` (10 Hz), fitness
``xy_displacement``. Four rows, in one process on one machine; each timed row is the best of
``--repeats`` and has ``ns_per_world_step`` = wall seconds x 1e9 / (worlds x steps):

1. warp, per world count in ``--worlds`` (any count >= 1; 65,536 fits a GPU): one call of
   ``WarpEvaluator(device).evaluate_batch`` on that many tasks: CPG controls on the host
   (overlapping the device's stepping), stepping, frames copied back, kinematics, fitness,
   results. The first call of each size (kernel compilation, graph capture) is untimed and
   reported.
2. bare, per world count: the same worlds stepping the same controls (uploaded beforehand) with
   the same captured graphs, nothing else. ``warp / bare`` is what the evaluator adds to the
   stepping (the issue's target: within 20 %).
3. testspeed, per world count: MuJoCo Warp's own speed test (``mjwarp-testspeed``) on the same
   compiled model (``build(EvaluationTask(body=GECKO)).model``), device, world count, steps and
   contact/constraint buffers: its timing function ``mujoco_warp._src.cli.unroll``, called
   in-process (on Warp's CPU device, which has no streams, a copy of its loop). It times each
   one-step graph launch and synchronize, nothing between. It replays ONE control sequence to
   every world (as ``--replay``; it cannot replay one per world): the first task's held
   controls, per step, with ``noise_std = 0`` and ``noise_rate = 1e-12`` s, so that its noise
   kernel sets ``ctrl`` to them exactly. ``bare / testspeed`` = bare steps/s / testspeed
   steps/s (the issue's target: >= 0.9).
4. cpu: ``mujoco.rollout.Rollout(nthread=T)``, T = all CPUs this process may use, of
   ``--cpu-evals`` evaluations with the engine's CPG controls (computed untimed): the
   reference; beside it the engine's ``evaluate_batch`` on T threads (CPG, recording included).

``speedup`` = warp evaluations/s at the largest world count / cpu evaluations/s. The last line
of output is one JSON object: ``gpu_evals_per_s``, ``cpu_evals_per_s``, ``speedup``,
``bare_over_testspeed`` and ``ns_per_world_step`` per row at the largest world count, the
per-size figures, ``device``, ``worlds``, ``steps``, ``versions`` (python, mujoco,
mujoco_warp, warp, numpy), ``card`` (name, memory, NVIDIA driver: nvidia-smi's, else Warp's;
None on the CPU), ``date``, threads and load average. ``--coevolution KxP`` adds a row of
one generation of K different bodies with P brains each, packed on the device, against the
local executor on all CPU threads (`_coevolution.py`); with ``--coevolution-only`` that row
alone (its JSON: ``coevolution`` and the machine's description).

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
import sys  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _coevolution import coevolution_row, parse_coevolution  # noqa: E402
from _common import best_of, nvidia_card, rates, utc_now, versions  # noqa: E402
from mujoco import rollout  # noqa: E402

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch  # noqa: E402
from ariel.evaluation._engine import (  # noqa: E402
    control_sequence,
    held_controls,
    num_steps,
    open_loop_targets,
)
from ariel.evaluation.builtin_plugins import NaCPGController  # noqa: E402
from ariel.evaluation.executors import default_workers  # noqa: E402

GECKO = BodySpec("prebuilt", "gecko")
SEED = 3  # the evaluation seed: every candidate's CPG starts from the same state (one batch)
# testspeed's control noise off: rate = exp(-timestep / NOISE_RATE) = 0, so ctrl = the replay
TESTSPEED_FLAGS = ("--noise_std=0", "--noise_rate=1e-12")  # and --function=step (mjw.step)
DISTRIBUTIONS = dict(mujoco="mujoco", mujoco_warp="mujoco-warp", warp="warp-lang", numpy="numpy")


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
    parser.add_argument("--coevolution", help="K bodies x P brains packed, e.g. 32x1024")
    parser.add_argument("--coevolution-duration", type=float, default=8.0)
    parser.add_argument("--coevolution-cpu-brains", type=int, default=8)
    parser.add_argument(
        "--coevolution-only", action="store_true", help="only the --coevolution row (no gecko)"
    )
    args = parser.parse_args(argv)
    try:
        args.coevolution = parse_coevolution(args.coevolution)
    except ValueError as exc:
        parser.error(str(exc))
    if args.coevolution_only and not args.coevolution:
        parser.error("--coevolution-only needs --coevolution KxP")
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
    same = {"duration": args.duration, "record_every": record_every, "record_bodies": False}
    return [
        EvaluationTask(body=GECKO, params=p, seed=SEED, eval_id=f"c{i:05d}", **same)
        for i, p in enumerate(params)
    ]


def cpg_targets(tasks: list[EvaluationTask]) -> tuple[np.ndarray, Any, int]:
    """The CPG targets ``(B, calls, nu)`` of the tasks, their built body and their steps."""
    head = tasks[0]
    built = build(head)
    model = built.model
    nstep = num_steps(head, model)
    call_times = np.arange(0, nstep, head.control_period) * model.opt.timestep
    params, seeds = np.array([t.params for t in tasks]), [SEED] * len(tasks)
    return open_loop_targets(NaCPGController(), params, seeds, call_times, model), built, nstep


def engine_controls(tasks: list[EvaluationTask]) -> np.ndarray:
    """Per-step controls ``(B, nstep, nu)`` of the tasks, as the CPU engine computes them."""
    targets, built, nstep = cpg_targets(tasks)
    period, smoothing = tasks[0].control_period, tasks[0].smoothing
    return control_sequence(targets, nstep, period, smoothing, built.low, built.high)


def warp_row(args: argparse.Namespace, tasks: list[EvaluationTask], evaluator: Any) -> dict:
    """The evaluator on the tasks: the first call untimed, then the best of ``--repeats``."""
    start = time.perf_counter()
    results = evaluator.evaluate_batch(tasks)
    first = time.perf_counter() - start

    def full() -> float:
        start = time.perf_counter()
        evaluator.evaluate_batch(tasks)
        return time.perf_counter() - start

    seconds = best_of(args.repeats, full)
    worlds, nstep = len(tasks), num_steps(tasks[0], build(tasks[0]).model)
    return {
        "worlds": worlds,
        **rates("", seconds, worlds, nstep),
        "first_call_s": first,
        "not_ok": sum(r.status != "ok" for r in results),
    }


def bare_row(args: argparse.Namespace, tasks: list[EvaluationTask], evaluator: Any) -> dict:
    """The evaluator's worlds (after warp_row) stepping these tasks' controls with its graphs,
    nothing else; and their ``buffer_sizes`` (nconmax, njmax), for testspeed to use the same."""
    from ariel.evaluation._warp import warp_modules

    wp, mjw = warp_modules()
    targets, built, nstep = cpg_targets(tasks)
    period = tasks[0].control_period
    body = evaluator._lone_body(tasks[0], built)
    held = held_controls(targets, tasks[0].smoothing, built.low, built.high)
    with wp.ScopedDevice(evaluator.device):
        worlds = evaluator._worlds(body, len(tasks))
        own = wp.array(np.ascontiguousarray(held.transpose(1, 0, 2)), dtype=wp.float32)
        shared = np.broadcast_to(held[:1].transpose(1, 0, 2), own.shape)  # task 0's, as testspeed
        same = wp.array(np.ascontiguousarray(shared), dtype=wp.float32)
    controls = own

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

    sample()  # untimed: captures the graphs where the evaluator's steps run in other graphs
    seconds = best_of(args.repeats, sample)
    controls = same  # every world task 0's controls: like for like with testspeed
    same_s = best_of(args.repeats, sample)
    return {
        **rates("bare_", seconds, len(tasks), nstep),
        **rates("bare_same_controls_", same_s, len(tasks), nstep),
        "buffer_sizes": list(worlds.sizes),
    }


def testspeed_row(args: argparse.Namespace, tasks: list[EvaluationTask], sizes: tuple) -> dict:
    """MuJoCo Warp's testspeed on the same model, worlds, steps and buffers (see the docs)."""
    from absl import flags
    from mujoco_warp._src import cli

    from ariel.evaluation._warp import warp_modules

    wp, mjw = warp_modules()
    worlds, ctrls = len(tasks), list(engine_controls(tasks[:1])[0])  # the first task's, per step
    nstep = len(ctrls)
    flags.FLAGS.unparse_flags()
    buffers = (f"--nconmax={sizes[0]}", f"--njmax={sizes[1]}")
    flags.FLAGS(["gpu.py", f"--nworld={worlds}", f"--nstep={nstep}", *buffers, *TESTSPEED_FLAGS])
    flags.FLAGS.device = args.device
    m, d, _, _ = cli.init_structs(mjw.step, build(tasks[0]).model)
    m.opt.warn_overflow = 0  # as testspeed's default (overflows counted below instead)
    unroll = cli.unroll if wp.get_device(args.device).is_cuda else unroll_without_streams
    jit, runs, latencies = [], [], []

    def timed(step: int, trace: dict, latency: float) -> None:
        latencies.append(latency)

    for _ in range(args.repeats):
        gc.collect()
        mjw.reset_data(m, d)
        latencies.clear()
        jit.append(unroll(mjw.step, m, d, None, timed, ctrls))
        runs.append(sum(latencies))
    return {
        **rates("testspeed_", min(runs), worlds, nstep),
        "testspeed_jit_s": jit[0],
        "testspeed_converged": int(np.sum(~np.isnan(d.qpos.numpy()).any(axis=1))),
        "testspeed_overflowed": int(np.count_nonzero(d.overflow.numpy())),
    }


def unroll_without_streams(fn: Any, m: Any, d: Any, rc: Any, callback: Any, ctrls: Any) -> float:
    """``mujoco_warp._src.cli.unroll``'s loop for Warp's CPU device, which has no streams."""
    import warp as wp
    from mujoco_warp._src import cli

    with wp.ScopedDevice(cli.DEVICE.value):
        start = time.perf_counter()
        with wp.ScopedCapture() as capture:
            fn(m, d)
        jit = time.perf_counter() - start
        noise = (cli.NOISE_STD.value, cli.NOISE_RATE.value)
        model_in = [m.opt.timestep, m.actuator_ctrllimited, m.actuator_ctrlrange, d.ctrl]
        for i in range(cli.NSTEP.value):
            center = wp.array(ctrls[i], dtype=wp.float32)
            inputs = [*model_in, center, i, *noise]
            wp.launch(cli._ctrl_noise, dim=(d.nworld, m.nu), inputs=inputs, outputs=[d.ctrl])
            wp.synchronize()
            start = time.perf_counter()
            wp.capture_launch(capture.graph)
            wp.synchronize()
            callback(i, {}, time.perf_counter() - start)
    return jit


def size_row(args: argparse.Namespace, worlds: int, evaluator: Any) -> dict[str, Any]:
    """Every per-world-count row (warp, bare, testspeed) of ``worlds`` worlds, printed."""
    tasks = gecko_tasks(worlds, args)
    row = warp_row(args, tasks, evaluator)
    row |= bare_row(args, tasks, evaluator)
    row |= testspeed_row(args, tasks, tuple(row["buffer_sizes"]))
    row["overhead_ratio"] = row["seconds"] / row["bare_seconds"]  # times: >= 1
    row["warp_over_bare"] = row["bare_seconds"] / row["seconds"]  # evals/s: the 0.9 target
    row["bare_over_testspeed"] = row["bare_steps_per_s"] / row["testspeed_steps_per_s"]
    same = row["bare_same_controls_steps_per_s"]
    row["bare_same_controls_over_testspeed"] = same / row["testspeed_steps_per_s"]
    for label, key in (("warp", ""), ("bare stepping", "bare_"), ("testspeed", "testspeed_")):
        print(
            f"{label:<13} {worlds:>6} worlds: {row[key + 'evals_per_s']:10.1f} evals/s, "
            f"{row[key + 'steps_per_s'] / 1e6:8.3f} M steps/s, "
            f"{row[key + 'ns_per_world_step']:8.1f} ns/world-step"
        )
    print(
        f"{'':<13} {worlds:>6} worlds: warp/bare {row['warp_over_bare']:.2f} (evals/s), "
        f"bare/testspeed {row['bare_over_testspeed']:.2f} (one control sequence for all worlds, as "
        f"testspeed: {row['bare_same_controls_over_testspeed']:.2f}), first call "
        f"{row['first_call_s']:.1f} s" + (f", {row['not_ok']} not ok" if row["not_ok"] else "")
    )
    return row


def cpu_row(args: argparse.Namespace, threads: int) -> dict[str, float]:
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
    cpu = rates("", raw_s, len(tasks), nstep) | rates("engine_", engine_s, len(tasks), nstep)
    print(
        f"cpu  {threads:>6} threads: {cpu['evals_per_s']:9.1f} evals/s (mujoco.rollout, "
        f"{cpu['ns_per_world_step']:.1f} ns/world-step), engine evaluate_batch "
        f"{cpu['engine_evals_per_s']:.1f} evals/s"
    )
    return cpu


def card(wp: Any, device: str) -> dict[str, Any]:
    """The GPU's name, memory and NVIDIA driver: nvidia-smi's, else Warp's; None on the CPU."""
    found = wp.get_device(device)
    if not found.is_cuda:
        return dict.fromkeys(("name", "memory", "driver_version", "source"))
    driver = wp.get_cuda_driver_version()  # Warp knows the CUDA driver API version, e.g. 12040
    return nvidia_card(found.ordinal) or {
        "name": found.name,
        "memory": f"{found.total_memory // 2**20} MiB",
        "driver_version": f"CUDA {driver // 1000}.{driver % 1000 // 10}",
        "source": "warp",
    }


def summary(
    args: argparse.Namespace, sizes: list[dict], cpu: dict, context: dict[str, Any]
) -> dict[str, Any]:
    """The JSON summary: headline figures at the largest world count, then every figure."""
    largest = max(sizes, key=lambda f: f["worlds"])
    return {
        "gpu_evals_per_s": largest["evals_per_s"],
        "cpu_evals_per_s": cpu["evals_per_s"],
        "speedup": largest["evals_per_s"] / cpu["evals_per_s"],
        "bare_over_testspeed": largest["bare_over_testspeed"],
        "ns_per_world_step": {
            "warp": largest["ns_per_world_step"],
            "bare": largest["bare_ns_per_world_step"],
            "testspeed": largest["testspeed_ns_per_world_step"],
            "cpu_rollout": cpu["ns_per_world_step"],
        },
        **{key: getattr(args, key) for key in ("device", "worlds", "duration", "rate_hz")},
        "steps": context["steps"],
        "per_worlds": sizes,
        "first_compile_s": sizes[0]["first_call_s"],
        "testspeed": {
            "timing": "mujoco_warp._src.cli.unroll (cuda) or its loop (cpu), function step",
            "controls": "the first task's held controls, replayed to every world",
            "flags": list(TESTSPEED_FLAGS),
        },
        "cpu_engine_evals_per_s": cpu["engine_evals_per_s"],
        "cpu_engine_ns_per_world_step": cpu["engine_ns_per_world_step"],
        **{key: getattr(args, key) for key in ("cpu_evals", "repeats")},
        "threads": context["threads"],
        **{key: context[key] for key in ("device_name", "card", "versions", "date")},
        "load_average": {"before": context["load_before"], "after": load_average()},
        **context["extra_rows"],
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    from ariel.evaluation._warp import (
        WarpEvaluator,
        WarpUnavailableError,
        cuda_available,
        warp_modules,
    )

    try:
        wp, _ = warp_modules()
        if args.device == "cuda" and not cuda_available():  # in this script's own options
            # (the library's line names a run's config and --set)
            print(
                "gpu.py: error: no CUDA device (no NVIDIA GPU or driver visible to Warp): give "
                "--device cpu for Warp's CPU device (slow), or --quick (a smoke run on it)",
                file=sys.stderr,
            )
            return 2
        evaluator = WarpEvaluator(args.device)
    except WarpUnavailableError as exc:
        print(f"gpu.py: error: {exc}", file=sys.stderr)
        return 2
    model = build(EvaluationTask(body=GECKO)).model
    context: dict[str, Any] = {
        "threads": default_workers(),
        "steps": max(1, round(args.duration / model.opt.timestep)),
        "load_before": load_average(),
        "device_name": wp.get_device(args.device).name,
        "card": card(wp, args.device),
        "versions": versions(**DISTRIBUTIONS),
        "date": utc_now(),
    }
    print(
        f"MuJoCo Warp benchmark: gecko, flat world, {args.duration:g} s = {context['steps']} "
        f"steps, frames at {args.rate_hz:g} Hz; warp, bare and testspeed on {args.device} "
        f"({context['device_name']}; {context['card']['name']}), worlds {args.worlds}; cpu: "
        f"Rollout(nthread={context['threads']}) of {args.cpu_evals}; best of {args.repeats}; "
        f"load average {context['load_before']}"
    )
    if args.coevolution_only:  # the packed row alone, with the machine's description
        row = coevolution_row(args, evaluator, context["threads"])
        keys = ("device_name", "card", "versions", "date", "threads")
        print(json.dumps({"coevolution": row, **{key: context[key] for key in keys}}))
        return 0
    sizes = [size_row(args, worlds, evaluator) for worlds in args.worlds]
    cpu = cpu_row(args, context["threads"])
    context["extra_rows"] = {}
    if args.coevolution:  # packed bodies: experiments/benchmarks/_coevolution.py
        row = coevolution_row(args, evaluator, context["threads"])
        context["extra_rows"]["coevolution"] = row
    result = summary(args, sizes, cpu, context)
    print(
        f"speedup at {max(args.worlds)} worlds: {result['speedup']:.2f}x all "
        f"{context['threads']} CPU threads; bare/testspeed {result['bare_over_testspeed']:.2f}"
    )
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
