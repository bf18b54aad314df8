"""The report's figures of the best evaluation: ``trajectory.png`` (its core path) and
``joints.png`` (every joint's target and angle, from the trajectories table; joints named by
`joint_labels`), and ``best_body.png`` (the best body rendered in its world; left out where
OpenGL is missing).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ariel.errors import DamagedRunError
from ariel.recording.analysis._report_figures import _DPI, _figure, _run_title, _save, _title
from ariel.recording.rerun import joint_labels, three_quarter_view
from ariel.recording.store import Run, one_line
from ariel.utils import mujoco_module

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.analysis._report import Report


def _trajectory_figures(report: Report, frames: pd.DataFrame) -> None:
    run, best = report.run, report.best
    assert best is not None
    label = f"{one_line(best['eval_id'])} (fitness {best['fitness']:.6g})"
    t = frames["t"].to_numpy()
    x, y = frames["core_x"].to_numpy(), frames["core_y"].to_numpy()

    figure = _figure(6.4, 6)
    axes = figure.add_subplot()
    axes.plot(x, y, color="0.6", lw=1, zorder=1)
    points = axes.scatter(x, y, c=t, cmap="viridis", s=14, zorder=2)
    axes.plot(x[0], y[0], "o", ms=10, mfc="none", mec="green", mew=2, label="start")
    axes.plot(x[-1], y[-1], "X", ms=10, color="red", label="end")
    figure.colorbar(points, ax=axes, label="time (s)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel("core x (m)")
    axes.set_ylabel("core y (m)")
    _title(axes, f"{_run_title(run)}: core path\nbest evaluation {label}")
    axes.grid(alpha=0.3)
    axes.legend(loc="best")
    _save(figure, report.folder / "trajectory.png", report)

    names = [str(n) for n in best.get("joint_names", [])]
    if not names:
        report.notes.append("joints.png: left out (the best body has no joints)")
        return
    labels = [one_line(n) for n in joint_labels(names, _graph_of(run, str(best["body_id"])))]
    target, angle = (_joint_values(frames[name].tolist(), len(names)) for name in JOINT_COLUMNS)
    if target is None or angle is None:  # a changed table: the rest of the report stands
        report.notes.append(
            "joints.png: left out (the trajectories table's joint lists are not one value "
            "per joint of the best body)"
        )
        return
    cols = min(3, len(names))
    rows = math.ceil(len(names) / cols)
    figure = _figure(4.2 * cols, 2.4 * rows + 0.8)
    _title(figure, f"{_run_title(run)}: best evaluation {label}: joints", suptitle=True)
    for j, name in enumerate(labels):
        axes = figure.add_subplot(rows, cols, j + 1)
        axes.plot(t, target[:, j], "--", lw=1.2, label="target")
        axes.plot(t, angle[:, j], lw=1.2, label="angle")
        _title(axes, name, fontsize=9)
        axes.set_xlabel("time (s)")
        axes.set_ylabel("angle (rad)")
        axes.grid(alpha=0.3)
        if j == 0:
            axes.legend(loc="best", fontsize=8)
    _save(figure, report.folder / "joints.png", report)


#: The trajectories table's joint signals: a list per frame, one value per joint.
JOINT_COLUMNS = ("joint_target", "joint_angle")


def _joint_values(lists: list[list[float] | None], width: int) -> np.ndarray | None:
    """``lists`` (a joint signal of one evaluation's frames, a list per frame) as a frames x
    ``width`` array; None where a frame has no list or one of another length (no run writes
    one)."""
    if any(values is None or len(values) != width for values in lists):
        return None
    return np.array(lists, dtype=float).reshape(len(lists), width)


def _graph_of(run: Run, body_id: str) -> str | None:
    """The robot graph (node-link JSON) of ``body_id`` from the bodies table, or None."""
    bodies = run.bodies
    if "graph" not in bodies:
        return None
    graphs = bodies.loc[bodies["body_id"] == body_id, "graph"]
    return graphs.iloc[0] if len(graphs) and graphs.iloc[0] else None


def _body_image(report: Report, width: int = 800, height: int = 600) -> None:
    # Reading the run's tables imported mujoco, with the GL backend MUJOCO_GL named then
    # (`ariel report` sets egl first where no display is set, unless --no-render); a backend
    # that fails leaves the image out, with create_renderer's one-line reason as the note.
    # lazy: build and single_frame_renderer import mujoco: only after MUJOCO_GL is set
    from ariel.evaluation import build
    from ariel.recording.resim import replay_task  # lazy: slow (~0.6 s: the engine, networkx)
    from ariel.utils.renderers import single_frame_renderer  # lazy: imports mujoco (see above)

    mujoco = mujoco_module()

    best = report.best
    assert best is not None
    try:
        built = build(replay_task(report.run, best))
    except DamagedRunError as exc:  # a changed table: the rest of the report stands
        report.notes.append(f"best_body.png: left out ({exc})")
        return
    model = built.model
    size = max(float(best.get(k) or 0.0) for k in ("extent_x", "extent_y", "extent_z"))
    try:
        try:
            view = three_quarter_view(built, size or 1.0)
            image = single_frame_renderer(
                model, mujoco.MjData(model), steps=0, width=width, height=height, **view
            )
        except ValueError:  # a model without "ortho-cam": the free camera frames everything
            image = single_frame_renderer(
                model, mujoco.MjData(model), steps=0, width=width, height=height
            )
    except RuntimeError as exc:  # no OpenGL backend here
        report.notes.append(f"best_body.png: left out ({exc})")
        return
    figure = _figure(width / _DPI, height / _DPI + 0.5)
    axes = figure.add_subplot()
    axes.imshow(np.asarray(image))
    axes.set_axis_off()
    modules = best.get("num_modules")
    shape = (
        f"{int(modules)} modules, {int(best.get('num_hinges') or 0)} hinges"
        if modules is not None and math.isfinite(modules)
        else f"{int(best.get('n_joints') or 0)} joints"
    )
    _title(
        axes,
        f"{_run_title(report.run)}: best body {one_line(best['body_id'])} ({shape}), "
        f"evaluation {one_line(best['eval_id'])}",
        fontsize=10,
    )
    _save(figure, report.folder / "best_body.png", report)
