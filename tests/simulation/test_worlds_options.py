"""World options: timestep, mujoco_config, checker_floor, and one-line errors for bad input."""

from __future__ import annotations

import dataclasses
import types
import warnings

import mujoco
import numpy as np
import pytest

from ariel.simulation import environments
from ariel.simulation.environments import BaseWorld, SimpleFlatWorld

ALL_CLASSES = [
    getattr(environments, name)
    for name in environments.__all__
    if issubclass(getattr(environments, name), BaseWorld)
]
FLOOR_CLASSES = [cls for cls in ALL_CLASSES if cls is not BaseWorld]


def tiny_robot() -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    core = spec.worldbody.add_body(name="core")
    core.add_geom(name="core", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.1, 0.05])
    arm = core.add_body(name="arm", pos=[0.15, 0, 0])
    arm.add_joint(name="servo", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
    arm.add_geom(name="arm", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.05])
    spec.add_actuator(name="servo", target="servo", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    return spec


def test_package_exports():
    assert set(environments.__all__) >= {
        "AmphitheatreTerrainWorld",
        "BaseWorld",
        "CompoundWorld",
        "CraterTerrainWorld",
        "OlympicArena",
        "RuggedTerrainWorld",
        "RuggedTiltedWorld",
        "SimpleFlatWorld",
        "SimpleTiltedWorld",
    }
    with pytest.raises(AttributeError):
        _ = environments.NoSuchWorld


@pytest.mark.parametrize("world_cls", ALL_CLASSES, ids=lambda c: c.__name__)
def test_timestep_is_explicit_and_configurable(world_cls):
    world = world_cls()
    assert world.timestep == 0.002
    assert world.spec.option.timestep == 0.002
    assert world.spec.option.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    model = world_cls(timestep=0.005).spec.compile()
    assert model.opt.timestep == 0.005
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


@pytest.mark.parametrize("world_cls", ALL_CLASSES, ids=lambda c: c.__name__)
def test_unknown_option_names_it_and_lists_the_allowed(world_cls):
    with pytest.raises(TypeError) as error:
        world_cls(foo=1)
    message = str(error.value)
    assert message.startswith(f"unknown option 'foo' for {world_cls.__name__}; allowed: ")
    assert "timestep" in message and "name" in message
    assert "\n" not in message
    with pytest.raises(TypeError, match="keyword options only"):
        world_cls("my-world")


def test_unknown_option_message_for_simple_flat_world():
    with pytest.raises(TypeError) as error:
        SimpleFlatWorld(foo=1)
    assert str(error.value) == (
        "unknown option 'foo' for SimpleFlatWorld; allowed: checker_floor, floor_size, "
        "load_precompiled, mujoco_config, name, timestep"
    )


@pytest.mark.parametrize("world_cls", FLOOR_CLASSES, ids=lambda c: c.__name__)
def test_checker_floor_false_gives_a_plain_floor(world_cls):
    plain = world_cls(checker_floor=False)
    model = plain.spec.compile()
    assert model.ntex == 1  # only the skybox
    assert model.nmat == 0
    checker = world_cls(checker_floor=True).spec.compile()
    assert checker.ntex >= 2
    assert checker.nmat >= 1
    plain.spawn(tiny_robot(), position=[0.2, 0.1, 0])
    assert plain.spec.compile().nu == 1
    with pytest.raises(ValueError, match="checker_floor must be True or False"):
        world_cls(checker_floor="yes")


@pytest.mark.parametrize("bad", [0, -0.001, float("nan"), float("inf"), "0.002", True])
def test_bad_timestep(bad):
    with pytest.raises(ValueError, match="timestep"):
        SimpleFlatWorld(timestep=bad)


@pytest.mark.parametrize("bad", [(10, 10), (10, -1, 1), (10, 0, 1), (np.nan, 10, 1), "big"])
@pytest.mark.parametrize(
    "world_cls",
    [SimpleFlatWorld, environments.SimpleTiltedWorld, environments.RuggedTerrainWorld],
    ids=lambda c: c.__name__,
)
def test_bad_floor_size(world_cls, bad):
    with pytest.raises(ValueError, match="floor_size"):
        world_cls(floor_size=bad)


def test_other_bad_world_options():
    with pytest.raises(ValueError, match="floor_tilt"):
        environments.SimpleTiltedWorld(floor_tilt=(95, 0, 0))
    with pytest.raises(ValueError, match="rotation sequence"):
        environments.SimpleTiltedWorld(floor_rot_sequence="XQZ")
    with pytest.raises(ValueError, match="dims"):
        environments.RuggedTerrainWorld(dims=(1, 100))
    with pytest.raises(ValueError, match="normalize"):
        environments.RuggedTerrainWorld(normalize="zscore")
    with pytest.raises(ValueError, match="incline_degrees"):
        environments.OlympicArena(incline_degrees=60)
    with pytest.raises(ValueError, match="arena_width"):
        environments.OlympicArena(arena_width=0)
    with pytest.raises(ValueError, match="terrain_color"):
        environments.CompoundWorld(terrain_color=(2, 0, 0, 1))
    with pytest.raises(ValueError, match="name"):
        SimpleFlatWorld(name="")


def test_mujoco_config_mapping_is_stored_and_applied():
    config = {"timestep": 0.001, "integrator": "RK4", "gravity": (0.0, 0.0, -3.7)}
    world = SimpleFlatWorld(mujoco_config=config)
    assert world.mujoco_config is config
    assert world.timestep == 0.001
    model = world.spec.compile()
    assert model.opt.timestep == 0.001
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert model.opt.gravity == pytest.approx([0, 0, -3.7])


def test_mujoco_config_dataclass_and_object():
    @dataclasses.dataclass
    class MujocoConfig:
        timestep: float = 0.004
        iterations: int = 7

    world = environments.RuggedTerrainWorld(mujoco_config=MujocoConfig())
    model = world.spec.compile()
    assert (model.opt.timestep, model.opt.iterations) == (0.004, 7)
    world = environments.OlympicArena(mujoco_config=types.SimpleNamespace(solver="cg"))
    assert world.spec.compile().opt.solver == mujoco.mjtSolver.mjSOL_CG
    assert world.timestep == 0.002
    # Same timestep twice is fine.
    assert SimpleFlatWorld(timestep=0.01, mujoco_config={"timestep": 0.01}).timestep == 0.01


@pytest.mark.parametrize(
    ("config", "timestep", "match"),
    [
        ({"timestepp": 0.01}, None, "unknown mujoco_config option 'timestepp'; allowed: "),
        ({"integrator": "leapfrog"}, None, "unknown integrator 'leapfrog'; allowed: euler"),
        ({"timestep": -1.0}, None, "timestep"),
        ({"timestep": 0.01}, 0.02, "conflicts"),
        ({"gravity": "down"}, None, "gravity"),
    ],
)
def test_bad_mujoco_config(config, timestep, match):
    with pytest.raises(ValueError, match=match) as error:
        SimpleFlatWorld(mujoco_config=config, timestep=timestep)
    assert "\n" not in str(error.value)


def test_mujoco_config_of_the_wrong_type():
    with pytest.raises(TypeError, match="mujoco_config"):
        SimpleFlatWorld(mujoco_config=3)


def test_load_precompiled_is_accepted():
    world = SimpleFlatWorld(load_precompiled=True)
    assert world.is_precompiled is False
    assert world.spec.compile().ngeom == 1


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"position": [0, 0]}, ValueError, "spawn position must be 3 numbers"),
        ({"position": [0, np.nan, 0]}, ValueError, "spawn position must be finite"),
        ({"position": "here"}, ValueError, "spawn position"),
        ({"rotation": [0, 0, 0, 1]}, ValueError, "spawn rotation must be 3 numbers"),
        ({"rotation": [np.inf, 0, 0]}, ValueError, "spawn rotation must be finite"),
        ({"rotation_sequence": "ABC"}, ValueError, "rotation sequence must be 3 letters"),
        ({"rotation_sequence": "XY"}, ValueError, "rotation sequence"),
        ({"spawn_prefix": ""}, ValueError, "spawn_prefix"),
    ],
)
def test_bad_spawn_arguments(kwargs, error, match):
    world = SimpleFlatWorld()
    with pytest.raises(error, match=match) as raised:
        world.spawn(tiny_robot(), **kwargs)
    assert "\n" not in str(raised.value)
    # Nothing was added.
    assert world.spawns == 0
    assert world.spec.compile().nbody == 2


def test_spawn_needs_an_mjspec():
    with pytest.raises(TypeError, match=r"robot_spec must be a mujoco\.MjSpec"):
        SimpleFlatWorld().spawn(tiny_robot().worldbody)


def test_failed_spawn_leaves_the_world_unchanged():
    broken = tiny_robot()
    broken.worldbody.first_body().add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="nowhere")
    world = SimpleFlatWorld()
    with pytest.raises(ValueError):
        world.spawn(broken)
    assert world.spawns == 0
    world.spawn(tiny_robot())
    assert world.spec.compile().body("robot1_core").id > 0


def test_validate_no_collisions_warns_only_when_touching():
    world = SimpleFlatWorld()
    with pytest.warns(RuntimeWarning, match="starts in contact"):
        world.spawn(tiny_robot(), correct_collision_with_floor=False, validate_no_collisions=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        world.spawn(tiny_robot(), position=[2, 0, 0], validate_no_collisions=True)


def test_spawn_accepts_lowercase_extrinsic_sequence():
    world = SimpleFlatWorld()
    world.spawn(tiny_robot(), rotation=[30, 0, 10], rotation_sequence="xyz")
    model = world.spec.compile()
    assert model.nu == 1
