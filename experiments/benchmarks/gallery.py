"""Gallery benchmark: body thumbnails drawn per second on one core (``ariel gallery``).

Without ``RUN_DIR`` it first makes a run in a child process (so this one has built no body
yet): ``experiments/coevolve_flat.toml`` scaled down to ``--generations`` (default 6) of 8 + 8
bodies of 12 modules, brains of popsize 2 for 1 iteration of 1 s, serial, no Rerun
recordings; into a temporary folder deleted afterwards. Then it draws the thumbnails of
``--thumbnails`` (default 40) distinct bodies of the run, the newest first, one after
another in this process: what each worker of ``ariel gallery`` does for its share. Each
thumbnail is the whole job: rebuild the body from the records (``replay_task``, ``build``
with its settling), draw it (256 x 256, the three-quarter camera) and write the PNG, into a
temporary folder (never the run folder).

One thumbnail is drawn first, untimed: a process's first drawing makes its GL context and
compiles the renderer's shaders (``setup_s``, paid once per worker). The figure is
``thumbnails_per_s_per_core``: thumbnails / seconds of the timed call (one process, one
core); target >= 20. Numbers depend on the machine's load (its load average is printed) and
on the GL backend (``MUJOCO_GL``; set to egl here where unset: Mesa's llvmpipe draws on the
CPU where no GPU driver is installed).

Prints a table, then as the last line one JSON object with ``thumbnails_per_s_per_core``,
``ms_per_thumbnail``, ``setup_s``, ``thumbnails`` and context.

    python experiments/benchmarks/gallery.py [RUN_DIR] [--thumbnails 40] [--generations 6]
        [--quick]
"""

from __future__ import annotations

from _common import (
    add_quick_option,
    apply_quick,
    check_at_least,
    exit_with,
    load_average,
    one_blas_thread,
    utc_now,
    versions,
)

one_blas_thread()

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "coevolve_flat.toml"
TARGET = 20.0  # thumbnails per second on one core
QUICK = {"thumbnails": 3, "generations": 1}
RUN_OVERRIDES = [
    "brain.popsize=2",
    "brain.iterations=1",
    "task.duration=1.0",
    'executor.kind="serial"',
    "record.rerun=false",
    "record.trajectories=false",
]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", nargs="?", help="a finished run (default: make one)")
    parser.add_argument("--thumbnails", type=int, default=40, help="thumbnails timed")
    parser.add_argument("--generations", type=int, default=6, help="of the run made")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    check_at_least(parser, args, 1, "thumbnails", "generations")
    return args


def make_run(folder: Path, generations: int) -> Path:
    """A small co-evolution run in ``folder/run``, made by ``ariel run`` in a child process."""
    out = folder / "run"
    command = [sys.executable, "-m", "ariel.cli", "run", str(CONFIG), "--out", str(out)]
    command += ["--quiet", "--set", f"generations={generations}"]
    for override in RUN_OVERRIDES:
        command += ["--set", override]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return out


def jobs_of(run: Any, count: int, folder: Path) -> list[Any]:
    """``count + 1`` distinct bodies that were built (newest first), as thumbnail jobs that
    write to ``folder``: the first is the untimed warm-up."""
    from ariel.recording.analysis._gallery_render import ThumbnailJob

    bodies = run.bodies.drop_duplicates("body_id", keep="last")
    built = bodies[bodies["fitness"].map(math.isfinite)].sort_values("body_id", ascending=False)
    ids = [str(b) for b in built["body_id"]][: count + 1]
    if len(ids) < 2:  # a brain-only run's one body: the scripts' one-line error, exit 2
        print(
            f"gallery.py: error: {run.path}: fewer than 2 bodies that were built", file=sys.stderr
        )
        raise SystemExit(2)
    return [ThumbnailJob(str(run.path), body, str(folder / f"{body}.png")) for body in ids]


def measure(run_dir: Path, count: int) -> dict[str, Any]:
    from ariel.recording import load_run
    from ariel.recording.analysis._gallery_render import gl_problem, render_thumbnails

    problem = gl_problem()
    if problem is not None:
        raise SystemExit(f"cannot draw here: {problem}")
    run = load_run(run_dir)
    with tempfile.TemporaryDirectory(prefix="ariel-gallery-bench-") as scratch:
        jobs = jobs_of(run, count, Path(scratch))
        start = time.perf_counter()
        warm = render_thumbnails(jobs[:1], workers=1, runs={str(run.path): run})
        setup = time.perf_counter() - start
        start = time.perf_counter()
        drawn = render_thumbnails(jobs[1:], workers=1, runs={str(run.path): run})
        seconds = time.perf_counter() - start
    failed = [why for why in [*warm.values(), *drawn.values()] if why is not None]
    if failed:
        raise SystemExit(f"{len(failed)} thumbnail(s) not drawn: {failed[0]}")
    timed = len(jobs) - 1
    return {
        "thumbnails": timed,
        "seconds": seconds,
        "thumbnails_per_s_per_core": timed / seconds,
        "ms_per_thumbnail": 1000 * seconds / timed,
        "setup_s": setup,
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    from ariel.utils import ensure_headless_gl

    ensure_headless_gl()  # before mujoco is imported: EGL where MUJOCO_GL is unset
    import os

    with tempfile.TemporaryDirectory(prefix="ariel-gallery-run-") as scratch:
        made = args.run_dir is None
        run_dir = make_run(Path(scratch), args.generations) if made else Path(args.run_dir)
        figures = measure(run_dir, args.thumbnails)
    figures.update(
        target=TARGET,
        target_met=figures["thumbnails_per_s_per_core"] >= TARGET,
        run=None if made else str(run_dir),
        mujoco_gl=os.environ.get("MUJOCO_GL"),
        load_average=load_average(),
        when=utc_now(),
        versions=versions(mujoco="mujoco", pillow="pillow"),
    )
    print(f"{'thumbnails timed':<28}{figures['thumbnails']:>10}")
    print(f"{'thumbnails/s on one core':<28}{figures['thumbnails_per_s_per_core']:>10.1f}")
    print(f"{'ms per thumbnail':<28}{figures['ms_per_thumbnail']:>10.1f}")
    print(f"{'first drawing (setup), s':<28}{figures['setup_s']:>10.2f}")
    print(f"target >= {TARGET:g}/s: {'met' if figures['target_met'] else 'NOT met'}")
    print(f"load average: {figures['load_average']}, MUJOCO_GL={figures['mujoco_gl']}")
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    exit_with(main)
