"""Building: a task's body compiled in its world, once per body per process.

`build` decodes the genotype with its body encoder, spawns the robot in its world, compiles the
model (settled, with ``task.settle``) and keeps the last few bodies built (`BuiltBody`, with the
indices the engine reads every frame). Re-exported by `ariel.evaluation._engine`.
"""

from __future__ import annotations

import contextlib
import functools
import json
import threading
import time as _time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import mujoco
import numpy as np

from ariel.body_phenotypes.robogen_lite.constructor import (
    construct_mjspec_from_graph,
    validate_robot_graph,
)
from ariel.body_phenotypes.robogen_lite.descriptors import morphology_descriptors
from ariel.errors import BodyBuildError
from ariel.evaluation._task import EvaluationTask
from ariel.plugins import (
    BodyEncoder,
    DuplicatePluginError,
    Registry,
    UnknownPluginError,
    body_encoders,
    worlds,
)
from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.controllers.controller import actuator_bounds
from ariel.simulation.settle import settle_model
from ariel.utils.interrupts import raise_pending

if TYPE_CHECKING:
    from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule

__all__ = ["SPAWN_PREFIX", "BuiltBody", "build", "make_plugin", "robot_module"]

T = TypeVar("T")

SPAWN_PREFIX = "robot1_"


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


_BUILD_CACHE: OrderedDict[str, BuiltBody] = OrderedDict()
_BUILD_CACHE_SIZE = 4
_BUILD_CACHE_LOCK = threading.Lock()  # evaluations in two threads of one process


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


def make_plugin(registry: Registry[Callable[..., T]], name: str, options: dict[str, Any]) -> T:
    """``registry.make(name, **options)``; options it rejects raise naming the plugin."""
    try:
        return registry.make(name, **options)
    except (UnknownPluginError, DuplicatePluginError):
        raise
    except (TypeError, ValueError) as exc:  # an unknown keyword or a bad value: the caller's
        # unless a stop signal came: its exception, raised inside MuJoCo's bindings, came out
        # as "incompatible function arguments" (a traceback where Ctrl-C stops the run)
        raise_pending()
        kind = TypeError if isinstance(exc, TypeError) else ValueError
        raise kind(f"{registry.label} {name!r} rejected options {options}: {exc}") from exc


def robot_module(encoder: BodyEncoder, genotype: Any) -> tuple[CoreModule, dict[str, float]]:
    """The robot's root module (a CoreModule) and its morphology descriptors."""
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
    with _BUILD_CACHE_LOCK:
        cached = _BUILD_CACHE.get(key)
        if cached is not None:
            _BUILD_CACHE.move_to_end(key)
            return cached

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
    with _BUILD_CACHE_LOCK:
        _BUILD_CACHE[key] = built
        while len(_BUILD_CACHE) > _BUILD_CACHE_SIZE:
            _BUILD_CACHE.popitem(last=False)
    return built


def _one_line(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}"
    return text.splitlines()[0] if text else type(exc).__name__
