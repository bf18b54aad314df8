"""Different bodies in one launch: K robots packed into ONE MuJoCo model.

MuJoCo Warp steps many worlds of one model at once. To evaluate a generation's different bodies
together, `pack` puts K of them (one task each) into one model: world ``w`` of a batch then
holds brain candidate ``w`` of every robot.

* Same place: every robot is spawned where, and as, it would be alone (same spawn position,
  rotation and lift above the ground), so its coordinates, hence its float rounding, are those
  of its lone model; robot ``k`` (0-based) has the names prefix ``robot{k+1}_``.
* No robot touches another: robot ``k``'s geoms get the collision bit ``1 << k`` in place of
  bit 0 (contype and conaffinity), the world's geoms all robots' bits. Robot ``k`` collides with
  itself (its parts do, as alone) and with the world exactly as alone, never with robot ``j``.
  Each robot needs a bit of its own: at most `MAX_ROBOTS` (32, an int's bits) robots per model;
  more go in several packed models (`pack_groups`).
* Same start: each robot's reset pose is its lone model's ``qpos0`` (settled by `build`).
* Same model: `pack` checks that every robot's bodies, joints, dofs, geoms and actuators carry
  the numbers of its lone model, bit for bit.
* Few kernel compiles: MuJoCo Warp compiles some kernels for each model size, so a packed
  model takes the sparse Jacobian and is padded with inert dofs to `nv_bucket` dofs.

On the CPU, MuJoCo solves each robot's constraints as an island of its own: packed robots move
as alone to rounding (about 1e-15 after 0.3 s). MuJoCo Warp solves all robots of a world in one
Newton solve (one line search, one stopping rule), so there they agree to float32 rounding
(about 1e-6), as MuJoCo Warp agrees with the CPU.
"""

from __future__ import annotations

import functools
import itertools
import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from ariel.errors import BodyBuildError
from ariel.evaluation._build import SPAWN_PREFIX, BuiltBody, build, make_plugin, robot_module
from ariel.evaluation._task import EvaluationTask
from ariel.plugins import body_encoders, worlds
from ariel.simulation.control_callback import control_callback_unset

__all__ = [
    "MAX_ROBOTS",
    "PAD_PREFIX",
    "PackedModel",
    "PackedRobot",
    "nv_bucket",
    "pack",
    "pack_groups",
    "packable",
]

#: Robots per packed model: one collision bit each, 32 bits in MuJoCo's ``contype``.
MAX_ROBOTS = 32

#: Names of the inert padding bodies and joints (`nv_bucket`).
PAD_PREFIX = "pack_pad"
_PAD_INERTIA = 1e-9  # kg, kg m^2: far below any robot dof's, well above MuJoCo's minimum

# Per-robot model fields that must equal the lone model's, by the kind of object they index.
_SAME_FIELDS: dict[str, tuple[str, ...]] = {
    "body": ("pos", "quat", "ipos", "iquat", "mass", "inertia", "gravcomp", "margin"),
    "jnt": ("type", "pos", "axis", "range", "limited", "stiffness", "solref", "solimp", "margin"),
    "dof": ("armature", "damping", "frictionloss", "M0", "solref", "solimp"),
    "geom": (
        "type", "size", "pos", "quat", "friction", "solref", "solimp", "solmix", "margin", "gap",
        "condim", "priority", "rbound",
    ),
    "actuator": (
        "gainprm", "biasprm", "dynprm", "gear", "ctrlrange", "forcerange", "ctrllimited",
        "forcelimited", "gaintype", "biastype", "dyntype",
    ),
}  # fmt: skip


@dataclass(frozen=True)
class PackedRobot:
    """Where one robot lies in a packed model (ids and addresses in the packed model)."""

    built: BuiltBody  # its lone model, from `build(task)`
    prefix: str  # its names' prefix in the packed model, e.g. "robot3_"
    qpos: slice  # its qpos in the packed qpos; ``packed[qpos]`` is its lone qpos layout
    qvel: slice  # its dofs in the packed qvel (and qacc, qfrc_*)
    ctrl: slice  # its actuators in the packed ctrl, in its lone model's order
    core_geom: int
    robot_bodies: np.ndarray  # packed ids, in the order of ``built.robot_bodies``
    joint_qpos: np.ndarray  # packed qpos addresses, in the order of ``built.joint_qpos``


@dataclass
class PackedModel:
    """K robots in one model (see the module docs)."""

    model: mujoco.MjModel
    robots: tuple[PackedRobot, ...]
    #: The packed model's reset state (mjSTATE_FULLPHYSICS): every robot in its lone start pose.
    initial_state: np.ndarray
    #: Inert dofs after the robots' (`nv_bucket`): bodies named ``PAD_PREFIX + i``.
    padding: int = 0

    def robot_qpos(self, packed_qpos: np.ndarray, k: int) -> np.ndarray:
        """Robot ``k``'s qpos ``(..., nq_k)``, in its lone model's layout, from ``(..., nq)``
        (its qvel: ``packed_qvel[..., robots[k].qvel]``)."""
        return np.asarray(packed_qpos)[..., self.robots[k].qpos]

    def packed_ctrl(self, controls: Sequence[np.ndarray]) -> np.ndarray:
        """One control per robot ``(..., nu_k)`` -> the packed controls ``(..., nu)``."""
        if len(controls) != len(self.robots):
            raise ValueError(f"{len(controls)} controls for {len(self.robots)} robots")
        parts = [np.asarray(c, dtype=np.float64) for c in controls]
        shape = np.broadcast_shapes(*(p.shape[:-1] for p in parts))
        out = np.zeros((*shape, self.model.nu))
        for robot, part in zip(self.robots, parts, strict=True):
            out[..., robot.ctrl] = part
        return out


# --------------------------------------------------------------------------------------------
# What can be packed
# --------------------------------------------------------------------------------------------


def _world_key(task: EvaluationTask) -> str:
    return json.dumps([task.world, task.world_options], sort_keys=True)


@functools.lru_cache(maxsize=16)
def _world_reason(key: str) -> str | None:
    name, options = json.loads(key)
    world = make_plugin(worlds, name, options)
    with control_callback_unset():
        model = world.spec.compile()
    shared = {"joints (movable objects every robot would share)": model.njnt, "actuators": model.nu}
    shared |= {"equality constraints": model.neq, "tendons": model.ntendon, "flexes": model.nflex}
    for what, count in (shared | {"explicit contact pairs": model.npair}).items():
        if count:
            return f"world {name!r} has {what}: {count}"
    if not _bit0_only(model):
        return f"world {name!r} has geoms with collision bits other than bit 0 (contype 1)"
    return None


def _bit0_only(model: mujoco.MjModel, geoms: slice | np.ndarray = slice(None)) -> bool:
    bits = np.concatenate([model.geom_contype[geoms], model.geom_conaffinity[geoms]])
    return bool(np.all((bits == 0) | (bits == 1)))


def packable(task: EvaluationTask) -> str | None:
    """Why ``task``'s body cannot share a model with other bodies (`pack`); None if it can.

    The world must be static (no joints, actuators, equality constraints, tendons, flexes or
    explicit contact pairs: things every packed robot would share) and its geoms and the body's
    must collide by bit 0 only (contype and conaffinity 0 or 1), as all built-in worlds and
    bodies do. A body that cannot be built gives its build error.
    """
    reason = _world_reason(_world_key(task))
    if reason is not None:
        return reason
    try:
        return _body_reason(build(task))
    except BodyBuildError as exc:
        return str(exc)


def _body_reason(built: BuiltBody) -> str | None:
    geoms = _robot_geoms(built.model, built.robot_bodies)
    if not _bit0_only(built.model, geoms):
        return "the body has geoms with collision bits other than bit 0 (contype 1)"
    return None


def _robot_geoms(model: mujoco.MjModel, bodies: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.isin(model.geom_bodyid, bodies))


# --------------------------------------------------------------------------------------------
# Packing
# --------------------------------------------------------------------------------------------


def nv_bucket(nv: int) -> int:
    """The dofs a packed model of ``nv`` dofs is padded to (`pack`'s ``bucket``).

    MuJoCo Warp 4.0's sparse path (packed models take it) compiles a few kernels anew for each
    ``nv`` (4 modules: the initial Jaref, the fused line search and the blocked Cholesky); other
    sizes (bodies, geoms, joints, actuators, worlds, constraint rows) compile nothing new.
    Buckets: 32, then multiples of 16 up to 256, of 32 up to 512, of 64 up to 1024, ...: at
    most 16 dofs or 1/8 more than needed above 32, 8 buckets per doubling of ``nv``.
    """
    if nv <= 32:
        return 32
    step = max(16, 1 << (int(nv).bit_length() - 4))
    return -(-nv // step) * step


def pack_groups(
    tasks: Sequence[EvaluationTask], builts: Sequence[BuiltBody] | None = None
) -> list[PackedModel]:
    """`pack` for any number of tasks: as few models as `MAX_ROBOTS` allows, of even sizes
    (33 tasks: 16 and 17 robots), the tasks in order."""
    tasks = list(tasks)
    groups = -(-len(tasks) // MAX_ROBOTS)
    bounds = np.linspace(0, len(tasks), groups + 1).round().astype(int).tolist()
    return [
        pack(tasks[a:b], None if builts is None else builts[a:b])
        for a, b in itertools.pairwise(bounds)
    ]


def pack(
    tasks: Sequence[EvaluationTask],
    builts: Sequence[BuiltBody] | None = None,
    *,
    bucket: bool = True,
) -> PackedModel:
    """One model holding the body of every task (one robot per task, in order).

    The tasks must share a world and its options (spawn and settle may differ); each must be
    `packable`, and there may be at most `MAX_ROBOTS`. Raises ValueError otherwise (and
    `BodyBuildError` for a body that cannot be built). ``builts``: ``build(task)`` of each task
    where the caller has them already (`build` keeps only a few).

    ``bucket`` (default): the model gets the sparse Jacobian and `nv_bucket` dofs (inert
    padding dofs after the robots'), so that MuJoCo Warp compiles its kernels once per bucket
    rather than once per generation (see `nv_bucket`).
    """
    tasks = list(tasks)
    if not 1 <= len(tasks) <= MAX_ROBOTS:
        raise ValueError(f"pack() takes 1 to {MAX_ROBOTS} tasks, not {len(tasks)}")
    worlds_named = {_world_key(t) for t in tasks}
    if len(worlds_named) > 1:
        raise ValueError(f"packed tasks must share one world and its options: {worlds_named}")
    reason = _world_reason(_world_key(tasks[0]))
    builts = [build(t) for t in tasks] if builts is None else list(builts)
    if len(builts) != len(tasks):
        raise ValueError(f"{len(builts)} built bodies for {len(tasks)} tasks")
    for i, (task, built) in enumerate(zip(tasks, builts)):
        reason = reason or _body_reason(built)
        if reason is not None:
            raise ValueError(f"task {i} ({task.eval_id!r}) cannot be packed: {reason}")
    nv = sum(b.model.nv for b in builts)
    padding = nv_bucket(nv) - nv if bucket else 0
    model, prefixes = _packed_model(tasks, padding, sparse=bucket)
    robots = tuple(_locate(model, b, p) for b, p in zip(builts, prefixes))
    for k, robot in enumerate(robots):
        lone = robot.built.model
        # Computed by the compiler from all dofs at once: equal to 1e-16 (relative) only.
        model.body_invweight0[robot.robot_bodies] = lone.body_invweight0[robot.built.robot_bodies]
        model.dof_invweight0[robot.qvel] = lone.dof_invweight0
        _check_same(model, robot, k)
        model.qpos0[robot.qpos] = lone.qpos0  # its (settled) lone start pose
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return PackedModel(model=model, robots=robots, initial_state=state, padding=padding)


def _packed_model(
    tasks: list[EvaluationTask], padding: int, *, sparse: bool
) -> tuple[mujoco.MjModel, list[str]]:
    """The world with every task's robot as alone, each with its bit; ``padding`` inert dofs."""
    head = tasks[0]
    # A built-in world (`packable`): its spawn_prefix and spawns are not in the World protocol.
    world: Any = make_plugin(worlds, head.world, head.world_options)
    every = 0
    for k in range(len(tasks)):
        every |= _bit(k)
    for geom in world.spec.geoms:  # before any robot: these are the world's geoms
        _recolour(geom, every)
    prefixes = []
    for k, task in enumerate(tasks):
        encoder = make_plugin(body_encoders, task.body.encoder, task.body.options)
        core, _ = robot_module(encoder, task.body.genotype)
        offset = _lone_offset(task, core.spec)
        for geom in core.spec.geoms:
            _recolour(geom, _bit(k))
        world.spawn(
            core.spec,
            position=task.spawn_position,
            rotation=task.spawn_rotation,
            correct_collision_with_floor=False,
        )
        prefix = f"{world.spawn_prefix}{world.spawns}_"
        world.spec.body(prefix + core.spec.worldbody.name).pos = offset
        prefixes.append(prefix)
    for i in range(padding):
        _add_inert_dof(world.spec, f"{PAD_PREFIX}{i}")
    if sparse:
        world.spec.option.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE
    with control_callback_unset():
        return world.spec.compile(), prefixes


def _add_inert_dof(spec: mujoco.MjSpec, name: str) -> None:
    """A body with one hinge about z through its centre of mass and no geoms: no contact, no
    gravity torque, no coupling; at rest it stays at rest, exactly. Its tiny inertia adds
    nothing to the trace of the mass matrix, which scales the solver's stopping rule."""
    body = spec.worldbody.add_body(name=name, mass=_PAD_INERTIA, inertia=[_PAD_INERTIA] * 3)
    body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0])


def _bit(k: int) -> int:
    """Robot ``k``'s collision bit as a C int (bit 31 is the sign bit)."""
    return (1 << k) - (1 << 32 if k == 31 else 0)


def _recolour(geom: mujoco.MjsGeom, bits: int) -> None:
    """Bit 0 (the only one `packable` allows) becomes ``bits``, in contype and conaffinity."""
    geom.contype = bits if geom.contype else 0
    geom.conaffinity = bits if geom.conaffinity else 0


def _lone_offset(task: EvaluationTask, robot_spec: mujoco.MjSpec) -> list[float]:
    """Where the world's spawn puts the robot's root when alone (as in `build`): spawning
    into the packed world would lift each robot by compiling all robots spawned before it."""
    # A built-in world (`packable`): its spawn_prefix and spawns are not in the World protocol.
    world: Any = make_plugin(worlds, task.world, task.world_options)
    world.spawn(robot_spec, position=task.spawn_position, rotation=task.spawn_rotation)
    prefix = f"{world.spawn_prefix}{world.spawns}_"
    return list(world.spec.body(prefix + robot_spec.worldbody.name).pos)


def _locate(model: mujoco.MjModel, built: BuiltBody, prefix: str) -> PackedRobot:
    """Robot ``prefix``'s ids and addresses in ``model``; its joints, dofs and actuators must
    map to contiguous ranges in its lone model's order."""
    lone = built.model

    def packed_id(kind: mujoco.mjtObj, name: str) -> int:
        ident = mujoco.mj_name2id(model, kind, prefix + name.removeprefix(SPAWN_PREFIX))
        if ident < 0:
            raise RuntimeError(f"packed model lacks {prefix + name!r}")
        return ident

    bodies = np.array([packed_id(mujoco.mjtObj.mjOBJ_BODY, n) for n in built.body_names])
    root = int(bodies[0])
    qpos0 = int(model.jnt_qposadr[model.body_jntadr[root]])
    dof0 = int(model.body_dofadr[root])
    acts = [packed_id(mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in built.joint_names]
    act0 = acts[0] if acts else 0
    robot = PackedRobot(
        built=built,
        prefix=prefix,
        qpos=slice(qpos0, qpos0 + lone.nq),
        qvel=slice(dof0, dof0 + lone.nv),
        ctrl=slice(act0, act0 + lone.nu),
        core_geom=packed_id(mujoco.mjtObj.mjOBJ_GEOM, SPAWN_PREFIX + "core"),
        robot_bodies=bodies,
        joint_qpos=qpos0 + built.joint_qpos,
    )
    joints = _joints(model, robot)
    body_of = dict(zip(built.robot_bodies.tolist(), bodies.tolist()))
    mapped = (
        acts == list(range(act0, act0 + lone.nu))
        and lone.body_jntadr[built.robot_bodies[0]] == 0  # no world joints (`packable`)
        and np.array_equal(model.jnt_qposadr[joints] - qpos0, lone.jnt_qposadr)
        and np.array_equal(model.jnt_dofadr[joints] - dof0, lone.jnt_dofadr)
        and [body_of[b] for b in lone.jnt_bodyid] == model.jnt_bodyid[joints].tolist()
        and np.array_equal(model.actuator_trnid[robot.ctrl, 0], joints[lone.actuator_trnid[:, 0]])
    )
    if not mapped:
        raise RuntimeError(f"robot {prefix!r}: joints or actuators do not map to its lone model")
    return robot


def _joints(model: mujoco.MjModel, robot: PackedRobot) -> np.ndarray:
    first = int(model.body_jntadr[robot.robot_bodies[0]])
    return np.arange(first, first + robot.built.model.njnt)


def _check_same(model: mujoco.MjModel, robot: PackedRobot, k: int) -> None:
    """Robot ``k``'s numbers in the packed model are its lone model's, bit for bit."""
    lone = robot.built.model
    lone_geoms = _robot_geoms(lone, robot.built.robot_bodies)
    packed_geoms = _robot_geoms(model, robot.robot_bodies)
    ids = {
        "body": (robot.robot_bodies, robot.built.robot_bodies),
        "jnt": (_joints(model, robot), np.arange(lone.njnt)),
        "dof": (np.arange(model.nv)[robot.qvel], np.arange(lone.nv)),
        "geom": (packed_geoms, lone_geoms),
        "actuator": (np.arange(model.nu)[robot.ctrl], np.arange(lone.nu)),
    }
    for kind, fields in _SAME_FIELDS.items():
        packed_ids, lone_ids = ids[kind]
        for field in fields:
            a = getattr(model, f"{kind}_{field}")[packed_ids]
            b = getattr(lone, f"{kind}_{field}")[lone_ids]
            if a.shape != b.shape or not np.array_equal(a, b):
                raise RuntimeError(f"robot {k}: packed {kind}_{field} differs from its lone model")
    for field in ("contype", "conaffinity"):
        a = getattr(model, f"geom_{field}")[packed_geoms] != 0
        if not np.array_equal(a, getattr(lone, f"geom_{field}")[lone_geoms] != 0):
            raise RuntimeError(f"robot {k}: packed geom_{field} does not match its lone model")
