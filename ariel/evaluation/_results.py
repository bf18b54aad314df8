"""From recorded frames to a result: what every path of the engine shares at its end.

The frame schedule (`num_steps`, `frame_steps`), the kinematics of the frames, the fitness
function's score (`TrajectoryRecord` is what it sees) and the result's status (`_finish`;
`_error_result` for a body that cannot be built). Re-exported by `ariel.evaluation._engine`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from ariel.evaluation._build import BuiltBody, _one_line
from ariel.evaluation._task import EvaluationResult, EvaluationTask, fitness_options_error

if TYPE_CHECKING:
    from ariel.plugins import FitnessFunction

__all__ = ["TrajectoryRecord", "frame_steps", "num_steps", "read_only", "worst_fitness"]


@dataclass(frozen=True)
class TrajectoryRecord:
    """What a fitness function sees: the recorded frames of one evaluation.

    The frames are the result's (`EvaluationResult`): every ``record_every`` physics steps,
    first at t = 0 and last at the end of the run; ``T`` frames, ``nu`` actuators. The
    arrays a run hands a fitness function are read-only: they are the ones recorded.

    Attributes:
        time: ``(T,)`` simulated seconds of the frames, from 0.
        core_pos: ``(T, 3)`` world position of the centre of the core geom, in metres.
        joint_target: ``(T, nu)`` the control in force at each frame (after smoothing and
            clipping to the actuator ranges).
        joint_angle: ``(T, nu)`` the angle of each actuated joint, in radians.
        target: The world's target position (its ``target_position``), or None for a world
            without one.
    """

    time: np.ndarray  # (T,)
    core_pos: np.ndarray  # (T, 3)
    joint_target: np.ndarray  # (T, nu)
    joint_angle: np.ndarray  # (T, nu)
    target: tuple[float, ...] | None = None  # the world's target, if it has one


def num_steps(task: EvaluationTask, model: mujoco.MjModel) -> int:
    """Physics steps of a run: ``round(duration / timestep)``, as `simple_runner` takes."""
    return max(1, round(task.duration / model.opt.timestep))


def frame_steps(nstep: int, record_every: int) -> np.ndarray:
    """Physics step indices of recorded frames: 0, R, 2R, ... and always the final step."""
    if record_every <= 0:
        return np.array([0, nstep])
    steps = np.arange(0, nstep + 1, record_every)
    return steps if steps[-1] == nstep else np.append(steps, nstep)


def _kinematics_frames(
    built: BuiltBody, qpos: np.ndarray, record_bodies: bool
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Core geom position (and robot body poses) for each row of ``qpos`` ``(T, nq)``."""
    model = built.model
    data = mujoco.MjData(model)
    frames = qpos.shape[0]
    core = np.empty((frames, 3))
    nb = len(built.robot_bodies)
    pos = np.empty((frames, nb, 3)) if record_bodies else None
    quat = np.empty((frames, nb, 4)) if record_bodies else None
    for t in range(frames):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        core[t] = data.geom_xpos[built.core_geom]
        if record_bodies:
            pos[t] = data.xpos[built.robot_bodies]
            quat[t] = data.xquat[built.robot_bodies]
    return core, pos, quat


def worst_fitness(maximise: bool) -> float:
    """The fitness of an evaluation that failed: worse than any a body can reach."""
    return -math.inf if maximise else math.inf


def _check_fitness_options(name: str, fitness_fn: FitnessFunction, options: dict[str, Any]) -> None:
    """Unknown fitness options raise before any physics runs, not after the rollout."""
    exc = fitness_options_error(fitness_fn, options)
    if exc is not None:
        raise TypeError(f"fitness function {name!r} rejected options {options}: {exc}")


def _score(
    name: str, fitness_fn: FitnessFunction, options: dict[str, Any], record: TrajectoryRecord
) -> float:
    try:
        value = fitness_fn(record, **options)
    except (TypeError, ValueError) as exc:  # e.g. a bad option value: the caller's mistake
        kind = TypeError if isinstance(exc, TypeError) else ValueError
        given = f" with options {options}" if options else ""
        raise kind(f"fitness function {name!r} failed{given}: {exc}") from exc
    except Exception as exc:
        raise _blame(exc, f"fitness function {name!r}") from None
    # The check's rule (`check_fitness`): a number, never a bool or a text ("0.03" read as one)
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"fitness function {name!r} returned {type(value).__name__}, not a float")
    try:
        return float(value)  # possibly NaN or infinite: the caller records it as ``invalid``
    except OverflowError:  # an int of more than 308 digits: no float holds it
        return math.inf


def read_only(values: np.ndarray) -> np.ndarray:
    """A read-only copy of ``values``: a view could be made writable again
    (``setflags(write=True)``) and write through to the recorded array; a copy cannot reach
    it."""
    copy = values.copy()
    copy.flags.writeable = False
    return copy


def _blame(exc: BaseException, plugin: str) -> BaseException:
    """``exc`` (type unchanged) noting which plugin raised it: the note travels with it from a
    worker (it is pickled with the exception) and names the plugin in the run's one line."""
    exc.add_note(f"raised by {plugin}")
    return exc


def _error_result(
    task: EvaluationTask, fitness_fn: FitnessFunction, exc: BaseException
) -> EvaluationResult:
    return EvaluationResult(
        eval_id=task.eval_id,
        fitness=worst_fitness(fitness_fn.maximise),
        status="error",
        error=_one_line(exc),
    )


def _finish(
    task: EvaluationTask,
    built: BuiltBody,
    fitness_fn: FitnessFunction,
    times: np.ndarray,
    qpos: np.ndarray,
    joint_target: np.ndarray,
    stable: bool,
    wall: float,
    poses: tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | None = None,
    backend: str = "mujoco",
) -> EvaluationResult:
    """Turn recorded frames into a result (kinematics, fitness, status).

    ``poses``: the core position and robot body poses of the frames where the caller computed
    them already (the Warp evaluator, on the device); else they come from ``qpos`` here.
    """
    if stable and not np.all(np.isfinite(qpos)):
        stable = False
    if poses is None:
        safe_qpos = np.where(np.isfinite(qpos), qpos, 0.0)
        poses = _kinematics_frames(built, safe_qpos, task.record_bodies)
    core, body_pos, body_quat = poses
    joint_angle = qpos[:, built.joint_qpos]
    record = TrajectoryRecord(  # read-only copies: what is recorded stays as it was
        time=read_only(times),
        core_pos=read_only(core),
        joint_target=read_only(joint_target),
        joint_angle=read_only(joint_angle),
        target=built.target,
    )
    fitness, status = worst_fitness(fitness_fn.maximise), "unstable"
    error = "physics became unstable (MuJoCo warning or non-finite state)"
    if stable:
        value = _score(task.fitness, fitness_fn, task.fitness_options, record)
        if math.isfinite(value):
            fitness, status, error = value, "ok", ""
        else:  # a number no ranking can use: kept out of the optimisers, its text recorded
            status = "invalid"
            error = f"fitness function {task.fitness!r} returned {value!r}, not a finite number"
    return EvaluationResult(
        eval_id=task.eval_id,
        fitness=fitness,
        status=status,
        error=error,
        descriptors=dict(built.descriptors),
        sim_time=float(times[-1]),
        wall_time=wall,
        time=times,
        core_pos=core,
        joint_target=joint_target,
        joint_angle=joint_angle,
        body_pos=body_pos,
        body_quat=body_quat,
        body_names=list(built.body_names),
        joint_names=list(built.joint_names),
        backend=backend,
    )
