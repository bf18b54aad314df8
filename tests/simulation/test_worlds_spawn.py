"""Spawning robots in every world: 1 cm above the ground under them, and stable physics.

One fixture is parametrised over every world class the package exports, so a new world is
tested the day it is added. The clearance is measured independently of the implementation:
lower the compiled robot until MuJoCo reports a contact with the world (bisection).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
import pytest

from ariel.simulation import environments
from ariel.simulation.environments import BaseWorld, OlympicArena

WORLD_CLASSES = [
    getattr(environments, name)
    for name in environments.__all__
    if issubclass(getattr(environments, name), BaseWorld) and name != "BaseWorld"
]
WORLD_IDS = [cls.__name__ for cls in WORLD_CLASSES]

# (position, rotation in degrees): origin, yawed, rolled on its side, pitched.
SPAWNS = [
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((1.3, -0.8, 0.0), (0.0, 0.0, 45.0)),
    ((-1.6, 1.1, 0.0), (90.0, 0.0, 0.0)),
    ((0.7, 0.4, 0.0), (0.0, 30.0, 0.0)),
]
# The arena is 2 m wide: one spawn per section (flat, rugged, flat, incline).
ARENA_POSITIONS = [(0.0, 0.0, 0.0), (1.5, -0.3, 0.0), (-1.5, 0.1, 0.0), (3.3, -0.2, 0.0)]


def spawn_position(world_cls: type, index: int) -> tuple[float, float, float]:
    if issubclass(world_cls, OlympicArena):
        return ARENA_POSITIONS[index]
    return SPAWNS[index][0]


# ---------------------------------------------------------------------------------------------
# Robots: the prebuilt gecko and a random NDE robot (built through the tutorial pipeline).
# ---------------------------------------------------------------------------------------------
def gecko_spec() -> mujoco.MjSpec:
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko

    return gecko().spec


@pytest.fixture(scope="module")
def nde_graph():
    from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import (
        HighProbabilityDecoder,
    )
    from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding

    nde = NeuralDevelopmentalEncoding(number_of_modules=20, seed=3)
    rng = np.random.default_rng(3)
    genotype = [rng.random(64).astype(np.float32) for _ in range(3)]
    graph = HighProbabilityDecoder(20).probability_matrices_to_graph(*nde.forward(genotype))
    assert graph.number_of_nodes() >= 5  # a real body, not just a core
    return graph


@pytest.fixture(params=["gecko", "nde"])
def robot_factory(request, nde_graph) -> Callable[[], mujoco.MjSpec]:
    if request.param == "gecko":
        return gecko_spec
    from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph

    return lambda: construct_mjspec_from_graph(nde_graph).spec


@pytest.fixture(params=WORLD_CLASSES, ids=WORLD_IDS)
def world_cls(request) -> type:
    return request.param


# ---------------------------------------------------------------------------------------------
# Measuring
# ---------------------------------------------------------------------------------------------
def robot_parts(model: mujoco.MjModel, prefix: str = "robot1_") -> tuple[int, np.ndarray, int]:
    """(body id, geom ids, qpos address of the free joint) of a spawned robot."""
    body = model.body(f"{prefix}world").id
    geoms = np.flatnonzero(model.body_rootid[model.geom_bodyid] == body)
    joint = model.body_jntadr[body]
    assert model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE
    return body, geoms, int(model.jnt_qposadr[joint])


def vertical_clearance(model: mujoco.MjModel, robot_geoms: np.ndarray, qadr: int) -> float:
    """How far the robot can be lowered before it touches a non-robot geom (MuJoCo contacts)."""
    data = mujoco.MjData(model)
    robot = set(robot_geoms.tolist())

    def touches(shift: float) -> bool:
        mujoco.mj_resetData(model, data)
        data.qpos[qadr + 2] -= shift
        mujoco.mj_fwdPosition(model, data)
        return any(
            ((int(c.geom1) in robot) != (int(c.geom2) in robot)) and c.dist < 0
            for c in data.contact[: data.ncon]
        )

    low, high = -0.05, 0.05
    assert not touches(low), "robot touches the world even when lifted"
    assert touches(high), "robot never touches the world"
    while high - low > 1e-6:
        middle = 0.5 * (low + high)
        low, high = (low, middle) if touches(middle) else (middle, high)
    return 0.5 * (low + high)


def box_corners(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> np.ndarray:
    """World corners of the robot's geoms (all robogen modules are boxes)."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = []
    for g in geoms:
        assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        rot = data.geom_xmat[g].reshape(3, 3)
        corners.append(data.geom_xpos[g] + (signs * model.geom_size[g]) @ rot.T)
    return np.vstack(corners)


# ---------------------------------------------------------------------------------------------
# Tests
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("spawn_index", range(len(SPAWNS)))
def test_spawn_rests_one_cm_above_ground(world_cls, robot_factory, spawn_index):
    mujoco.set_mjcb_control(None)
    world = world_cls()
    position = spawn_position(world_cls, spawn_index)
    rotation = SPAWNS[spawn_index][1]
    spec = world.spawn(robot_factory(), position=position, rotation=rotation)
    assert spec is world.spec
    model = world.spec.compile()
    _, geoms, qadr = robot_parts(model)
    assert len(geoms) > 1

    # Independent check: MuJoCo's collision detection against the whole world.
    assert vertical_clearance(model, geoms, qadr) == pytest.approx(0.01, abs=1e-3)

    # The corners never dip below 1 cm over ground_height; on planes a corner is the lowest
    # point, so there it is exactly 1 cm.
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    corners = box_corners(model, data, geoms)
    gaps = corners[:, 2] - world.ground_height(corners[:, 0], corners[:, 1])
    assert gaps.min() >= 0.01 - 1e-6
    if world_cls.__name__ in {"SimpleFlatWorld", "SimpleFlatWorldWithTarget", "SimpleTiltedWorld"}:
        assert gaps.min() == pytest.approx(0.01, abs=1e-6)

    # The robot sits above the requested (x, y): the lift is along world z only.
    body = model.body("robot1_world").id
    assert data.xpos[body][:2] == pytest.approx(position[:2], abs=1e-9)


def test_simulate_two_seconds_with_zero_control(world_cls, robot_factory):
    mujoco.set_mjcb_control(None)
    world = world_cls()
    world.spawn(robot_factory(), position=spawn_position(world_cls, 1), rotation=(0, 0, 30))
    model = world.spec.compile()
    data = mujoco.MjData(model)
    assert model.opt.timestep == 0.002
    steps = round(2.0 / model.opt.timestep)
    mujoco.mj_step(model, data, nstep=steps)
    assert data.time == pytest.approx(2.0)
    assert np.all(np.isfinite(data.qpos))
    assert np.all(np.isfinite(data.qvel))
    # Still on top of the ground: no robot geom's centre fell through it.
    _, geoms, _ = robot_parts(model)
    centres = data.geom_xpos[geoms]
    assert np.all(centres[:, 2] > world.ground_height(centres[:, 0], centres[:, 1]))


def test_gecko_on_flat_world_matches_upstream_numbers():
    mujoco.set_mjcb_control(None)
    world = environments.SimpleFlatWorld()
    world.spawn(gecko_spec(), position=[0, 0, 0])
    model = world.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert (model.nu, model.nv, model.nq) == (8, 14, 15)
    assert model.opt.timestep == 0.002
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert data.qpos[2] == pytest.approx(0.1307, abs=1e-3)
    assert data.qpos[:3] == pytest.approx([0.0, 0.0, 0.130711], abs=1e-5)
    assert model.actuator(0).name == "robot1_neckservo"


def test_spawn_height_is_a_drop_height_above_the_ground():
    world = environments.SimpleFlatWorld()
    world.spawn(gecko_spec(), position=[1, 2, 0.5])
    model = world.spec.compile()
    assert model.body("robot1_world").pos == pytest.approx([1, 2, 0.630711], abs=1e-5)


def test_spawn_without_correction_keeps_position():
    world = environments.SimpleFlatWorld()
    world.spawn(gecko_spec(), position=[0.2, 0.3, 0.4], correct_collision_with_floor=False)
    model = world.spec.compile()
    assert model.body("robot1_world").pos == pytest.approx([0.2, 0.3, 0.4])


def test_multiple_spawns_get_their_own_prefix_and_free_joint():
    world = environments.RuggedTerrainWorld()
    world.spawn(gecko_spec(), position=[0, 0, 0])
    world.spawn(gecko_spec(), position=[2, -1, 0], rotation=[0, 0, 90])
    world.spawn(gecko_spec(), position=[-2, 1, 0], spawn_prefix="rival")
    assert world.spawns == 3
    model = world.spec.compile()
    for prefix in ("robot1_", "robot2_", "rival3_"):
        _, geoms, qadr = robot_parts(model, prefix)
        assert model.body(f"{prefix}core").id > 0
        assert vertical_clearance(model, geoms, qadr) == pytest.approx(0.01, abs=1e-3)
    assert int(np.sum(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)) == 3
    assert (model.nu, model.nq) == (24, 45)
    # A second world counts from 1 again.
    other = environments.SimpleFlatWorld()
    other.spawn(gecko_spec())
    assert other.spec.compile().body("robot1_core").id > 0


def test_spawn_does_not_fire_the_global_control_callback():
    calls = []

    def callback(model, data):
        calls.append(data.time)

    mujoco.set_mjcb_control(callback)
    try:
        worlds = [environments.SimpleFlatWorld(), environments.CraterTerrainWorld()]
        for world in worlds:
            world.spawn(gecko_spec(), validate_no_collisions=True)
            world.spawn(gecko_spec(), position=[1, 1, 0])
        assert calls == []
        assert mujoco.get_mjcb_control() is callback
    finally:
        mujoco.set_mjcb_control(None)
    for world in worlds:
        assert world.spec.compile().nu == 16


def test_spawn_copies_the_robot_spec():
    robot = gecko_spec()
    before = robot.to_xml()
    world = environments.SimpleTiltedWorld()
    world.spawn(robot, position=[0.5, 0.5, 0], rotation=[0, 30, 0])
    world.spawn(robot, position=[-1.0, -1.0, 0])
    assert robot.to_xml() == before
    assert world.spec.compile().nu == 16


def mixed_shapes_robot() -> mujoco.MjSpec:
    """A small robot with one geom of each convex primitive type and a hinge."""
    spec = mujoco.MjSpec()
    core = spec.worldbody.add_body(name="core")
    G = mujoco.mjtGeom
    core.add_geom(name="box", type=G.mjGEOM_BOX, size=[0.1, 0.06, 0.04])
    core.add_geom(name="ball", type=G.mjGEOM_SPHERE, size=[0.05, 0, 0], pos=[0.15, 0, -0.02])
    core.add_geom(
        name="egg", type=G.mjGEOM_ELLIPSOID, size=[0.08, 0.04, 0.03], pos=[-0.15, 0.05, 0]
    )
    arm = core.add_body(name="arm", pos=[0, 0.12, 0], quat=[0.9239, 0.3827, 0, 0])
    arm.add_joint(name="hinge", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    arm.add_geom(name="capsule", type=G.mjGEOM_CAPSULE, size=[0.03, 0.08, 0], pos=[0, 0.05, 0])
    arm.add_geom(
        name="can",
        type=G.mjGEOM_CYLINDER,
        size=[0.04, 0.03, 0],
        pos=[0.1, 0.1, 0],
        quat=[0.9659, 0, 0.2588, 0],
    )
    spec.add_actuator(name="hinge", target="hinge", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    return spec


@pytest.mark.parametrize(
    "world_name", ["SimpleFlatWorld", "SimpleTiltedWorld", "RuggedTerrainWorld"]
)
@pytest.mark.parametrize("rotation", [(0, 0, 0), (35, -20, 60)])
def test_spawn_handles_non_box_geoms(world_name, rotation):
    world = getattr(environments, world_name)()
    world.spawn(mixed_shapes_robot(), position=[0.9, -1.3, 0], rotation=rotation)
    model = world.spec.compile()
    _, geoms, qadr = robot_parts(model)
    assert len(geoms) == 5
    assert vertical_clearance(model, geoms, qadr) == pytest.approx(0.01, abs=1e-3)


def test_base_world_uses_the_plane_z_zero():
    world = BaseWorld()
    world.spawn(mixed_shapes_robot(), position=[0.0, 0.0, 0.0], rotation=(0, 90, 0))
    model = world.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    _, geoms, _ = robot_parts(model)
    # Pitched 90 degrees the ball hangs lowest (its centre 0.15 below the core); without a
    # floor its bottom ends 1 cm above z = 0.
    ball = model.geom("robot1_ball").id
    assert data.geom_xpos[ball][2] - 0.05 == pytest.approx(0.01, abs=1e-6)
    assert data.geom_xpos[geoms][:, 2].min() == data.geom_xpos[ball][2]
