"""Evaluation tasks and results: plain data that crosses process and machine boundaries.

A task names its plugins (body encoder, world, controller, fitness) and carries only numbers,
strings, lists and dicts, so any worker can rebuild everything from it; `evaluate(task)` is a
pure function of the task.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from ariel.utils import unknown_option

__all__ = [
    "FAILED_STATUSES",
    "BodySpec",
    "EvaluationResult",
    "EvaluationTask",
    "Status",
    "fitness_options_error",
]

#: ``invalid``: the fitness function returned NaN or an infinity (the value is in ``error``).
Status = Literal["ok", "unstable", "error", "invalid"]

#: The statuses of an evaluation that gave no fitness of its own, in the order they are shown.
FAILED_STATUSES: tuple[Status, ...] = ("error", "unstable", "invalid")


def _plain(value: Any) -> Any:
    """Numpy arrays and scalars -> lists and Python numbers (JSON-able, hashable as text)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


@dataclass(frozen=True)
class BodySpec:
    """Which body to build: a genotype (or graph, or prebuilt name) and the encoder that reads it.

    Examples: ``BodySpec("prebuilt", "gecko")``, ``BodySpec("nde", genotype, {"number_of_modules":
    20})``, ``BodySpec("graph", networkx.node_link_data(graph, edges="edges"))``.

    Attributes:
        encoder: Registered body encoder name, e.g. ``"prebuilt"``, ``"nde"`` or ``"graph"``;
            a non-empty string (else `ValueError`).
        genotype: What the encoder decodes into a body. Stored as plain data: numpy arrays and
            scalars become lists and Python numbers, so the spec survives JSON and pickling.
        options: Keyword arguments for the encoder's factory (default: none), stored as plain
            data too.
    """

    encoder: str
    genotype: Any
    options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.encoder, str) or not self.encoder:
            raise ValueError(f"body encoder must be a non-empty name, not {self.encoder!r}")
        object.__setattr__(self, "genotype", _plain(self.genotype))
        object.__setattr__(self, "options", _plain(dict(self.options)))

    @property
    def key(self) -> str:
        """Stable content hash: equal bodies share one compiled model in a worker."""
        text = json.dumps([self.encoder, self.genotype, self.options], sort_keys=True)
        return hashlib.sha1(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class EvaluationTask:
    """One evaluation: a body in a world, driven by a controller with fixed parameters.

    Every field is checked when the task is made (`ValueError` naming the field), and the
    options, params and spawn pose are stored as plain data.

    Attributes:
        body: the body to build.
        params: the controller's flat parameter vector (finite numbers; stored as a tuple of
            floats).
        controller: registered controller name, e.g. ``"na_cpg"``.
        world: registered world name, e.g. ``"flat"``.
        fitness: registered fitness name, e.g. ``"xy_displacement"``.
        controller_options: keyword arguments for the controller's factory (default: none).
        world_options: keyword arguments for the world's factory (default: none).
        fitness_options: keyword arguments passed to the fitness function after the record
            (default: none).
        duration: simulated seconds (measured, after ``settle``).
        settle: seconds the robot is first held at zero controls to come to rest; the
            evaluation (frames, fitness, ``time`` 0) starts from the pose it reaches, with zero
            velocity (`ariel.simulation.settle`). 0: from the spawn pose, as the tutorials.
        control_period: physics steps between controller calls (the tutorial's 50).
        smoothing: each controller call sets ``ctrl = ctrl * (1 - smoothing) + target *
            smoothing`` (then clipped to the actuator ranges): the tutorial `Controller`'s
            ``alpha``, 0.5. In (0, 1]; 1 applies the target at once.
        record_every: physics steps between recorded frames (0: only first and last frame).
        record_bodies: also record every body's world pose (for 3D replays).
        seed: seeds everything stochastic in this evaluation (e.g. the CPG's initial state); an
            integer, stored as a Python ``int``.
        spawn_position: where the robot is spawned, ``(x, y, z)`` in metres, as given to the
            world's ``spawn`` (in the built-in worlds z is extra height above the ground).
        spawn_rotation: the robot's orientation at spawn, Euler angles in degrees.
        eval_id: the caller's id for this evaluation, copied into the result.
    """

    body: BodySpec
    params: tuple[float, ...] = ()
    controller: str = "na_cpg"
    world: str = "flat"
    fitness: str = "xy_displacement"
    controller_options: dict[str, Any] = field(default_factory=dict)
    world_options: dict[str, Any] = field(default_factory=dict)
    fitness_options: dict[str, Any] = field(default_factory=dict)
    duration: float = 15.0
    settle: float = 0.0
    control_period: int = 50
    smoothing: float = 0.5
    record_every: int = 50
    record_bodies: bool = True
    seed: int = 0
    spawn_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    spawn_rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    eval_id: str = ""

    def __post_init__(self) -> None:
        params = np.asarray(self.params, dtype=np.float64).ravel()
        if not np.all(np.isfinite(params)):
            raise ValueError("controller params contain NaN or inf; all must be finite")
        object.__setattr__(self, "params", tuple(params.tolist()))
        if not (isinstance(self.duration, int | float) and math.isfinite(self.duration)):
            raise ValueError(f"duration must be a finite number of seconds, not {self.duration!r}")
        if self.duration <= 0:
            raise ValueError(f"duration must be > 0 seconds, not {self.duration}")
        if not (
            isinstance(self.settle, numbers.Real)
            and not isinstance(self.settle, bool)
            and math.isfinite(self.settle)
            and self.settle >= 0
        ):
            raise ValueError(f"settle must be a finite number of seconds >= 0, not {self.settle!r}")
        object.__setattr__(self, "settle", float(self.settle))
        if int(self.control_period) != self.control_period or self.control_period < 1:
            raise ValueError(
                f"control_period must be a whole number of physics steps >= 1, "
                f"not {self.control_period!r}"
            )
        if not (
            isinstance(self.smoothing, numbers.Real)
            and not isinstance(self.smoothing, bool)
            and math.isfinite(self.smoothing)
            and 0 < self.smoothing <= 1
        ):
            raise ValueError(
                f"smoothing must be a finite number in (0, 1] (1: no smoothing), "
                f"not {self.smoothing!r}"
            )
        object.__setattr__(self, "smoothing", float(self.smoothing))
        # Plugins get the seed as a Python int (np.random.default_rng takes lists silently).
        if not isinstance(self.seed, numbers.Integral) or isinstance(self.seed, bool):
            raise ValueError(f"seed must be an integer, not {self.seed!r}")
        object.__setattr__(self, "seed", int(self.seed))
        if int(self.record_every) != self.record_every or self.record_every < 0:
            raise ValueError(
                f"record_every must be a whole number of physics steps >= 0 (0: first and "
                f"last frame only), not {self.record_every!r}"
            )
        for name in ("spawn_position", "spawn_rotation"):
            value = tuple(float(v) for v in getattr(self, name))
            if len(value) != 3 or not all(math.isfinite(v) for v in value):
                raise ValueError(f"{name} must be 3 finite numbers, not {getattr(self, name)!r}")
            object.__setattr__(self, name, value)
        for name in ("controller_options", "world_options", "fitness_options"):
            object.__setattr__(self, name, _plain(dict(getattr(self, name))))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (for JSON, Parquet rows and logs)."""
        return asdict(self)


@dataclass
class EvaluationResult:
    """What one evaluation produced.

    Arrays are recorded every ``record_every`` physics steps, first frame at t = 0 and last at
    the end of the run: ``T`` frames, ``nu`` actuators, ``nbody`` robot bodies (the world's own
    bodies are not recorded).

    Attributes:
        eval_id: The task's ``eval_id``, copied.
        fitness: The fitness function's value; for a failed evaluation (any status but
            ``"ok"``) the worst fitness there is (``-inf`` when maximising, ``inf`` otherwise).
        status: ``"ok"``; ``"unstable"`` (MuJoCo warned about bad accelerations, or the state
            became NaN or infinite); ``"error"`` (the evaluation could not run: the body could
            not be built, say, or its worker failed); or ``"invalid"`` (the fitness function
            returned NaN or an infinity).
        error: One line saying what went wrong; empty when the status is ``"ok"``. An
            ``"error"`` result carries no frames (empty arrays).
        descriptors: The body's morphology descriptors by name (empty for a body without a
            graph form).
        sim_time: Simulated seconds at the last recorded frame (the run's length, settling
            not counted).
        wall_time: Wall-clock seconds the simulation took for this task (a batch's time
            divided by its tasks).
        time: ``(T,)`` simulated seconds of the recorded frames, from 0.
        core_pos: ``(T, 3)`` world position of the centre of the core geom, in metres (as the
            tutorial's tracker reports it).
        joint_target: ``(T, nu)`` the control in force at each frame (after smoothing and
            clipping to the actuator ranges).
        joint_angle: ``(T, nu)`` the angle of each actuated joint, in radians.
        body_pos: ``(T, nbody, 3)`` world positions of the robot's bodies, or None when the
            task's ``record_bodies`` is False.
        body_quat: ``(T, nbody, 4)`` world orientations of the robot's bodies as quaternions
            (w, x, y, z), or None when the task's ``record_bodies`` is False.
        body_names: Names of the robot's bodies, in the order of ``body_pos``'s second axis.
        joint_names: Names of the actuators, in the order of the last axis of
            ``joint_target`` and ``joint_angle``.
        backend: The simulator that produced the result: ``"mujoco"`` (the CPU engine) or
            ``"mujoco-warp:<device>"`` (`ariel.evaluation._warp`).
    """

    eval_id: str
    fitness: float
    status: Status
    error: str = ""
    descriptors: dict[str, float] = field(default_factory=dict)
    sim_time: float = 0.0
    wall_time: float = 0.0
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    core_pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    joint_target: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    joint_angle: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    body_pos: np.ndarray | None = None
    body_quat: np.ndarray | None = None
    body_names: list[str] = field(default_factory=list)
    joint_names: list[str] = field(default_factory=list)
    backend: str = "mujoco"

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def fitness_options_error(
    fitness_fn: Callable[..., object], options: Mapping[str, Any]
) -> TypeError | None:
    """The `TypeError` that calling ``fitness_fn(record, **options)`` would raise for its
    keywords (an unknown option, a missing one), or None: where a run's fitness options are
    checked (the engine, a run's preparation, a replay), before any physics runs. None too for
    a function without a signature to read (a C function): the call itself then says."""
    try:
        signature = inspect.signature(fitness_fn)
    except (TypeError, ValueError):
        return None
    try:
        signature.bind(None)  # the record alone (its options may be keywords with defaults)
    except TypeError as exc:
        if "too many positional" in str(exc):  # not a matter of the options given
            return TypeError(
                "it takes no argument for the record: a fitness function is called as "
                "fn(record, **options)"
            )
    try:
        signature.bind(None, **options)
    except TypeError as exc:
        unknown = unknown_option(fitness_fn, options, skip=1)
        return exc if unknown is None else TypeError(unknown)
    return None
