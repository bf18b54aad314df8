"""Quick-start tutorial flow, end to end, as one script.

The "Quick Start: Modular Robots" tutorial in a single run: the prebuilt gecko on a
SimpleFlatWorld, driven by a seeded NA-CPG through ``Controller`` (with a ``Tracker`` on the core)
and ``simple_runner``. It prints the core's planar displacement, saves a trajectory plot (PNG)
and a short video that follows the robot (MP4), and prints their paths.

    python experiments/quickstart.py [--duration 15] [--seed 42] [--out data/quickstart]

Rendering is headless: on Linux ``MUJOCO_GL`` defaults to ``egl`` (set before ``mujoco`` is
imported, and only when the video is made: with ``--no-video`` no GL library is loaded); pass
``--no-video`` on a machine without OpenGL.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import NoReturn

from ariel.utils._gl import ensure_headless_gl

if "--no-video" not in sys.argv[1:]:  # only the video renders; before anything imports mujoco
    ensure_headless_gl(without="run with --no-video")

# The imports below need the GL choice above, hence after code.
import matplotlib

matplotlib.use("Agg")  # files only, never a window

import matplotlib.pyplot as plt
import mujoco
import numpy as np

from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
from ariel.recording.store import records_folder_of
from ariel.simulation.controllers.controller import Controller
from ariel.simulation.controllers.na_cpg import (
    NaCPG,
    create_fully_connected_adjacency,
)
from ariel.simulation.environments import SimpleFlatWorld
from ariel.utils.renderers import tracking_video_renderer
from ariel.utils.runners import simple_runner
from ariel.utils.tracker import Tracker
from ariel.utils.video_recorder import VideoRecorder

# Snapshot the core every 25 physics steps (0.05 s at 0.002 s) for a smooth trajectory plot;
# the tutorial's default of 500 steps gives only 15 points in 15 s.
STEPS_PER_SNAPSHOT = 25


#: The longest simulated run (--duration) and video (--video-seconds): an hour of simulated time
#: is minutes of wall time and a trajectory of 72,000 points; beyond it, a typo.
MAX_SECONDS = 3600.0


class _Parser(argparse.ArgumentParser):
    """A usage error is one line, as the ariel commands' (the message and where to get help)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _folder(text: str) -> Path:
    if not text:  # Path("") is the current folder
        raise argparse.ArgumentTypeError("an empty path; give a folder such as data/quickstart")
    return Path(text)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = _Parser(description=__doc__.split("\n\n")[0])
    default = " (default: %(default)s)"
    parser.add_argument(
        "--duration", type=float, default=15.0, metavar="SECONDS", help="simulated time" + default
    )
    parser.add_argument(
        "--seed", type=int, default=42, metavar="N", help="seed of the CPG parameters" + default
    )
    parser.add_argument(
        "--out",
        type=_folder,
        default=Path("data/quickstart"),
        metavar="DIR",
        help="output folder" + default,
    )
    parser.add_argument(
        "--video-seconds", type=float, default=5.0, metavar="SECONDS", help="video length" + default
    )
    parser.add_argument("--no-video", action="store_true", help="skip the video (no OpenGL)")
    args = parser.parse_args(argv)
    for flag, seconds in (("--duration", args.duration), ("--video-seconds", args.video_seconds)):
        if not (math.isfinite(seconds) and 0 < seconds <= MAX_SECONDS):
            parser.error(
                f"{flag} must be above 0 and at most {MAX_SECONDS:g} seconds, not {seconds}"
            )
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {str(args.out)!r} is a file, not a folder")
    records = records_folder_of(args.out)
    if records is not None:  # its files are a run's or a campaign's records alone
        parser.error(f"--out {str(args.out)!r} is inside the run or campaign {str(records)!r}")
    return args


def build(seed: int) -> tuple[mujoco.MjModel, mujoco.MjData, Controller, Tracker]:
    """World + gecko + tracker + seeded CPG controller, registered as MuJoCo's callback."""
    mujoco.set_mjcb_control(None)  # spawning runs mj_forward: no stale callback may fire
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=[0, 0, 0])
    model = world.spec.compile()
    data = mujoco.MjData(model)

    tracker = Tracker(
        mujoco_obj_to_find=mujoco.mjtObj.mjOBJ_GEOM,
        name_to_bind="core",
        observable_attributes=["xpos"],
    )
    tracker.setup(world.spec, data)
    cpg = NaCPG(
        adjacency_dict=create_fully_connected_adjacency(model.nu),
        hard_bounds=(-np.pi / 2, np.pi / 2),
        seed=seed,
    )
    controller = Controller(
        controller_callback_function=lambda m, d: cpg.forward(time=d.time),
        time_steps_per_save=STEPS_PER_SNAPSHOT,
        tracker=tracker,
    )
    mujoco.set_mjcb_control(controller.set_control)
    return model, data, controller, tracker


def plot_trajectory(xyz: np.ndarray, displacement: float, title: str, path: Path) -> None:
    """Top view of the core's path with start/end markers, equal axes."""
    fig, ax = plt.subplots(figsize=(6.5, 6), layout="constrained")
    ends = xyz[[0, -1], :2]
    ax.plot(ends[:, 0], ends[:, 1], "--", color="0.5", linewidth=1, label="displacement")
    ax.plot(xyz[:, 0], xyz[:, 1], color="tab:blue", linewidth=2, label="core path")
    ax.plot(*xyz[0, :2], "o", color="tab:green", markersize=10, label="start")
    ax.plot(*xyz[-1, :2], "s", color="tab:red", markersize=10, label="end")
    # Square window around the path, at least 0.5 m wide, so short walks are not blown up.
    centre = (xyz[:, :2].min(axis=0) + xyz[:, :2].max(axis=0)) / 2
    half = max(float(np.ptp(xyz[:, :2], axis=0).max()) / 2 * 1.25, 0.25)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.4)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{title}\ndisplacement {displacement:.3f} m")
    ax.legend(loc="best")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    out: Path = args.out
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a read-only place, a file on the way, ...
        print(
            f"{sys.argv[0]}: error: cannot make --out {str(out)!r}: {exc.strerror or exc}",
            file=sys.stderr,
        )
        return 2
    print("ARIEL quick-start tutorial flow: gecko + NA-CPG on SimpleFlatWorld")

    start = time.perf_counter()
    model, data, _controller, tracker = build(args.seed)
    try:
        simple_runner(model, data, duration=args.duration)
        xyz = np.array(tracker.history["xpos"][0])  # copy before the video appends more
        displacement = float(np.linalg.norm(xyz[-1, :2] - xyz[0, :2]))
        print(
            f"simulated {data.time:.2f} s ({model.nu} actuators, CPG seed {args.seed}) "
            f"in {time.perf_counter() - start:.2f} s wall time"
        )
        print(f"displacement of the core: {displacement:.4f} m")

        plot_path = out / f"quickstart_trajectory_seed{args.seed}.png"
        title = f"Gecko, NA-CPG seed {args.seed}, {args.duration:g} s"
        plot_trajectory(xyz, displacement, title, plot_path)
        print(f"trajectory plot: {plot_path}")

        if not args.no_video:
            # The same controller stays registered and the renderer resets the data, so the
            # video shows the first seconds of the very run measured above.
            seconds = min(args.video_seconds, args.duration)
            recorder = VideoRecorder(
                file_name=f"quickstart_seed{args.seed}", output_folder=out, fps=30
            )
            tracking_video_renderer(model, data, duration=seconds, video_recorder=recorder)
            print(f"video ({recorder.frame_count} frames, {seconds:g} s): {recorder.path}")
    finally:
        mujoco.set_mjcb_control(None)
    print(f"done in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
