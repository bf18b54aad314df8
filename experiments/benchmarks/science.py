"""Does the default experiment measure walking, and does learning matter? Figures from a run.

    python experiments/benchmarks/science.py [RUN_DIR]

Without ``RUN_DIR`` it runs the default experiment (``experiments/coevolve_flat.toml``, as
``make run`` does) into a temporary folder first. It reads the run's tables (trajectories at
the run's record rate) and prints, then writes as JSON on the last line:

- ``first_second_share``: for the 10 % best evaluations (by fitness), the median share of the
  measured window's planar displacement that the core has covered by the window's first
  second (|p(1 s) - p(0)| / |p(end) - p(0)|). A fall counted as locomotion is covered in the
  first second (share near 1); a gait spreads it over the window (near 1 / duration).
- ``late_step_share``: the same evaluations' median largest single 1-s displacement as a share
  of the path's summed 1-s displacements: a tip-over late in the window is one big step.
- ``best_saturated_share``: the share of the best evaluation's recorded joint targets that
  sit at the controller's bounds (within 1 % of ±π/2).
- ``learning_gain_median`` / ``learning_gain_share``: per body, the best fitness after its brain
  run's last CMA-ES iteration minus the best after its first; the median over bodies, and that
  median as a share of the median final best.
- ``core_z_start`` / ``core_z_end``: the median core height at the window's first and last
  frame (m), and ``distinct_bodies_per_generation``.

The issue's targets (issue 22): ``first_second_share <= 0.3``, ``best_saturated_share <= 0.5``,
``learning_gain_share >= 0.1``; ``targets_met`` says whether all three hold.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ariel.utils import replace_non_finite

BOUND = math.pi / 2


def _paths(trajectories: Any) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """eval_id -> (t, core xyz) of each recorded evaluation."""
    out = {}
    for eval_id, frame in trajectories.groupby("eval_id", sort=False):
        frame = frame.sort_values("t")
        out[str(eval_id)] = (
            frame["t"].to_numpy(),
            frame[["core_x", "core_y", "core_z"]].to_numpy(),
        )
    return out


def _first_second_share(t: np.ndarray, xyz: np.ndarray) -> float:
    total = float(np.linalg.norm(xyz[-1, :2] - xyz[0, :2]))
    if total < 1e-9:
        return math.nan
    one = int(np.searchsorted(t, t[0] + 1.0 - 1e-9))
    return float(np.linalg.norm(xyz[min(one, len(t) - 1), :2] - xyz[0, :2])) / total


def _largest_step_share(t: np.ndarray, xyz: np.ndarray) -> float:
    edges = np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, 1.0))
    edges = np.unique(np.append(edges, len(t) - 1))
    steps = np.linalg.norm(np.diff(xyz[edges, :2], axis=0), axis=1)
    return float(steps.max() / steps.sum()) if steps.sum() > 1e-9 else math.nan


def _learning_gain(evaluations: Any, maximise: bool) -> tuple[float, float]:
    """Median per-body gain (last iteration's best so far minus the first's), median final."""
    ok = evaluations[np.isfinite(evaluations["fitness"])]
    gains, finals = [], []
    for _, body in ok.groupby("body_id"):
        per_iteration = body.groupby("iteration")["fitness"]
        best = (per_iteration.max() if maximise else -per_iteration.min()).sort_index()
        if len(best) < 2:
            continue
        so_far = best.cummax()
        gains.append(float(so_far.iloc[-1] - so_far.iloc[0]))
        finals.append(float(so_far.iloc[-1]))
    if not gains:
        return math.nan, math.nan
    return float(np.median(gains)), float(np.median(finals))


def measure(run_dir: str | Path) -> dict[str, Any]:
    """The figures above for the run in ``run_dir``."""
    from ariel.recording import load_run

    run = load_run(run_dir)
    evaluations = run.evaluations
    maximise = run.maximise
    paths = _paths(run.trajectories)
    ok = evaluations[np.isfinite(evaluations["fitness"])].copy()
    ok = ok[ok["eval_id"].isin(paths)]
    ok = ok.sort_values("fitness", ascending=not maximise)
    top = ok.head(max(1, len(ok) // 10))
    shares = [_first_second_share(*paths[e]) for e in top["eval_id"]]
    steps = [_largest_step_share(*paths[e]) for e in top["eval_id"]]
    best_id = str(ok.iloc[0]["eval_id"])
    targets = run.trajectories[run.trajectories["eval_id"] == best_id]["joint_target"]
    target_values = np.abs(np.concatenate([np.asarray(v, float) for v in targets]))
    saturated = float(np.mean(target_values >= 0.99 * BOUND)) if target_values.size else 0.0
    gain, final = _learning_gain(evaluations, maximise)
    z = np.array([[xyz[0, 2], xyz[-1, 2]] for _, xyz in paths.values()])
    bodies = run.bodies
    selected = bodies[bodies["selected"]] if "selected" in bodies else bodies
    distinct = selected.groupby("generation")["graph"].nunique().astype(int).tolist()
    figures = {
        "run": str(run_dir),
        "evaluations": len(evaluations),
        "best_fitness": float(ok.iloc[0]["fitness"]),
        "fitness_fn": str(evaluations["fitness_fn"].iloc[0]),
        "settle_seconds": float(evaluations["settle_seconds"].iloc[0]),
        "first_second_share": float(np.nanmedian(shares)),
        "late_step_share": float(np.nanmedian(steps)),
        "best_saturated_share": saturated,
        "learning_gain_median": gain,
        "learning_gain_share": gain / final if final and math.isfinite(final) else math.nan,
        "core_z_start": float(np.median(z[:, 0])),
        "core_z_end": float(np.median(z[:, 1])),
        "distinct_bodies_per_generation": distinct,
    }
    figures["targets_met"] = bool(
        figures["first_second_share"] <= 0.3
        and figures["best_saturated_share"] <= 0.5
        and figures["learning_gain_share"] >= 0.1
    )
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", nargs="?", help="a finished run (default: run the default)")
    parser.add_argument("--set", action="append", default=[], help="config override key=value")
    args = parser.parse_args(argv)
    if args.run_dir is None:
        from ariel.evolution import run_experiment

        with tempfile.TemporaryDirectory(prefix="ariel-science-") as scratch:  # removed after
            result = run_experiment(None, overrides=args.set, out=Path(scratch) / "run")
            figures = measure(str(result.run_dir))
    else:
        figures = measure(args.run_dir)
    for key, value in figures.items():
        print(f"{key}: {value}", file=sys.stderr)
    # strict JSON: NaN (no learning gain without a second CMA-ES iteration) as null, which
    # JSON.parse and strict readers take (a bare NaN they refuse)
    print(json.dumps(replace_non_finite(figures, lambda _: None), allow_nan=False))
    return 0


if __name__ == "__main__":
    from _common import exit_with

    exit_with(main)
