"""The rollout engine: evaluation tasks -> results, with physics as nearly all of the cost.

* A body is compiled once per process (`build`, cached) and every brain candidate of that body
  runs on that model.
* Open-loop controllers (the CPGs) are functions of time: the whole control sequence of every
  candidate is computed in numpy first, then all candidates step in C with `mujoco.rollout`
  across threads (GIL released).
* Closed-loop controllers step in chunks: ``mj_step(model, data, nstep=control_period)``
  between policy calls, never a Python callback per physics step.
* Control semantics are the tutorial `Controller`'s (same formula, `blend_and_clip`): the
  controller runs at physics steps ``k % control_period == 0``, its output is blended with the
  previous control by the task's ``smoothing`` (the tutorial's ``alpha``, 0.5) and clipped to
  the actuator ranges. Hence the fast path and the tutorial path give identical trajectories.
* Failures: the caller's mistakes (unknown plugin names, options a plugin rejects, a wrong
  number of parameters) raise at once. A genotype whose body cannot be built gives status
  ``error`` (`BodyBuildError` inside), physics instability (MuJoCo warnings such as bad
  accelerations, NaN or inf state) status ``unstable``, a fitness function that returns NaN or
  an infinity status ``invalid`` (the value's text in ``error``); all with the worst fitness.
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import json
import math
import queue
import sys
import threading
import time as _time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout as _rollout

from ariel.errors import BodyBuildError
from ariel.evaluation._heap import steady_heap
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.controllers.controller import actuator_bounds, blend_and_clip
from ariel.simulation.settle import settle_model

__all__ = [
    "BodyBuildError",
    "BuiltBody",
    "TrajectoryRecord",
    "build",
    "control_sequence",
    "evaluate",
    "evaluate_batch",
    "frame_steps",
    "open_loop_targets",
    "worst_fitness",
]

SPAWN_PREFIX = "robot1_"
_BAD_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)


@dataclass(frozen=True)
class TrajectoryRecord:
    """What a fitness function sees: the recorded frames of one evaluation.

    The frames are the result's (`EvaluationResult`): every ``record_every`` physics steps,
    first at t = 0 and last at the end of the run; ``T`` frames, ``nu`` actuators.

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


@dataclass
class BuiltBody:
    """A compiled body in its world, plus the indices the engine reads every frame."""

    model: mujoco.MjModel
    descriptors: dict[str, float]
    core_geom: int
    robot_bodies: np.ndarray
    body_names: list[str]
    joint_names: list[str]
    joint_qpos: np.ndarray
    low: np.ndarray
    high: np.ndarray
    target: tuple[float, ...] | None
    initial_state: np.ndarray
    build_time: float


# --------------------------------------------------------------------------------------------
# Building (once per body per process)
# --------------------------------------------------------------------------------------------

_BUILD_CACHE: OrderedDict[str, BuiltBody] = OrderedDict()
_BUILD_CACHE_SIZE = 4


def _build_key(task: EvaluationTask) -> str:
    return json.dumps(
        [
            task.body.key,
            task.world,
            task.world_options,
            task.spawn_position,
            task.spawn_rotation,
            task.settle,
        ],
        sort_keys=True,
    )


def make_plugin(registry: Any, name: str, options: dict[str, Any]) -> Any:
    """``registry.make(name, **options)``; options it rejects raise naming the plugin."""
    from ariel.plugins import DuplicatePluginError, UnknownPluginError

    try:
        return registry.make(name, **options)
    except (UnknownPluginError, DuplicatePluginError):
        raise
    except (TypeError, ValueError) as exc:  # an unknown keyword or a bad value: the caller's
        kind = TypeError if isinstance(exc, TypeError) else ValueError
        raise kind(f"{registry.label} {name!r} rejected options {options}: {exc}") from exc


def robot_module(encoder: Any, genotype: Any) -> tuple[Any, dict[str, float]]:
    """The robot's root module (a CoreModule) and its morphology descriptors."""
    from ariel.body_phenotypes.robogen_lite.constructor import (
        construct_mjspec_from_graph,
        validate_robot_graph,
    )
    from ariel.body_phenotypes.robogen_lite.descriptors import morphology_descriptors

    build_direct = getattr(encoder, "build", None)
    tree = None
    if build_direct is None:
        tree = validate_robot_graph(encoder.decode(genotype))
        core = construct_mjspec_from_graph(tree)
    else:
        core = build_direct(genotype)
        with contextlib.suppress(ValueError):  # a body without a graph form has no descriptors
            tree = validate_robot_graph(encoder.decode(genotype))
    descriptors = morphology_descriptors(tree) if tree is not None else {}
    return core, descriptors


def build(task: EvaluationTask) -> BuiltBody:
    """Compile ``task``'s body in its world (cached per process by body, world, spawn and
    settle); with ``task.settle`` the model's reset pose is the settled one (`settle_model`).

    Only the task's body, world, spawn pose and ``settle`` matter; its controller, params and
    timing are not read. The last few bodies built are cached, so a repeated call is cheap.

    Args:
        task: The evaluation task whose body to build.

    Returns:
        The body built: its compiled ``model`` (a ``mujoco.MjModel``; the robot's names are
        prefixed ``robot1_``), morphology ``descriptors``, the indices and names the engine
        reads every frame, the actuator ranges, the world's ``target`` and the initial state.
        The cache shares it: don't change it.

    Raises:
        BodyBuildError: The genotype cannot become a body (decoding, construction, spawning
            or compiling failed; the cause is chained).
        UnknownPluginError: No body encoder or world of that name.
        TypeError: The encoder or world rejected the options (an unknown keyword).
        ValueError: The encoder or world rejected an option's value.
    """
    key = _build_key(task)
    cached = _BUILD_CACHE.get(key)
    if cached is not None:
        _BUILD_CACHE.move_to_end(key)
        return cached

    from ariel.plugins import body_encoders, worlds

    start = _time.perf_counter()
    encoder = make_plugin(body_encoders, task.body.encoder, task.body.options)
    world = make_plugin(worlds, task.world, task.world_options)
    try:
        core, descriptors = robot_module(encoder, task.body.genotype)
        world.spawn(core.spec, position=task.spawn_position, rotation=task.spawn_rotation)
        with control_callback_unset():
            model = world.spec.compile()
        core_geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, SPAWN_PREFIX + "core")
        if core_geom < 0:
            raise ValueError(f"the robot has no core geom named {SPAWN_PREFIX + 'core'!r}")
        settle_model(model, task.settle)
    except Exception as exc:
        raise BodyBuildError(
            f"body encoder {task.body.encoder!r}: this genotype cannot be built: {_one_line(exc)}"
        ) from exc

    body_name = functools.partial(mujoco.mj_id2name, model, mujoco.mjtObj.mjOBJ_BODY)
    names = [body_name(i) for i in range(model.nbody)]
    robot_bodies = np.array([i for i, n in enumerate(names) if n.startswith(SPAWN_PREFIX)])
    joints = model.actuator_trnid[:, 0]
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    low, high = actuator_bounds(model)
    target = getattr(world, "target_position", None)
    built = BuiltBody(
        model=model,
        descriptors=descriptors,
        core_geom=int(core_geom),
        robot_bodies=robot_bodies,
        body_names=[names[i] for i in robot_bodies],
        joint_names=[
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(model.nu)
        ],
        joint_qpos=model.jnt_qposadr[joints].copy(),
        low=low,
        high=high,
        target=None if target is None else tuple(float(v) for v in target),
        initial_state=state,
        build_time=_time.perf_counter() - start,
    )
    _BUILD_CACHE[key] = built
    while len(_BUILD_CACHE) > _BUILD_CACHE_SIZE:
        _BUILD_CACHE.popitem(last=False)
    return built


# --------------------------------------------------------------------------------------------
# Control and recording helpers (shared by both paths)
# --------------------------------------------------------------------------------------------


def num_steps(task: EvaluationTask, model: mujoco.MjModel) -> int:
    """Physics steps of a run: ``round(duration / timestep)``, as `simple_runner` takes."""
    return max(1, round(task.duration / model.opt.timestep))


def frame_steps(nstep: int, record_every: int) -> np.ndarray:
    """Physics step indices of recorded frames: 0, R, 2R, ... and always the final step."""
    if record_every <= 0:
        return np.array([0, nstep])
    steps = np.arange(0, nstep + 1, record_every)
    return steps if steps[-1] == nstep else np.append(steps, nstep)


def held_controls(
    targets: np.ndarray, smoothing: float, low: Any, high: Any, ctrl: np.ndarray | None = None
) -> np.ndarray:
    """The control held after each controller call, ``(B, C, nu)``, from targets ``(B, C, nu)``.

    Call ``c`` sets ``ctrl = blend_and_clip(ctrl, target_c, smoothing, low, high)`` (the
    tutorial `Controller`'s formula); ``ctrl`` starts at zero (a reset) unless given.
    """
    batch, calls, nu = targets.shape
    held = np.empty_like(targets)
    ctrl = np.zeros((batch, nu)) if ctrl is None else ctrl
    for c in range(calls):
        ctrl = blend_and_clip(ctrl, targets[:, c], smoothing, low, high)
        held[:, c] = ctrl
    return held


def control_sequence(
    targets: np.ndarray, nstep: int, period: int, smoothing: float, low: Any, high: Any
) -> np.ndarray:
    """Per-step controls ``(B, nstep, nu)``: each call's control holds for ``period`` steps."""
    held = held_controls(targets, smoothing, low, high)
    # min(): a period longer than the run (one call) must not allocate period columns.
    return np.repeat(held, min(period, nstep), axis=1)[:, :nstep]


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


def _check_fitness_options(name: str, fitness_fn: Any, options: dict[str, Any]) -> None:
    """Unknown fitness options raise before any physics runs, not after the rollout."""
    try:
        signature = inspect.signature(fitness_fn)
    except (TypeError, ValueError):  # no signature to read (e.g. a C function): checked later
        return
    try:
        signature.bind(None, **options)
    except TypeError as exc:
        raise TypeError(f"fitness function {name!r} rejected options {options}: {exc}") from None


def _score(name: str, fitness_fn: Any, options: dict[str, Any], record: TrajectoryRecord) -> float:
    try:
        value = float(fitness_fn(record, **options))
    except (TypeError, ValueError) as exc:  # e.g. a bad option value: the caller's mistake
        kind = TypeError if isinstance(exc, TypeError) else ValueError
        raise kind(f"fitness function {name!r} failed with options {options}: {exc}") from exc
    except Exception as exc:
        raise _blame(exc, f"fitness function {name!r}") from None
    return value  # possibly NaN or infinite: the caller records it as ``invalid``


def _blame(exc: BaseException, plugin: str) -> BaseException:
    """``exc`` (type unchanged) noting which plugin raised it: the note travels with it from a
    worker (it is pickled with the exception) and names the plugin in the run's one line."""
    exc.add_note(f"raised by {plugin}")
    return exc


def _one_line(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}"
    return text.splitlines()[0] if text else type(exc).__name__


def _error_result(task: EvaluationTask, fitness_fn: Any, exc: BaseException) -> EvaluationResult:
    return EvaluationResult(
        eval_id=task.eval_id,
        fitness=worst_fitness(fitness_fn.maximise),
        status="error",
        error=_one_line(exc),
    )


# --------------------------------------------------------------------------------------------
# Open loop: all candidates of one body in one threaded rollout
# --------------------------------------------------------------------------------------------

_ROLLOUTS: dict[int, _rollout.Rollout] = {}


def _rollout_pool(nthread: int) -> _rollout.Rollout:
    pool = _ROLLOUTS.get(nthread)
    if pool is None:
        pool = _ROLLOUTS[nthread] = _rollout.Rollout(nthread=nthread)
    return pool


def open_loop_targets(
    controller: Any,
    params: np.ndarray,
    seeds: Sequence[int],
    sample_times: np.ndarray,
    model: mujoco.MjModel,
    *,
    name: str = "",
) -> np.ndarray:
    """Targets ``(B, T, nu)`` of an open-loop controller for rows ``params`` with their seeds.

    ``controller.targets`` is called once per distinct seed on that seed's rows (vectorised
    within the group) and always gets one Python ``int``, as the protocol promises; results
    come back in input order. Shapes and values are checked (a plugin's bug raises here).
    """
    label = f"controller {name or type(controller).__name__!r}"
    rows_by_seed: dict[int, list[int]] = {}
    for row, seed in enumerate(seeds):
        rows_by_seed.setdefault(int(seed), []).append(row)
    out = np.empty((len(seeds), sample_times.size, model.nu))
    for seed, rows in rows_by_seed.items():
        try:
            part = np.asarray(controller.targets(params[rows], sample_times, model, seed=seed))
        except Exception as exc:
            raise _blame(exc, label) from None
        if part.shape != (len(rows), sample_times.size, model.nu):
            raise ValueError(
                f"{label}: targets() returned shape {part.shape}; expected "
                f"{(len(rows), sample_times.size, model.nu)} (candidates, calls, actuators)"
            )
        if not np.all(np.isfinite(part)):
            raise ValueError(f"{label}: targets() returned NaN or inf")
        out[rows] = part
    return out


def _open_loop(
    tasks: Sequence[EvaluationTask],
    built: BuiltBody,
    controller: Any,
    fitness_fn: Any,
    nthread: int,
) -> list[EvaluationResult]:
    head = tasks[0]
    model = built.model
    nstep = num_steps(head, model)
    period = head.control_period
    smoothing = head.smoothing
    dt = model.opt.timestep
    call_times = np.arange(0, nstep, period) * dt
    params = np.array([t.params for t in tasks], dtype=np.float64)

    from ariel.evaluation._threads import evaluation_threads

    start = _time.perf_counter()
    # The pipelined path keeps a second thread busy: only where this process has CPUs to spare.
    if len(tasks) == 1 and hasattr(controller, "iter_targets") and evaluation_threads() > 1:
        states, controls = _pipelined_single(
            head, built, controller, params, call_times, nstep, period, smoothing
        )
    else:
        seeds = [t.seed for t in tasks]
        targets = open_loop_targets(
            controller, params, seeds, call_times, model, name=head.controller
        )
        controls = control_sequence(targets, nstep, period, smoothing, built.low, built.high)
        nthread = max(1, min(nthread, len(tasks)))
        datas = [mujoco.MjData(model) for _ in range(nthread)]
        with control_callback_unset():
            states, _ = _rollout_pool(nthread).rollout(
                model, datas, built.initial_state[None, :], controls, nstep=nstep
            )
    wall = (_time.perf_counter() - start) / len(tasks)

    qpos_slice = slice(1, 1 + model.nq)  # FULLPHYSICS state: time, qpos, qvel, ...
    steps = frame_steps(nstep, head.record_every)
    results = []
    for b, task in enumerate(tasks):
        final_time = states[b, -1, 0]
        stable = math.isclose(final_time, nstep * dt, rel_tol=0, abs_tol=dt / 2) and bool(
            np.all(np.isfinite(states[b, -1]))
        )
        qpos = np.where(
            (steps == 0)[:, None],
            built.initial_state[qpos_slice],
            states[b, np.maximum(steps - 1, 0), qpos_slice],
        )
        joint_target = controls[b, np.minimum(steps, nstep - 1)]
        results.append(
            _finish(task, built, fitness_fn, steps * dt, qpos, joint_target, stable, wall)
        )
    return results


def _pipelined_single(
    task: EvaluationTask,
    built: BuiltBody,
    controller: Any,
    params: np.ndarray,
    call_times: np.ndarray,
    nstep: int,
    period: int,
    smoothing: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One candidate: compute the CPG (Python) on a second thread while physics (C) steps.

    Physics runs as consecutive rollouts carrying the solver warm start, which is bit for bit
    one continuous rollout. The GIL switch interval is shortened meanwhile so the stepping
    thread gets the GIL back promptly between chunks.
    """
    model = built.model
    pieces: queue.SimpleQueue[Any] = queue.SimpleQueue()
    # Pieces of 1, 2, 4, ... 16 controller calls: stepping starts almost at once, and the
    # CPG thread then stays ahead of the physics.
    chunks: list[int] = []
    while sum(chunks) < call_times.size:
        chunks.append(min(2 ** len(chunks), 16, call_times.size - sum(chunks)))

    def produce() -> None:
        try:
            for piece in controller.iter_targets(
                params, call_times, model, seed=int(task.seed), chunks=chunks
            ):
                pieces.put(piece)
        except BaseException as exc:  # handed to the stepping thread, which raises it
            pieces.put(exc)

    nstate = built.initial_state.size
    states = np.empty((1, nstep, nstate))
    controls = np.empty((1, nstep, model.nu))
    data = mujoco.MjData(model)
    state = built.initial_state[None, :].copy()
    warmstart = np.zeros((1, model.nv))
    ctrl = np.zeros((1, model.nu))
    done_calls = 0
    producer = threading.Thread(target=produce, name="ariel-cpg", daemon=True)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    try:
        producer.start()
        with control_callback_unset():
            for _ in chunks:
                piece = pieces.get()
                if isinstance(piece, BaseException):
                    raise piece
                if piece.shape[1] == 0:
                    continue
                held = held_controls(piece, smoothing, built.low, built.high, ctrl)
                ctrl = held[:, -1]
                k0 = done_calls * period
                done_calls += piece.shape[1]
                k1 = min(done_calls * period, nstep)
                repeat = min(period, k1 - k0)  # one call when the period outlasts the rest
                controls[:, k0:k1] = np.repeat(held, repeat, axis=1)[:, : k1 - k0]
                out, _ = _rollout_pool(1).rollout(
                    model,
                    data,
                    state,
                    controls[:, k0:k1],
                    nstep=k1 - k0,
                    initial_warmstart=warmstart,
                )
                states[:, k0:k1] = out
                if not math.isclose(out[0, -1, 0], k1 * model.opt.timestep, abs_tol=1e-9):
                    states[:, k1:] = out[:, -1:]  # unstable: freeze, as rollout itself does
                    controls[:, k1:] = ctrl[:, None]
                    break
                state = out[:, -1]
                warmstart = data.qacc_warmstart[None, :].copy()
    finally:
        sys.setswitchinterval(interval)
        producer.join()
    return states, controls


def _finish(
    task: EvaluationTask,
    built: BuiltBody,
    fitness_fn: Any,
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
    record = TrajectoryRecord(
        time=times,
        core_pos=core,
        joint_target=joint_target,
        joint_angle=qpos[:, built.joint_qpos],
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
        joint_angle=record.joint_angle,
        body_pos=body_pos,
        body_quat=body_quat,
        body_names=list(built.body_names),
        joint_names=list(built.joint_names),
        backend=backend,
    )


# --------------------------------------------------------------------------------------------
# Closed loop: chunked stepping between policy calls
# --------------------------------------------------------------------------------------------


def _closed_loop(
    task: EvaluationTask, built: BuiltBody, controller: Any, fitness_fn: Any
) -> EvaluationResult:
    from ariel.simulation.controllers.observations import hinge_observation

    model = built.model
    nstep = num_steps(task, model)
    period = task.control_period
    smoothing = task.smoothing
    policy = controller.make_policy(np.asarray(task.params), model)
    observe = getattr(controller, "observation", hinge_observation)
    steps = frame_steps(nstep, task.record_every)
    wanted = set(steps.tolist())
    qpos = np.empty((steps.size, model.nq))
    targets = np.empty((steps.size, model.nu))

    start = _time.perf_counter()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    boundaries = sorted(set(range(0, nstep, period)) | wanted)
    frame = 0
    stable = True
    with control_callback_unset():
        for i, k in enumerate(boundaries):
            if k % period == 0 and k < nstep:
                try:
                    out = np.asarray(policy(observe(model, data)), dtype=np.float64)
                except Exception as exc:
                    raise _blame(exc, f"controller {task.controller!r}") from None
                if out.shape != (model.nu,) or not np.all(np.isfinite(out)):
                    raise ValueError(
                        f"policy returned {out.shape} values (NaN/inf or wrong size); "
                        f"model has {model.nu} actuators"
                    )
                data.ctrl[:] = blend_and_clip(data.ctrl, out, smoothing, built.low, built.high)
            if k in wanted:
                qpos[frame] = data.qpos
                targets[frame] = data.ctrl
                frame += 1
            if k < nstep:
                mujoco.mj_step(model, data, nstep=boundaries[i + 1] - k)
                if any(data.warning[w].number for w in _BAD_WARNINGS) or not np.all(
                    np.isfinite(data.qpos)
                ):
                    stable = False
                    qpos[frame:] = data.qpos
                    targets[frame:] = data.ctrl
                    break
    wall = _time.perf_counter() - start
    return _finish(task, built, fitness_fn, steps * model.opt.timestep, qpos, targets, stable, wall)


# --------------------------------------------------------------------------------------------
# Public entry points
# --------------------------------------------------------------------------------------------


def _group_key(task: EvaluationTask) -> str:
    return json.dumps(
        [
            _build_key(task),
            task.controller,
            task.controller_options,
            task.fitness,
            task.fitness_options,
            task.duration,
            task.control_period,
            task.smoothing,
            task.record_every,
            task.record_bodies,
        ],
        sort_keys=True,
    )


def evaluate_batch(
    tasks: Sequence[EvaluationTask], *, nthread: int | None = None
) -> list[EvaluationResult]:
    """Evaluate many tasks, compiling each body once; results in input order.

    Tasks that share a body, world, controller and timing run as one batch: open-loop ones in a
    single threaded rollout. Every group is checked before any physics runs. A body that cannot
    be built gives ``error`` results, unstable physics ``unstable`` ones.

    Args:
        tasks: The evaluation tasks, in any mix of bodies, worlds and controllers.
        nthread: Threads of an open-loop batch's rollout (at most one per task of the batch);
            None (the default): `evaluation_threads`, this process's share of the CPUs.

    Returns:
        One `EvaluationResult` per task, in the order of ``tasks``.

    Raises:
        TypeError: An item of ``tasks`` is not an `EvaluationTask`, or a plugin rejected its
            options (an unknown keyword).
        UnknownPluginError: A plugin name that nothing provides.
        ValueError: A task's params do not number the controller's ``num_parameters`` for its
            body, or a plugin rejected an option's value.

    Example:
        ```python
        import numpy as np

        from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch
        from ariel.plugins import controllers

        body = BodySpec("prebuilt", "gecko")
        model = build(EvaluationTask(body=body)).model
        params = controllers.make("na_cpg").random_parameters(model, np.random.default_rng(1), 4)
        tasks = [
            EvaluationTask(body=body, params=p, duration=2.0, eval_id=f"c{i}")
            for i, p in enumerate(params)
        ]
        for result in evaluate_batch(tasks):
            print(result.eval_id, result.status, round(result.fitness, 3))
        ```
    """
    from ariel.evaluation._threads import evaluation_threads

    steady_heap()  # each batch's arrays of megabytes come and go: keep the heap from growing
    if nthread is None:
        nthread = evaluation_threads()
    threads: int = nthread
    return evaluate_groups(
        tasks, lambda g: _open_loop(g.tasks, g.built, g.controller, g.fitness_fn, threads)
    )


def evaluate_groups(
    tasks: Sequence[EvaluationTask],
    open_loop: Callable[[TaskGroup], list[EvaluationResult]],
) -> list[EvaluationResult]:
    """Checks and groups ``tasks`` (`prepare_groups`), then runs every group: an open-loop one
    by ``open_loop`` (all its tasks), a closed-loop one task by task here; input order."""
    results, ready = prepare_groups(tasks)
    for group in ready:
        for i, out in zip(group.indices, evaluate_group(group, open_loop)):
            results[i] = out
    return results  # type: ignore[return-value]


def evaluate_group(
    group: TaskGroup, open_loop: Callable[[TaskGroup], list[EvaluationResult]]
) -> list[EvaluationResult]:
    """One group's results: an open-loop group by ``open_loop``, a closed-loop one (a policy
    per controller call) on the CPU here, task by task."""
    if group.controller.open_loop:
        return open_loop(group)
    return [_closed_loop(t, group.built, group.controller, group.fitness_fn) for t in group.tasks]


@dataclass
class TaskGroup:
    """Tasks that share a body, world, controller and timing: they run as one batch."""

    indices: list[int]  # positions in the caller's list
    tasks: list[EvaluationTask]
    built: BuiltBody
    controller: Any
    fitness_fn: Any


def prepare_groups(
    tasks: Sequence[EvaluationTask],
) -> tuple[list[EvaluationResult | None], list[TaskGroup]]:
    """Group ``tasks`` into batches and check each before any physics runs.

    Returns the results known already (``error`` ones for bodies that cannot be built; None
    elsewhere) and the groups to run. Unknown plugin names, options a plugin rejects and wrong
    parameter counts raise.
    """
    from ariel.plugins import controllers, fitness_functions

    groups: dict[str, list[int]] = {}
    for i, task in enumerate(tasks):
        if not isinstance(task, EvaluationTask):
            raise TypeError(f"tasks must be EvaluationTask objects, got {type(task).__name__}")
        groups.setdefault(_group_key(task), []).append(i)

    results: list[EvaluationResult | None] = [None] * len(tasks)
    ready: list[TaskGroup] = []
    for indices in groups.values():
        group = [tasks[i] for i in indices]
        head = group[0]
        controller = make_plugin(controllers, head.controller, head.controller_options)
        fitness_fn = fitness_functions.get(head.fitness)
        _check_fitness_options(head.fitness, fitness_fn, head.fitness_options)
        try:
            built = build(head)
        except BodyBuildError as exc:  # a genotype that cannot be built is a result
            for i, task in zip(indices, group):
                results[i] = _error_result(task, fitness_fn, exc)
            continue
        expected = controller.num_parameters(built.model)
        for task in group:
            if len(task.params) != expected:
                raise ValueError(
                    f"controller {task.controller!r} needs {expected} parameters for this body "
                    f"({built.model.nu} actuators); task {task.eval_id!r} has {len(task.params)}"
                )
        ready.append(TaskGroup(indices, group, built, controller, fitness_fn))
    return results, ready


def evaluate(task: EvaluationTask) -> EvaluationResult:
    """Evaluate one task (a pure function of the task).

    The same as ``evaluate_batch([task], nthread=1)[0]``: see `evaluate_batch` for what is
    checked and raised.

    Args:
        task: The evaluation to run: body, world, controller with its params, fitness.

    Returns:
        The task's result: fitness, status and the recorded frames.

    Example:
        ```python
        import numpy as np

        from ariel.evaluation import BodySpec, EvaluationTask, evaluate

        # The gecko has 8 actuators; the default controller, "na_cpg", takes 5 numbers each.
        params = np.random.default_rng(0).uniform(-1.0, 1.0, 40)
        task = EvaluationTask(body=BodySpec("prebuilt", "gecko"), params=params, duration=2.0)
        result = evaluate(task)
        print(result.status, result.fitness, result.core_pos[-1])
        ```
    """
    return evaluate_batch([task], nthread=1)[0]
