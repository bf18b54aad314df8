"""Export one evaluation of a run for use outside the workbench (`ariel export`).

The folder it writes holds the body in its world as MJCF (``body.xml``, MuJoCo's own viewer
opens it: ``python -m mujoco.viewer --mjcf body.xml``), the genotype (``genotype.json``), the
controller and its exact parameters (``controller.json``), and ``replay.py``: a 10-line
script of the tutorial API that rebuilds the robot (`load_exported`: the registries, the
constructor, ``world.spawn``, `Controller`), drives it (``mjcb_control``, `simple_runner`)
and prints where the core ends up: where the run recorded it, as the tutorial path equals
the engine's. (MJCF rounds numbers to 6 digits, so a simulation of
``body.xml`` drifts from the recorded path; it is for looking at.)
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ariel.errors import ArielError

__all__ = ["ExportError", "export"]

#: The files `export` writes into its folder.
FILES = ("body.xml", "genotype.json", "controller.json", "replay.py")

_SCRIPT = '''\
"""Replay evaluation {eval_id} of run {run_id} with ARIEL's tutorial API: python replay.py"""

from pathlib import Path

import mujoco

from ariel.recording import load_exported
from ariel.utils.runners import simple_runner

robot = load_exported(Path(__file__).resolve().parent)  # genotype.json, controller.json
mujoco.set_mjcb_control(robot.controller.set_control)
simple_runner(robot.model, robot.data, duration=robot.duration)
mujoco.mj_kinematics(robot.model, robot.data)  # the final state's positions
print("core at", robot.data.geom("{core}").xpos.tolist())
'''


class ExportError(ArielError, ValueError):
    """An export that cannot be made (its folder is not empty, its body cannot be built)."""


def export(run_dir: str | Path, eval_id: str, out: str | Path) -> Path:
    """Write evaluation ``eval_id`` (or ``"best"``) of the run in ``run_dir`` to the folder
    ``out`` (created; an existing one must be empty): `FILES`. Returns ``out``.

    Raises `UnknownEvaluationError` for an id not in the run's finished generations,
    `ExportError` for a non-empty ``out`` or a body that could not be built, and
    `MissingPluginError` when a plugin the body or world needs is not installed here.
    """
    from ariel.evaluation._engine import SPAWN_PREFIX
    from ariel.recording._load import load_run
    from ariel.recording._replay import _find_row, _require_plugins, replay_task

    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ExportError(f"{out}: exists and is not an empty folder; name a new one")
    run = load_run(run_dir)
    row = _find_row(run, eval_id)
    if row["status"] == "error":
        raise ExportError(
            f"evaluation {row['eval_id']!r} has no body to export: its genotype cannot be "
            f"built ({row.get('error') or 'build error'})"
        )
    _require_plugins(run)
    task = replay_task(run, row)
    xml = _world_spec(task).to_xml()
    genotype = {  # as the run's encoder sees it (the task may ship the decoded graph instead)
        "body_encoder": str(row["body_encoder"]),
        "options": run.config.get("body", {}).get("options", {}),
        "genotype": json.loads(row["body_genotype"]),
    }
    brain = {
        "run_id": run.info.get("run_id"),
        "eval_id": str(row["eval_id"]),
        "controller": task.controller,
        "options": task.controller_options,
        "params": [float(v) for v in task.params],
        "seed": int(task.seed),
        "duration": float(task.duration),
        "settle": float(task.settle),
        "control_period": int(task.control_period),
        "smoothing": float(task.smoothing),
        "world": task.world,
        "world_options": task.world_options,
        "spawn_position": list(task.spawn_position),
        "spawn_rotation": list(task.spawn_rotation),
        "fitness_fn": task.fitness,
        "fitness": float(row["fitness"]),
    }
    script = _SCRIPT.format(
        eval_id=row["eval_id"], run_id=run.info.get("run_id"), core=SPAWN_PREFIX + "core"
    )
    texts = {
        "body.xml": xml,
        "genotype.json": json.dumps(genotype, indent=1) + "\n",
        "controller.json": json.dumps(brain, indent=1) + "\n",
        "replay.py": script,
    }
    out.mkdir(parents=True, exist_ok=True)
    for name, text in texts.items():
        (out / name).write_text(text, encoding="utf-8")
    return out


def _world_spec(task: Any) -> Any:
    """``task``'s body spawned in its world: the `mujoco.MjSpec` that `build` compiles."""
    from ariel.evaluation._engine import _plugin, _robot_module
    from ariel.plugins import body_encoders, worlds

    encoder = _plugin(body_encoders, task.body.encoder, task.body.options)
    world = _plugin(worlds, task.world, task.world_options)
    core, _ = _robot_module(encoder, task.body.genotype)
    world.spawn(core.spec, position=task.spawn_position, rotation=task.spawn_rotation)
    return world.spec
