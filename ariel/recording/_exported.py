"""Read back a folder written by `ariel export` (`export`): the robot ready to simulate.

`load_exported` rebuilds the body from ``genotype.json`` with the tutorial API (the
registries, the constructor, ``world.spawn``) and the controller from ``controller.json``
(`Controller`), as the run evaluated them: simulated with `simple_runner`, the core ends
where the run recorded it. The folder is data: only its two JSON files are read, and its
run id and evaluation id must have their shapes (`_ids`: one line otherwise).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["ExportedRobot", "load_exported"]


@dataclass
class ExportedRobot:
    """A compiled model and its data, the controller to hand ``mujoco.set_mjcb_control``
    (``controller.set_control``), and the evaluation's simulated seconds; what the run
    recorded of it: its ids, its fitness (and the fitness function's name) and where the core
    ended (``[x, y, z]``, None where the run kept no trajectories)."""

    model: Any
    data: Any
    controller: Any
    duration: float
    eval_id: str = ""
    run_id: str = ""
    fitness: float = math.nan
    fitness_fn: str = ""
    recorded_core: list[float] | None = None


def load_exported(folder: str | Path) -> ExportedRobot:
    """The exported evaluation in ``folder`` (``genotype.json``, ``controller.json``)."""
    import mujoco

    from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
    from ariel.plugins import body_encoders, controllers, worlds
    from ariel.recording._escape import one_line
    from ariel.recording._ids import check_eval_id, check_run_id
    from ariel.simulation.controllers.controller import Controller
    from ariel.simulation.controllers.observations import hinge_observation
    from ariel.simulation.settle import settle_model

    folder = Path(folder)
    body = json.loads((folder / "genotype.json").read_text(encoding="utf-8"))
    brain = json.loads((folder / "controller.json").read_text(encoding="utf-8"))
    eval_id = check_eval_id(brain.get("eval_id"), folder)
    run_id = check_run_id(brain.get("run_id"), folder)
    encoder = body_encoders.make(body["body_encoder"], **body["options"])
    if hasattr(encoder, "build"):  # a prebuilt robot
        core = encoder.build(body["genotype"])
    else:
        core = construct_mjspec_from_graph(encoder.decode(body["genotype"]))
    world = worlds.make(brain["world"], **brain["world_options"])
    world.spawn(core.spec, position=brain["spawn_position"], rotation=brain["spawn_rotation"])
    # Held at rest first, as the run's evaluation was (an export without the key did not).
    model = settle_model(world.spec.compile(), float(brain.get("settle", 0.0)))

    plugin = controllers.make(brain["controller"], **brain["options"])
    params, period, dt = np.array(brain["params"]), brain["control_period"], model.opt.timestep
    if plugin.open_loop:  # a function of time: its target at every controller call, first
        calls = np.arange(0, round(brain["duration"] / dt), period) * dt
        targets = plugin.targets(params[None], calls, model, seed=brain["seed"])[0]

        def policy(m: Any, d: Any) -> Any:
            return targets[round(d.time / (dt * period))]
    else:  # closed loop: a policy of the robot's observation
        act = plugin.make_policy(params, model)
        observe = getattr(plugin, "observation", hinge_observation)

        def policy(m: Any, d: Any) -> Any:
            return act(observe(m, d))

    controller = Controller(policy, time_steps_per_ctrl_step=period, alpha=brain["smoothing"])
    core = brain.get("core_end")
    return ExportedRobot(
        model,
        mujoco.MjData(model),
        controller,
        float(brain["duration"]),
        eval_id=eval_id,
        run_id=run_id,
        fitness=float(brain.get("fitness", math.nan)),
        fitness_fn=one_line(brain.get("fitness_fn", "")),
        recorded_core=[float(v) for v in core] if isinstance(core, list) else None,
    )
