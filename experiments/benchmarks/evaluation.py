"""Evaluation speed benchmark: the engine's paths against raw MuJoCo stepping, in one run.

The gecko on ``SimpleFlatWorld`` for ``--duration`` simulated seconds (15 s = 7,500 steps at
0.002 s). Every figure is the best (minimum) of ``--repeats`` wall times (``time.perf_counter``)
after one untimed warm-up; the figures are sampled round robin (one sample of each per round), so
load on a shared machine affects them alike; ``gc.collect()`` runs before every sample, untimed.

1. raw: ``mj_step(model, data, nstep)`` from ``mj_resetData`` (zero ctrl, no callback) on the
   tutorial's compiled model. The reference for the single-evaluation paths. A walking robot
   costs the solver more than a resting one, so a raw rollout of the fast path's own gait is
   reported beside it (``raw_gait_ms``): path / raw gait is the pure overhead.
2. tutorial path: one evaluation the way the quick-start tutorial's ``evaluate()`` does it, with
   the world already built and compiled (built once): ``MjData``, ``Tracker`` + ``setup``,
   ``NaCPG``, ``Controller``, ``set_mjcb_control``, ``simple_runner``, the displacement. All of
   that per-evaluation work is timed (it is what a tutorial user pays per candidate); the
   ``simple_runner`` call alone is reported beside it. The CPG gets the fast path's parameters
   and initial state, so both paths walk the same gait (checked and printed).
3. fast path: ``evaluate(task)`` for one NaCPG candidate on the prebuilt gecko, the model
   already compiled and cached by ``build(task)``, default recording options.
4. batch: ``evaluate_batch(tasks, nthread=threads)`` for ``--batch`` candidates, per evaluation,
   against a raw threaded ``mujoco.rollout`` of the same control sequences (computed outside the
   timed region, as the engine computes them) on the same number of threads. With
   ``--batch-seeds shared`` (default) every candidate has the same evaluation seed (one CMA-ES
   generation of one body: the CPGs start from the same state), and the engine computes all
   CPGs in one vectorised pass; with ``distinct`` each has its own seed, which the engine
   currently computes one candidate at a time.
5. build: genotype -> compiled model for a 20-module NDE body (``build(task)``), a fresh random
   genotype per sample so the build cache never hits; the one-time NDE weight creation is
   excluded by a warm-up build. The same for 20-module ``tree`` and ``cppn`` bodies
   (``build_tree_ms``, ``build_cppn_ms``).

Prints a table, then as the last line one JSON object with ``tutorial_path_ratio``,
``fast_path_ratio``, ``batch_ratio``, ``build_ms`` and context (raw_ms, threads, versions, load).

    python experiments/benchmarks/evaluation.py [--repeats 5] [--duration 15] [--batch 32]
        [--threads N] [--genotypes 20] [--seed 0] [--batch-seeds shared|distinct]
"""

from __future__ import annotations

from _common import check_at_least, check_seconds, load_average, one_blas_thread

# BLAS/OpenMP pools must be sized before numpy (or torch) is first imported: they read these
# variables once, at load (see `one_blas_thread`).
one_blas_thread()

# The imports below must see the variables above, hence after code.
import argparse  # noqa: E402
import contextlib  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from typing import Any  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from mujoco import rollout  # noqa: E402

from ariel.body_phenotypes.robogen_lite.cppn_encoder import CPPNEncoder  # noqa: E402
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko  # noqa: E402
from ariel.ec.genotypes.tree.operators import random_tree  # noqa: E402
from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate, evaluate_batch  # noqa: E402
from ariel.evaluation._engine import control_sequence, num_steps  # noqa: E402
from ariel.evaluation.builtin_plugins import NaCPGController  # noqa: E402
from ariel.simulation.controllers.controller import Controller  # noqa: E402
from ariel.simulation.controllers.na_cpg import (  # noqa: E402
    NaCPG,
    create_fully_connected_adjacency,
)
from ariel.simulation.environments import SimpleFlatWorld  # noqa: E402
from ariel.utils.runners import simple_runner  # noqa: E402
from ariel.utils.tracker import Tracker  # noqa: E402

TARGETS = {  # name -> upper bound (ratios, except build in ms)
    "tutorial_path_ratio": 1.6,
    "fast_path_ratio": 1.1,
    "batch_ratio": 1.15,
    "build_ms": 12.0,
    "build_tree_ms": 12.0,
    "build_cppn_ms": 12.0,
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed samples per figure")
    parser.add_argument("--duration", type=float, default=15.0, help="simulated seconds")
    parser.add_argument("--batch", type=int, default=32, help="candidates in the batch")
    parser.add_argument(
        "--threads", type=int, default=os.cpu_count() or 1, help="rollout threads (batch)"
    )
    parser.add_argument("--genotypes", type=int, default=20, help="NDE bodies built (build)")
    parser.add_argument("--seed", type=int, default=0, help="seed of parameters and genotypes")
    parser.add_argument(
        "--batch-seeds",
        choices=("shared", "distinct"),
        default="shared",
        help="evaluation seeds of the batch: all the same, or one per candidate",
    )
    args = parser.parse_args(argv)
    check_at_least(parser, args, 1, "repeats", "batch", "threads", "genotypes")
    check_seconds(parser, args, "duration")
    return args


Sample = Callable[[], dict[str, float]]
"""Runs one evaluation (or batch) and returns its wall times in seconds by part ("total", ...)."""


@dataclass
class Samples:
    """Wall times (seconds) of the timed samples of one figure, by part."""

    parts: dict[str, list[float]] = field(default_factory=dict)

    def add(self, seconds: dict[str, float]) -> None:
        for name, value in seconds.items():
            self.parts.setdefault(name, []).append(value)

    def best(self, part: str = "total") -> float:
        return min(self.parts[part])


def measure_interleaved(samplers: dict[str, Sample], repeats: int) -> dict[str, Samples]:
    """One untimed warm-up of every figure, then ``repeats`` rounds of one sample of each.

    Round robin rather than figure after figure: on a shared machine a burst of load then hits
    every figure alike, instead of inflating whichever figure happened to run during it, which
    would skew the ratios.
    """
    for sample in samplers.values():
        sample()
    results = {name: Samples() for name in samplers}
    for _ in range(repeats):
        for name, sample in samplers.items():
            gc.collect()  # no collection of earlier garbage inside a timed region
            results[name].add(sample())
    return results


def timed(run: Callable[[], Any]) -> dict[str, float]:
    """``{"total": seconds}`` of ``run()``."""
    start = time.perf_counter()
    run()
    return {"total": time.perf_counter() - start}


# --------------------------------------------------------------------------------------------
# The figures: each returns a sampler (plus what the consistency checks need)
# --------------------------------------------------------------------------------------------


def raw_sampler(model: mujoco.MjModel, nstep: int) -> Sample:
    """Plain ``mj_step`` from a reset: zero control, no callback."""
    data = mujoco.MjData(model)

    def sample() -> dict[str, float]:
        mujoco.set_mjcb_control(None)
        mujoco.mj_resetData(model, data)  # also zeroes ctrl
        return timed(lambda: mujoco.mj_step(model, data, nstep=nstep))

    return sample


def tutorial_evaluation(
    world: Any, model: mujoco.MjModel, params: np.ndarray, state: Any, duration: float
) -> tuple[dict[str, float], mujoco.MjData]:
    """The tutorial's per-evaluation work on an already compiled world, timed by part."""
    start = time.perf_counter()
    data = mujoco.MjData(model)
    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker.setup(world.spec, data)
    cpg = NaCPG(create_fully_connected_adjacency(model.nu), hard_bounds=(-math.pi / 2, math.pi / 2))
    cpg.set_flat_params(params)  # the fast path's candidate, so both paths walk the same gait
    cpg.set_initial_state(*state)
    controller = Controller(
        controller_callback_function=lambda m, d: cpg.forward(time=d.time), tracker=tracker
    )
    mujoco.set_mjcb_control(controller.set_control)
    try:
        runner_start = time.perf_counter()
        simple_runner(model, data, duration=duration)
        runner_end = time.perf_counter()
    finally:
        mujoco.set_mjcb_control(None)
    xpos = tracker.history["xpos"][0]
    float(np.linalg.norm(np.asarray(xpos[-1])[:2] - np.asarray(xpos[0])[:2]))  # the fitness
    end = time.perf_counter()
    return {"total": end - start, "runner": runner_end - runner_start}, data


def tutorial_sampler(
    world: Any, model: mujoco.MjModel, params: np.ndarray, state: Any, duration: float
) -> tuple[Sample, Callable[[], np.ndarray]]:
    """Tutorial-path sampler, and the core's final position of its last run (same-gait check)."""
    last: list[mujoco.MjData] = []

    def sample() -> dict[str, float]:
        seconds, data = tutorial_evaluation(world, model, params, state, duration)
        last[:] = [data]
        return seconds

    def final_core() -> np.ndarray:
        data = last[0]
        mujoco.mj_kinematics(model, data)  # geom_xpos of the final state, as the engine records
        core = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "robot1_core")
        return data.geom_xpos[core].copy()

    return sample, final_core


def engine_sampler(tasks: list[EvaluationTask], nthread: int | None) -> tuple[Sample, list[Any]]:
    """``evaluate(task)`` (one task, ``nthread`` None) or ``evaluate_batch``, body prebuilt.

    The list returned fills with the results of the latest sample.
    """
    build(tasks[0])  # compiled and cached outside the timed region
    results: list[Any] = []

    def sample() -> dict[str, float]:
        start = time.perf_counter()
        out = [evaluate(tasks[0])] if nthread is None else evaluate_batch(tasks, nthread=nthread)
        total = time.perf_counter() - start
        results[:] = out
        return {"total": total, "engine": sum(r.wall_time for r in out)}

    return sample, results


def engine_controls(tasks: list[EvaluationTask], built: Any) -> np.ndarray:
    """Per-step controls ``(B, nstep, nu)`` of ``tasks``, computed as the engine computes them."""
    head = tasks[0]
    model = built.model
    nstep = num_steps(head, model)
    call_times = np.arange(0, nstep, head.control_period) * model.opt.timestep
    smoothing = float(head.controller_options.get("smoothing", 0.5))
    controller = NaCPGController()
    params = np.array([t.params for t in tasks])
    seeds = np.array([t.seed for t in tasks])
    targets = np.empty((len(tasks), call_times.size, model.nu))
    for seed in np.unique(seeds):
        rows = np.flatnonzero(seeds == seed)
        targets[rows] = controller.targets(params[rows], call_times, model, seed=int(seed))
    return control_sequence(targets, nstep, head.control_period, smoothing, built.low, built.high)


def rollout_sampler(
    built: Any, controls: np.ndarray, nthread: int, stack: contextlib.ExitStack
) -> tuple[Sample, Callable[[], np.ndarray]]:
    """A raw threaded rollout of precomputed controls (the physics alone), whole batch.

    Also gives the final actuated joint angles ``(B, nu)`` of the latest sample. The thread
    pool lives until ``stack`` closes.
    """
    model = built.model
    nthread = max(1, min(nthread, controls.shape[0]))  # as the engine caps it
    datas = [mujoco.MjData(model) for _ in range(nthread)]
    state = built.initial_state[None, :]
    nstep = controls.shape[1]
    pool = rollout.Rollout(nthread=nthread)
    stack.callback(pool.close)
    outputs: list[np.ndarray] = []

    def run() -> None:
        states, _ = pool.rollout(model, datas, state, controls, nstep=nstep)
        outputs[:] = [states]

    def sample() -> dict[str, float]:
        mujoco.set_mjcb_control(None)
        return timed(run)

    def final_angles() -> np.ndarray:
        return outputs[0][:, -1, 1 + built.joint_qpos]  # FULLPHYSICS state: time, qpos, ...

    return sample, final_angles


# Per body encoder: its options for 20-module bodies and a fresh random genotype.
BUILD_BODIES: dict[str, tuple[dict, Callable[[np.random.Generator], object]]] = {
    "nde": ({"number_of_modules": 20}, lambda rng: rng.random((3, 64))),
    "tree": ({"max_modules": 20}, lambda rng: random_tree(20, rng=rng).to_dict()),
    "cppn": (
        {"max_modules": 20},
        lambda rng: CPPNEncoder(max_modules=20).random_genotype(rng),
    ),
}


def bench_build(
    args: argparse.Namespace, rng: np.random.Generator, encoder: str = "nde"
) -> tuple[list[float], list]:
    """``build`` of fresh 20-module bodies of ``encoder``: per-genotype seconds and modules."""
    options, random_genotype = BUILD_BODIES[encoder]

    def task_for(genotype: object) -> EvaluationTask:
        body = BodySpec(encoder, genotype, options)
        return EvaluationTask(body=body, duration=args.duration)

    build(task_for(random_genotype(rng)))  # warm-up: NDE weights (torch) and imports, once
    limit_torch_threads()
    seconds: list[float] = []
    modules: list[int] = []
    for _ in range(args.genotypes):
        task = task_for(random_genotype(rng))  # a new genotype: the build cache cannot hit
        gc.collect()
        start = time.perf_counter()
        built = build(task)
        seconds.append(time.perf_counter() - start)
        modules.append(int(built.descriptors.get("num_modules", -1)))
    return seconds, modules


def limit_torch_threads() -> None:
    """One intra-op thread for torch, if it is loaded (same reason as the variables above)."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def verdict(name: str, value: float) -> str:
    target = TARGETS[name]
    return f"<= {target:g}  {'ok' if value <= target else 'MISSED'}"


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    limit_torch_threads()  # na_cpg imports torch
    load_before = load_average()
    rng = np.random.default_rng(args.seed)

    # One compiled tutorial world (built once, outside every timed region).
    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    robot = gecko()
    world.spawn(robot.spec, position=[0, 0, 0])
    model = world.spec.compile()
    nstep = round(args.duration / model.opt.timestep)

    controller = NaCPGController()
    body = BodySpec("prebuilt", "gecko")
    single = EvaluationTask(
        body=body,
        params=controller.random_parameters(model, rng, 1)[0],
        duration=args.duration,
        seed=args.seed,
        eval_id="single",
    )
    built = build(single)
    batch = [
        EvaluationTask(
            body=body,
            params=p,
            duration=args.duration,
            seed=args.seed + 1 + (i if args.batch_seeds == "distinct" else 0),
            eval_id=f"b{i}",
        )
        for i, p in enumerate(controller.random_parameters(model, rng, args.batch))
    ]

    print(
        f"ARIEL evaluation benchmark: gecko on SimpleFlatWorld, {args.duration:g} s simulated "
        f"({nstep} steps of {model.opt.timestep:g} s), best of {args.repeats} after a warm-up"
    )
    print(
        f"mujoco {mujoco.__version__}, numpy {np.__version__}, python {platform.python_version()}"
        f", {os.cpu_count()} CPUs, batch {args.batch} ({args.batch_seeds} seeds) on "
        f"{args.threads} threads, "
        f"load average {load_before}"
    )

    state = controller.initial_state(built.model, single.seed)
    single_params = np.asarray(single.params)
    batch_controls = engine_controls(batch, built)
    with contextlib.ExitStack() as stack:
        tutorial_sample, tutorial_core = tutorial_sampler(
            world, model, single_params, state, args.duration
        )
        fast_sample, fast_results = engine_sampler([single], None)
        gait_sample, _ = rollout_sampler(built, engine_controls([single], built), 1, stack)
        reference_sample, final_angles = rollout_sampler(built, batch_controls, args.threads, stack)
        batch_sample, batch_results = engine_sampler(batch, args.threads)
        samples = measure_interleaved(
            {
                "raw": raw_sampler(model, nstep),
                "tutorial": tutorial_sample,
                "fast": fast_sample,
                "gait": gait_sample,
                "reference": reference_sample,
                "batch": batch_sample,
            },
            args.repeats,
        )
        final = final_angles()
    raw, tutorial, fast = samples["raw"], samples["tutorial"], samples["fast"]
    gait, reference, batched = samples["gait"], samples["reference"], samples["batch"]
    fast_result = fast_results[0]
    build_seconds, modules = bench_build(args, rng)
    other_builds = {name: bench_build(args, rng, name) for name in ("tree", "cppn")}
    load_after = load_average()

    raw_ms = raw.best() * 1e3
    tutorial_ms = tutorial.best() * 1e3
    fast_ms = fast.best() * 1e3
    gait_ms = gait.best() * 1e3
    batch_ms = batched.best() * 1e3 / args.batch
    reference_ms = reference.best() * 1e3 / args.batch
    build_ms = statistics.median(build_seconds) * 1e3
    ratios = {
        "tutorial_path_ratio": tutorial_ms / raw_ms,
        "fast_path_ratio": fast_ms / raw_ms,
        "batch_ratio": batch_ms / reference_ms,
    }

    rows = [
        ("raw mj_step (zero ctrl, reference)", raw_ms, "1.00", ""),
        (
            "tutorial path, whole evaluation",
            tutorial_ms,
            f"{ratios['tutorial_path_ratio']:.2f}",
            verdict("tutorial_path_ratio", ratios["tutorial_path_ratio"]),
        ),
        ("  of which simple_runner", tutorial.best("runner") * 1e3, "", ""),
        (
            "fast path evaluate(task)",
            fast_ms,
            f"{ratios['fast_path_ratio']:.2f}",
            verdict("fast_path_ratio", ratios["fast_path_ratio"]),
        ),
        ("  of which controls + physics", fast.best("engine") * 1e3, "", ""),
        ("raw rollout of the same gait, 1 thread", gait_ms, f"{gait_ms / raw_ms:.2f}", "(info)"),
        ("  tutorial path / raw gait", tutorial_ms, f"{tutorial_ms / gait_ms:.2f}", "(info)"),
        ("  fast path / raw gait", fast_ms, f"{fast_ms / gait_ms:.2f}", "(info)"),
        (f"raw rollout, {args.batch} evals, per eval", reference_ms, "1.00", "batch reference"),
        (
            f"evaluate_batch, {args.batch} evals, per eval",
            batch_ms,
            f"{ratios['batch_ratio']:.2f}",
            verdict("batch_ratio", ratios["batch_ratio"]),
        ),
        ("  of which controls + physics", batched.best("engine") * 1e3 / args.batch, "", ""),
        ("  batch per eval / raw mj_step", batch_ms, f"{batch_ms / raw_ms:.2f}", "(info)"),
    ]
    print()
    print(f"{'figure':<44}{'ms':>9}{'ratio':>8}  target")
    print("-" * 78)
    for label, ms, ratio, note in rows:
        print(f"{label:<44}{ms:>9.2f}{ratio:>8}  {note}")
    print(
        f"{'build, 20-module NDE body (median)':<44}{build_ms:>9.2f}{'':>8}  "
        f"{verdict('build_ms', build_ms)}"
    )
    print(
        f"  min {min(build_seconds) * 1e3:.2f} ms, max {max(build_seconds) * 1e3:.2f} ms over "
        f"{len(build_seconds)} genotypes; modules per body: min {min(modules)}, median "
        f"{statistics.median(modules):g}, max {max(modules)}"
    )
    for name, (secs, mods) in other_builds.items():
        ms = statistics.median(secs) * 1e3
        label = f"build, 20-module {name} body (median)"
        print(f"{label:<44}{ms:>9.2f}{'':>8}  {verdict(f'build_{name}_ms', ms)}")
        print(f"  min {min(secs) * 1e3:.2f} ms, max {max(secs) * 1e3:.2f} ms; modules {min(mods)}")

    # Same work on both sides? The tutorial and fast paths should walk the same gait, and the
    # batch reference should reproduce the engine's final joint angles.
    gait_diff = float(np.max(np.abs(tutorial_core() - fast_result.core_pos[-1])))
    angle_diff = max(
        float(np.max(np.abs(final[b] - r.joint_angle[-1]))) for b, r in enumerate(batch_results)
    )
    statuses = sorted({r.status for r in [fast_result, *batch_results]})
    print()
    print(f"tutorial vs fast path, final core position: max |diff| {gait_diff:.3g} m")
    print(f"batch reference vs engine, final joint angles: max |diff| {angle_diff:.3g} rad")
    print(f"statuses: {', '.join(statuses)}; load average after: {load_after}")

    summary = {
        **{k: round(v, 4) for k, v in ratios.items()},
        "build_ms": round(build_ms, 3),
        "raw_ms": round(raw_ms, 3),
        "tutorial_ms": round(tutorial_ms, 3),
        "tutorial_runner_ms": round(tutorial.best("runner") * 1e3, 3),
        "fast_ms": round(fast_ms, 3),
        "raw_gait_ms": round(gait_ms, 3),
        "tutorial_vs_gait_ratio": round(tutorial_ms / gait_ms, 4),
        "fast_vs_gait_ratio": round(fast_ms / gait_ms, 4),
        "batch_per_eval_ms": round(batch_ms, 3),
        "raw_rollout_per_eval_ms": round(reference_ms, 3),
        "batch_vs_raw_step_ratio": round(batch_ms / raw_ms, 4),
        "build_min_ms": round(min(build_seconds) * 1e3, 3),
        **{
            f"build_{name}_ms": round(statistics.median(secs) * 1e3, 3)
            for name, (secs, _mods) in other_builds.items()
        },
        "build_modules_median": statistics.median(modules),
        "same_gait_max_diff": gait_diff,
        "duration_s": args.duration,
        "nstep": nstep,
        "repeats": args.repeats,
        "batch": args.batch,
        "batch_seeds": args.batch_seeds,
        "threads": args.threads,
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
