"""Read back a folder written by `ariel export` (`export`): the robot ready to simulate.

`load_exported` rebuilds the body from ``genotype.json`` with the tutorial API (the
registries, the constructor, ``world.spawn``) and the controller from ``controller.json``
(`Controller`), as the run evaluated them: simulated with `simple_runner`, the core ends
where the run recorded it. Driven through `ExportedRobot.set_control`, it also keeps the
frames the run's fitness function saw (every ``record_every`` physics steps and the last,
as the evaluation engine records them), and `ExportedRobot.replayed_fitness` scores them
with that function: the recorded fitness again. The folder is data: only its two JSON files
are read, and its run id and evaluation id must have their shapes (`_ids`: one line
otherwise).

This module imports mujoco (which reads its GL backend, ``MUJOCO_GL``, when first imported):
ARIEL reaches it at call time only, through `ariel.recording.load_exported`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.errors import DamagedRunError
from ariel.evaluation import SPAWN_PREFIX, TrajectoryRecord, frame_steps
from ariel.plugins import body_encoders, controllers, fitness_functions, worlds
from ariel.recording.store import check_eval_id, check_run_id, json_file, one_line
from ariel.simulation.controllers.controller import Controller
from ariel.simulation.controllers.observations import hinge_observation
from ariel.simulation.settle import settle_model
from ariel.utils import path_argument

if TYPE_CHECKING:
    from ariel.recording.store import JsonObject

__all__ = ["ExportedRobot", "load_exported"]


@dataclass
class ExportedRobot:
    """An exported robot, ready to simulate, and what the run recorded of its evaluation.

    ``mujoco.set_mjcb_control(robot.set_control)`` drives it with ``controller`` and keeps
    the frames its fitness function scores: `replayed_fitness` after `simple_runner`.

    Attributes:
        model: The compiled `mujoco.MjModel` of the world with the robot spawned, held at
            rest for the run's settle time first, as the evaluation was.
        data: A fresh `mujoco.MjData` of ``model``.
        controller: The controller (`Controller`) to hand ``mujoco.set_mjcb_control``
            (``controller.set_control``; `set_control` also keeps the fitness's frames).
        duration: The evaluation's simulated seconds.
        eval_id: The evaluation's id, e.g. ``"b000052-i005-c002"``.
        run_id: The id of the run it came from.
        fitness: The fitness the run recorded; NaN where the export does not say.
        fitness_fn: The name of the run's fitness function.
        recorded_core: Where the run recorded the core at the end, ``[x, y, z]`` in metres;
            None where the run kept no trajectories.
        fitness_unit: The fitness function's unit (e.g. ``"m"``); ``""`` where it is unknown
            here or the export does not say how the run recorded frames.
        backend: The simulator the run evaluated it with: ``"mujoco"`` (the CPU engine, as
            this replay) or ``"mujoco-warp:cuda"`` / ``"mujoco-warp:cpu"`` (float32, not
            bitwise the same as MuJoCo: its replay differs slightly).
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    controller: Controller
    duration: float
    eval_id: str = ""
    run_id: str = ""
    fitness: float = math.nan
    fitness_fn: str = ""
    recorded_core: list[float] | None = None
    fitness_unit: str = ""
    backend: str = "mujoco"
    _frames: _Frames | None = field(default=None, repr=False)

    def set_control(
        self, model: mujoco.MjModel, data: mujoco.MjData, *args: object, **kwargs: object
    ) -> None:
        """The MuJoCo control callback: ``controller.set_control``, then this step's frame
        where the run recorded one."""
        self.controller.set_control(model, data, *args, **kwargs)
        if self._frames is not None:
            self._frames.record(data)

    def replayed_fitness(self) -> float:
        """The run's fitness function (with its options) on the frames recorded while
        `set_control` drove ``data`` through the whole evaluation (``duration`` seconds);
        NaN for an export that does not say how the run recorded frames (made before
        ``record_every`` was exported). `ValueError` when the robot was not simulated for
        ``duration`` seconds through `set_control`."""
        if self._frames is None:
            return math.nan
        return self._frames.fitness(self.data)


class _Frames:
    """The frames a fitness function sees (`TrajectoryRecord`), kept on the tutorial path at
    the physics steps where the engine keeps them (`frame_steps`): core position and joint
    angles of the state about to be stepped, the control just set."""

    def __init__(
        self, model: mujoco.MjModel, brain: JsonObject, target: Sequence[float] | None
    ) -> None:
        self.model = model
        self.dt = model.opt.timestep
        self.nstep = max(1, round(float(brain["duration"]) / self.dt))
        self.every = int(brain["record_every"])
        self.wanted = frame_steps(self.nstep, self.every)
        self.core = model.geom(SPAWN_PREFIX + "core").id
        self.joint_qpos = model.jnt_qposadr[model.actuator_trnid[:, 0]]
        self.target = None if target is None else tuple(float(v) for v in target)
        self.function = fitness_functions.get(brain["fitness_fn"])
        self.options = dict(brain.get("fitness_options", {}))
        self.rows: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def record(self, data: mujoco.MjData) -> None:
        step = round(data.time / self.dt)
        if step == 0:
            self.rows.clear()  # a new simulation (simple_runner resets the data)
        if step < self.nstep and (step % self.every == 0 if self.every > 0 else step == 0):
            self._keep(step, data)

    def _keep(self, step: int, data: mujoco.MjData) -> None:
        core = data.geom_xpos[self.core].copy()
        self.rows[step] = (core, data.ctrl.copy(), data.qpos[self.joint_qpos].copy())

    def fitness(self, data: mujoco.MjData) -> float:
        kept = self.rows.keys() | {self.nstep}
        if round(data.time / self.dt) != self.nstep or not set(self.wanted.tolist()) <= kept:
            raise ValueError(
                f"simulate the robot for its {self.nstep * self.dt:g} seconds through "
                "robot.set_control first (mujoco.set_mjcb_control, simple_runner)"
            )
        mujoco.mj_kinematics(self.model, data)  # the final state's positions
        self._keep(self.nstep, data)
        core, ctrl, angle = (
            np.array([self.rows[int(k)][i] for k in self.wanted]) for i in range(3)
        )
        record = TrajectoryRecord(self.wanted * self.dt, core, ctrl, angle, self.target)
        return float(self.function(record, **self.options))


def _read(folder: Path, name: str) -> JsonObject:
    """The JSON object in ``folder``/``name``, read as a run folder's JSON is (`json_file`: a
    regular file, not too large, nested no deeper than a few levels); `DamagedRunError`, one
    line, for one missing or unreadable."""
    try:
        data = json_file(folder / name)
    except (OSError, ValueError) as exc:
        problem = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
    else:
        if isinstance(data, dict):
            return data
        problem = "not a JSON object"
    raise DamagedRunError(
        f"{str(folder)!r} is not a readable `ariel export` folder: {name}: {problem}"
    )


def load_exported(folder: str | Path) -> ExportedRobot:
    """The exported evaluation in ``folder`` (``genotype.json``, ``controller.json``).

    Args:
        folder: A folder written by `ariel export` (`export`); only its two JSON files are
            read.

    Returns:
        The robot, rebuilt with the tutorial API as the run evaluated it, with what the run
        recorded of the evaluation.

    Raises:
        DamagedRunError: When ``genotype.json`` or ``controller.json`` is missing or is not a
            readable JSON object, or its run id or evaluation id does not have its shape.

    Example:
        After ``ariel export data/runs/<run-id> best exported`` (the run's best evaluation
        into the new folder ``exported``), simulate it again:

        ```python
        import mujoco

        from ariel.recording import load_exported
        from ariel.utils.runners import simple_runner

        robot = load_exported("exported")
        mujoco.set_mjcb_control(robot.set_control)
        simple_runner(robot.model, robot.data, duration=robot.duration)
        print(robot.replayed_fitness(), robot.fitness)  # the recorded fitness again
        ```
    """
    folder = path_argument("folder", folder, function="load_exported")
    body, brain = (_read(folder, name) for name in ("genotype.json", "controller.json"))
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

        def policy(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
            return targets[round(d.time / (dt * period))]
    else:  # closed loop: a policy of the robot's observation
        act = plugin.make_policy(params, model)
        observe = getattr(plugin, "observation", hinge_observation)

        def policy(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
            return act(observe(m, d))

    controller = Controller(policy, time_steps_per_ctrl_step=period, alpha=brain["smoothing"])
    core = brain.get("core_end")
    frames = None
    if "record_every" in brain:  # exports before it did not say how the run kept frames
        frames = _Frames(model, brain, getattr(world, "target_position", None))
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
        fitness_unit=one_line(str(getattr(frames.function, "unit", None) or "")) if frames else "",
        backend=one_line(str(brain.get("backend") or "mujoco")),
        _frames=frames,
    )
