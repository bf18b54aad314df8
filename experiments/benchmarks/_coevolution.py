"""gpu.py's ``--coevolution KxP`` row: one generation of K different bodies, P brains each.

The bodies are random NDE bodies of the default experiment (up to 12 modules, flat world,
settled for 1 s, NA-CPG brains, ``sustained_displacement``, ``--coevolution-duration`` s), the
brains random. On the device: one `WarpEvaluator.evaluate_batch` of all K x P tasks, which
packs the bodies into ceil(K / 32) models of P worlds (world w: brain w of every body); the
first call (kernel compiles for a new size bucket, packing, graph capture) untimed and
reported. Against it: the ``local`` executor on all CPU threads (one worker process per
thread, each body's brains one batch, as the loop sends them), on ``--coevolution-cpu-brains``
brains per body (timed after a warm-up call). ``speedup`` = device evaluations/s / CPU ones.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ariel.evaluation import BodySpec, EvaluationTask, build, make_executor
from ariel.evaluation.builtin_plugins import NaCPGController

OPTIONS = {"number_of_modules": 12}


def parse_coevolution(text: str | None) -> tuple[int, int] | None:
    """``"32x1024"`` -> (32, 1024); None stays None; ValueError for anything else."""
    if not text:
        return None
    bodies, _, brains = text.lower().partition("x")
    try:
        k, p = int(bodies), int(brains)
    except ValueError:  # "invalid literal for int()" named neither the option nor its form
        raise ValueError(f"--coevolution takes KxP, e.g. 32x1024, not {text!r}") from None
    if k < 2 or p < 1:
        raise ValueError(f"--coevolution needs K >= 2 bodies and P >= 1 brains, got {text!r}")
    return k, p


def generation(bodies: int, brains: int, duration: float, seed: int) -> list[list[EvaluationTask]]:
    """K bodies' brain batches (a list of P tasks per body)."""
    from ariel.plugins import body_encoders

    encoder = body_encoders.make("nde", **OPTIONS)
    rng = np.random.default_rng(seed)
    out = []
    for k in range(bodies):
        body = BodySpec("nde", encoder.random_genotype(rng), OPTIONS)
        task = EvaluationTask(body=body, duration=duration, settle=1.0)
        params = NaCPGController().random_parameters(build(task).model, rng, brains)
        fields = {"fitness": "sustained_displacement", "record_bodies": False}
        out.append(
            [
                EvaluationTask(body=body, params=p, eval_id=f"b{k}-c{c}", duration=duration,
                               settle=1.0, seed=seed + k, **fields)  # type: ignore[arg-type]
                for c, p in enumerate(params)
            ]
        )  # fmt: skip
    return out


def _device(evaluator: Any, batches: list[list[EvaluationTask]], repeats: int) -> dict:
    tasks = [t for batch in batches for t in batch]
    start = time.perf_counter()
    results = evaluator.evaluate_batch(tasks)
    first = time.perf_counter() - start
    print(f"  packed: first call {first:.1f} s (compiles, packing, capture)", flush=True)
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        evaluator.evaluate_batch(tasks)
        best = min(best, time.perf_counter() - start)
    not_ok = sum(r.status != "ok" for r in results)
    return {"seconds": best, "first_call_s": first, "not_ok": not_ok}


def _cpu(batches: list[list[EvaluationTask]], brains: int, threads: int) -> float:
    """Seconds for the local executor to evaluate ``brains`` brains of every body."""
    work = [batch[:brains] for batch in batches]
    with make_executor("local", workers=threads) as executor:
        for _ in range(2):  # the first call starts the workers and builds the bodies
            start = time.perf_counter()
            futures = [executor.submit_batch(batch) for batch in work]
            for future in futures:
                future.result()
            seconds = time.perf_counter() - start
    print(f"  local executor: {seconds:.2f} s for {sum(map(len, work))} evaluations", flush=True)
    return seconds


def coevolution_row(args: Any, evaluator: Any, threads: int) -> dict[str, Any]:
    """The row, printed; ``ns_per_world_step`` counts one robot in one world as a world."""
    bodies, brains = args.coevolution
    batches = generation(bodies, brains, args.coevolution_duration, args.seed)
    steps = round(args.coevolution_duration / build(batches[0][0]).model.opt.timestep)
    device = _device(evaluator, batches, args.repeats)
    cpu_brains = min(brains, args.coevolution_cpu_brains)
    cpu_s = _cpu(batches, cpu_brains, threads)
    evals, cpu_evals = bodies * brains, bodies * cpu_brains
    row = {
        "bodies": bodies,
        "brains": brains,
        "duration": args.coevolution_duration,
        "evals_per_s": evals / device["seconds"],
        "ns_per_world_step": device["seconds"] * 1e9 / (evals * steps),
        **device,
        "cpu_threads": threads,
        "cpu_evals": cpu_evals,
        "cpu_evals_per_s": cpu_evals / cpu_s,
        "cpu_ns_per_world_step": cpu_s * 1e9 / (cpu_evals * steps),
    }
    row["speedup"] = row["evals_per_s"] / row["cpu_evals_per_s"]
    print(
        f"coevolution {bodies} bodies x {brains} brains ({args.coevolution_duration:g} s): "
        f"{row['evals_per_s']:.1f} evals/s packed ({row['ns_per_world_step']:.1f} ns/robot-step,"
        f" first call {device['first_call_s']:.1f} s); local executor on {threads} threads "
        f"{row['cpu_evals_per_s']:.1f} evals/s: {row['speedup']:.2f}x"
    )
    return row
