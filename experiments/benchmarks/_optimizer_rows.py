"""coevolution.py's co-evolution rows: the loop with each body optimizer (``ga``, ``map_elites``,
``novelty``, ``map_elites_cvt``) against raw ``mujoco.rollout`` of the very evaluations the loop
made.

Each row (`ROWS`: an experiment file and overrides) runs a small co-evolution experiment
(``coevolve_flat.toml`` for the GA, ``qd_flat.toml`` for MAP-Elites, ``novelty_flat.toml`` for
novelty search, ``qd_flat.toml`` with a 64-cell CVT archive over the same measures for
CVT-MAP-Elites; ``--coevolve-generations`` generations, the main options' popsize, iterations
and duration, recordings off) on a prestarted local pool, as the brain-only row does. The
reference then rolls out, for every body the loop evaluated, as many evaluations as the loop
made of it, in batches of ``popsize`` on one ``Rollout(nthread=CPUs)`` pool, with random
controls shaped as the engine shapes them; only the ``rollout`` calls are timed
(compiling the bodies and making the controls are not). The ratio is (loop evaluations/s) /
(reference evaluations/s): what the loop costs over the physics of the same bodies, including
everything a new body costs the loop (decoding and compiling in the driver and a worker, CMA-ES,
shipping, records).
"""

from __future__ import annotations

import gc
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout

from ariel.evaluation import build
from ariel.evaluation._engine import control_sequence, num_steps
from ariel.evolution import ExperimentConfig, load_config
from ariel.evolution._tasks import body_spec, evaluation_task
from ariel.recording import load_run

__all__ = ["optimizer_rows"]

EXPERIMENTS = Path(__file__).resolve().parents[1]
CVT = (
    'body.optimizer_options={ archive = "cvt", cells = 64, '
    'measures = ["num_limbs", "joints_ratio"], ranges = [[0, 8], [0, 1]] }'
)
# Row name -> (experiment file, overrides applied before the benchmark's own). The CVT row is
# qd_flat.toml's MAP-Elites with a CVT archive of 64 cells (its grid: 8 x 8) on its measures.
ROWS: dict[str, tuple[Path, tuple[str, ...]]] = {
    "ga": (EXPERIMENTS / "coevolve_flat.toml", ()),
    "map_elites": (EXPERIMENTS / "qd_flat.toml", ()),
    "novelty": (EXPERIMENTS / "novelty_flat.toml", ()),
    "map_elites_cvt": (EXPERIMENTS / "qd_flat.toml", (CVT,)),
}


def optimizer_config(row: str, args: Any) -> ExperimentConfig:
    path, overrides = ROWS[row]
    return load_config(
        path,
        [
            *overrides,
            f"seed={args.seed}",
            f"generations={args.coevolve_generations}",
            f"brain.popsize={args.popsize}",
            f"brain.iterations={args.iterations}",
            f"task.duration={min(args.duration, 8.0)!r}",
            'executor.kind="local"',
            "record.rerun=false",
        ],
    )


def raw_seconds(config: ExperimentConfig, evaluations: Any, threads: int, seed: int) -> float:
    """Seconds of raw rollouts of as many evaluations of each body as the loop made."""
    rng = np.random.default_rng(seed)
    pool = rollout.Rollout(nthread=threads)
    total = 0.0
    popsize = config.brain.popsize
    try:
        for genotype, count in evaluations.groupby("body_genotype").size().items():
            task = evaluation_task(config, body_spec(config, json.loads(genotype)))
            built = build(task)
            model = built.model
            nstep = num_steps(task, model)
            calls = math.ceil(nstep / config.brain.control_period)
            datas = [mujoco.MjData(model) for _ in range(threads)]
            initial = built.initial_state[None, :]
            for start in range(0, int(count), popsize):
                size = min(popsize, int(count) - start)
                targets = rng.uniform(built.low, built.high, size=(size, calls, model.nu))
                controls = control_sequence(
                    targets,
                    nstep,
                    config.brain.control_period,
                    config.brain.smoothing,
                    built.low,
                    built.high,
                )
                states = np.empty((size, nstep, initial.shape[1]))
                gc.collect()
                begin = time.perf_counter()
                pool.rollout(model, datas, initial, controls, nstep=nstep, state=states)
                total += time.perf_counter() - begin
    finally:
        pool.close()
    return total


def optimizer_rows(
    args: Any,
    workers: int | None,
    threads: int,
    folder: Path,
    timed_loop: Callable[[ExperimentConfig, Path], float],
) -> dict[str, dict[str, Any]]:
    """Per row: loop and raw evaluations/s and their ratio (medians over the rounds), and the
    rounds' ratios."""
    from ariel.plugins import body_encoders

    # Untimed: the NDE's first decode imports torch (once per process; a run pays it once).
    encoder = body_encoders.make("nde", number_of_modules=12)
    encoder.decode(encoder.random_genotype(np.random.default_rng(0)))
    rows = {}
    for optimizer in ROWS:
        config = optimizer_config(optimizer, args)
        ratios, loop_rates, raw_rates = [], [], []
        for round_ in range(args.repeats):
            out = folder / f"{optimizer}-{round_}"
            seconds = timed_loop(config, out)
            evaluations = load_run(out).evaluations
            evaluations = evaluations[evaluations["status"] != "error"]
            reference = raw_seconds(config, evaluations, threads, args.seed + round_)
            loop_rates.append(len(evaluations) / seconds)
            raw_rates.append(len(evaluations) / reference)
            ratios.append(loop_rates[-1] / raw_rates[-1])
        rows[optimizer] = {
            "ratio": float(np.median(ratios)),
            "loop_evals_per_s": float(np.median(loop_rates)),
            "raw_evals_per_s": float(np.median(raw_rates)),
            "evaluations": len(evaluations),
            "ratios": [round(r, 4) for r in ratios],
        }
    return rows
