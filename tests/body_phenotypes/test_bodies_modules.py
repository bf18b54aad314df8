"""Core, brick and hinge modules: upstream geometry, masses, actuator, rotation, sites."""

from __future__ import annotations

import math
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleType
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule
from ariel.body_phenotypes.robogen_lite.modules.module import FaceNotAvailableError, Module

S = math.sqrt(0.5)


def _compile(module: Module) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = module.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _site_frame(model: mujoco.MjModel, data: mujoco.MjData, name: str):
    site = model.site(name)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[site.id])
    return data.site_xpos[site.id].copy(), quat


def _same_rotation(q1, q2) -> bool:
    # q and -q are the same rotation
    q1, q2 = np.asarray(q1, float), np.asarray(q2, float)
    return bool(np.allclose(q1, q2, atol=1e-6) or np.allclose(q1, -q2, atol=1e-6))


# ---------------------------------------------------------------- core


def test_core_geometry_mass_colour_and_camera() -> None:
    core = CoreModule(index=0)
    model, _ = _compile(core)
    geom = model.geom("core")
    assert geom.type[0] == mujoco.mjtGeom.mjGEOM_BOX
    np.testing.assert_allclose(geom.size, [0.1, 0.1, 0.1])
    np.testing.assert_allclose(geom.pos, [0.0, 0.1, 0.0])
    np.testing.assert_allclose(geom.rgba, [253 / 255, 202 / 255, 64 / 255, 1.0])
    body = model.body("core")
    assert body.mass[0] == pytest.approx(1.0)
    np.testing.assert_allclose(body.inertia, [0.2**2 / 6] * 3, rtol=1e-6)  # 0.006667
    np.testing.assert_allclose(body.ipos, [0.0, 0.1, 0.0], atol=1e-12)
    camera = model.camera("core_mycamera")
    np.testing.assert_allclose(camera.pos, [0.0, 0.0, 0.08])
    assert _same_rotation(camera.quat, [0.0, 0.0, S, S])


CORE_SITES = {
    ModuleFaces.FRONT: ("core-front", (0, 0.2, -0.05), (1, 0, 0, 0)),
    ModuleFaces.BACK: ("core-back", (0, 0, -0.05), (0, 0, 0, 1)),
    ModuleFaces.LEFT: ("core-left", (-0.1, 0.1, -0.05), (S, 0, 0, S)),
    ModuleFaces.RIGHT: ("core-right", (0.1, 0.1, -0.05), (-S, 0, 0, S)),
    ModuleFaces.TOP: ("core-top", (0, 0.1, 0.1), (S, S, 0, 0)),
    ModuleFaces.BOTTOM: ("core-bottom", (0, 0.1, -0.1), (0, 0, -S, S)),
}


def test_core_sites_positions_and_orientations() -> None:
    core = CoreModule(index=0)
    assert set(core.sites) == set(ModuleFaces)
    model, data = _compile(core)
    for face, (name, pos, quat) in CORE_SITES.items():
        assert core.sites[face].name == name
        np.testing.assert_allclose(core.sites[face].quat, quat, atol=1e-12)
        xpos, xquat = _site_frame(model, data, name)
        np.testing.assert_allclose(xpos, pos, atol=1e-12)
        assert _same_rotation(xquat, quat), (face, xquat)


def test_site_orientation_decides_growth_direction() -> None:
    # A child grows along the site's +y: FRONT +y, BACK -y, LEFT -x, RIGHT +x, TOP +z, BOTTOM -z.
    expected = {
        ModuleFaces.FRONT: (0, 1, 0),
        ModuleFaces.BACK: (0, -1, 0),
        ModuleFaces.LEFT: (-1, 0, 0),
        ModuleFaces.RIGHT: (1, 0, 0),
        ModuleFaces.TOP: (0, 0, 1),
        ModuleFaces.BOTTOM: (0, 0, -1),
    }
    core = CoreModule(index=0)
    model, data = _compile(core)
    for face, direction in expected.items():
        xmat = data.site_xmat[model.site(CORE_SITES[face][0]).id].reshape(3, 3)
        np.testing.assert_allclose(xmat[:, 1], direction, atol=1e-12)


def test_core_index_must_be_zero() -> None:
    assert CoreModule(index=0).index == 0
    assert CoreModule().index == 0
    with pytest.raises(ValueError, match="index must be 0, got 3"):
        CoreModule(index=3)
    with pytest.raises(TypeError):
        CoreModule(index="0")  # type: ignore[arg-type]


def test_core_rotate_only_zero() -> None:
    core = CoreModule(index=0)
    core.rotate(0)
    np.testing.assert_allclose(core.body.quat, [1, 0, 0, 0])
    with pytest.raises(ValueError, match="cannot be rotated"):
        core.rotate(90)


# ---------------------------------------------------------------- brick

BRICK_SITES = {
    ModuleFaces.FRONT: ("brick-front", (0, 0.1, 0), (1, 0, 0, 0)),
    ModuleFaces.LEFT: ("brick-left", (-0.05, 0.05, 0), (S, 0, 0, S)),
    ModuleFaces.RIGHT: ("brick-right", (0.05, 0.05, 0), (-S, 0, 0, S)),
    ModuleFaces.TOP: ("brick-top", (0, 0.05, 0.05), (S, S, 0, 0)),
    ModuleFaces.BOTTOM: ("brick-bottom", (0, 0.05, -0.05), (0, 0, -S, S)),
}


def test_brick_geometry_mass_colour_and_sites() -> None:
    brick = BrickModule(index=4)
    assert brick.index == 4
    assert brick.module_type is ModuleType.BRICK
    model, data = _compile(brick)
    geom = model.geom("brick")
    np.testing.assert_allclose(geom.size, [0.05, 0.05, 0.05])
    np.testing.assert_allclose(geom.pos, [0.0, 0.05, 0.0])
    np.testing.assert_allclose(geom.rgba, [28 / 255, 119 / 255, 195 / 255, 1.0])
    assert model.body("brick").mass[0] == pytest.approx(0.055)
    assert set(brick.sites) == set(BRICK_SITES)
    assert ModuleFaces.BACK not in brick.sites
    for face, (name, pos, quat) in BRICK_SITES.items():
        assert brick.sites[face].name == name
        xpos, xquat = _site_frame(model, data, name)
        np.testing.assert_allclose(xpos, pos, atol=1e-12)
        assert _same_rotation(xquat, quat), face


# ---------------------------------------------------------------- hinge


def test_hinge_bodies_geoms_masses_and_colours() -> None:
    hinge = HingeModule(index=7)
    assert hinge.module_type is ModuleType.HINGE
    model, _ = _compile(hinge)
    assert [model.body(i).name for i in range(model.nbody)] == ["world", "hinge", "stator", "rotor"]
    # Physical masses only: nothing on the root body (docs/decisions.md).
    assert model.body("hinge").mass[0] == 0.0
    assert model.body("stator").mass[0] == pytest.approx(0.02)
    assert model.body("rotor").mass[0] == pytest.approx(0.04)
    assert model.body_mass.sum() == pytest.approx(0.06)
    np.testing.assert_allclose(model.body("stator").pos, [0, 0.03, 0])
    np.testing.assert_allclose(model.body("rotor").pos, [0, 0.08, 0])
    np.testing.assert_allclose(model.geom("stator").size, [0.02475, 0.0297, 0.02475])
    np.testing.assert_allclose(model.geom("rotor").size, [0.025, 0.02, 0.025])
    np.testing.assert_allclose(model.geom("stator").rgba, [223 / 255, 41 / 255, 53 / 255, 1])
    np.testing.assert_allclose(model.geom("rotor").rgba, [160 / 255, 24 / 255, 33 / 255, 1])


def test_hinge_joint_and_servo_actuator() -> None:
    hinge = HingeModule(index=1)
    model, data = _compile(hinge)
    joint = model.joint("servo")
    assert joint.type[0] == mujoco.mjtJoint.mjJNT_HINGE
    np.testing.assert_allclose(joint.axis, [0, 0, 1])
    np.testing.assert_allclose(joint.pos, [0, -0.02, 0])
    assert model.jnt_bodyid[joint.id] == model.body("rotor").id
    assert not model.jnt_limited[joint.id]  # unlimited joint, only the ctrl is limited
    assert model.dof_damping[0] == 0.0
    np.testing.assert_allclose(data.xanchor[joint.id], [0, 0.06, 0], atol=1e-12)

    assert model.nu == 1
    act = model.actuator("servo")
    assert model.actuator_trntype[0] == mujoco.mjtTrn.mjTRN_JOINT
    assert model.actuator_trnid[0, 0] == joint.id
    assert model.actuator_dyntype[0] == mujoco.mjtDyn.mjDYN_NONE
    assert model.actuator_gaintype[0] == mujoco.mjtGain.mjGAIN_FIXED
    assert model.actuator_biastype[0] == mujoco.mjtBias.mjBIAS_AFFINE
    np.testing.assert_allclose(act.gainprm[:3], [1, 0, 0])
    np.testing.assert_allclose(act.biasprm[:3], [0, -1, -1])
    np.testing.assert_allclose(act.ctrlrange, [-math.pi / 2, math.pi / 2])
    assert model.actuator_ctrllimited[0]
    assert not model.actuator_forcelimited[0]
    np.testing.assert_allclose(act.gear[0], 1.0)

    # force = kp * (ctrl - q) - kv * qdot with kp = kv = 1
    data.qpos[0] = 0.2
    data.qvel[0] = 0.5
    data.ctrl[0] = 1.0
    mujoco.mj_forward(model, data)
    assert data.actuator_force[0] == pytest.approx(1.0 - 0.2 - 0.5)


def test_hinge_contact_exclusion_and_site() -> None:
    hinge = HingeModule(index=1)
    model, data = _compile(hinge)
    assert model.nexclude == 1
    pair = {model.body("stator").id, model.body("rotor").id}
    signature = int(model.exclude_signature[0])
    assert {signature >> 16, signature & 0xFFFF} == pair
    assert list(hinge.sites) == [ModuleFaces.FRONT]
    assert hinge.sites[ModuleFaces.FRONT].name == "hinge-front"
    xpos, xquat = _site_frame(model, data, "hinge-front")
    np.testing.assert_allclose(xpos, [0, 0.10, 0], atol=1e-12)
    assert _same_rotation(xquat, [1, 0, 0, 0])


# ---------------------------------------------------------------- rotation


@pytest.mark.parametrize(
    ("degrees", "quat"),
    [
        (0, (1, 0, 0, 0)),
        (45, (0.924, 0, 0.383, 0)),
        (90, (0.707, 0, 0.707, 0)),
        (180, (0, 0, 1, 0)),
        (-90, (0.707, 0, -0.707, 0)),
    ],
)
@pytest.mark.parametrize("module_class", [BrickModule, HingeModule])
def test_rotate_sets_quaternion_about_growth_axis(module_class, degrees, quat) -> None:
    module = module_class(index=1)
    module.rotate(degrees)
    np.testing.assert_allclose(module.body.quat, quat, atol=1e-3)
    assert module.rotation == degrees


def test_rotate_is_absolute_not_cumulative() -> None:
    hinge = HingeModule(index=1)
    hinge.rotate(30)
    hinge.rotate(45)
    np.testing.assert_allclose(
        hinge.body.quat, [math.cos(math.pi / 8), 0, math.sin(math.pi / 8), 0]
    )
    hinge.rotate(45)
    np.testing.assert_allclose(
        hinge.body.quat, [math.cos(math.pi / 8), 0, math.sin(math.pi / 8), 0]
    )


def test_rotate_90_turns_joint_axis_horizontal_and_works_after_attach() -> None:
    core = CoreModule(index=0)
    hinge = HingeModule(index=1)
    core.sites[ModuleFaces.FRONT].attach_body(body=hinge.body, prefix="h")
    hinge.rotate(90)  # after attaching: attachment is by reference
    model, data = _compile(core)
    axis = data.xaxis[model.joint("hservo").id]
    np.testing.assert_allclose(np.abs(axis), [1, 0, 0], atol=1e-12)


def test_rotate_rejects_non_numbers() -> None:
    with pytest.raises(TypeError):
        BrickModule(index=1).rotate("90")  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        BrickModule(index=1).rotate(float("nan"))


# ---------------------------------------------------------------- common interface


@pytest.mark.parametrize(
    ("module_class", "faces"),
    [
        (CoreModule, set(ModuleFaces)),
        (BrickModule, set(ModuleFaces) - {ModuleFaces.BACK}),
        (HingeModule, {ModuleFaces.FRONT}),
    ],
)
def test_every_module_has_the_common_interface(module_class, faces) -> None:
    module = module_class(index=0)
    assert isinstance(module, Module)
    assert isinstance(module.spec, mujoco.MjSpec)
    assert isinstance(module.body, mujoco.MjsBody)
    assert module.body.name == module.module_type.name.lower()
    assert module.spec.compiler.degree is False
    assert set(module.sites) == faces
    assert all(isinstance(site, mujoco.MjsSite) for site in module.sites.values())
    assert module.index == 0
    # Each module owns a fresh spec.
    assert module_class(index=0).spec is not module.spec


@pytest.mark.parametrize(
    ("module", "face", "text"),
    [
        (lambda: HingeModule(index=1), ModuleFaces.LEFT, "LEFT is not available on a HINGE"),
        (lambda: BrickModule(index=1), ModuleFaces.BACK, "BACK is not available on a BRICK"),
        (lambda: CoreModule(index=0), "FRONT", "not a ModuleFaces member"),
    ],
)
def test_missing_face_gives_a_clear_error(module, face, text) -> None:
    mod = module()
    with pytest.raises(FaceNotAvailableError) as info:
        mod.sites[face]
    message = str(info.value)
    assert text in message
    assert "\n" not in message
    assert isinstance(info.value, KeyError)
    assert isinstance(info.value, ValueError)
    for have in mod.sites:
        assert have.name in message


def test_module_index_must_be_an_int() -> None:
    assert HingeModule(index=np.int64(3)).index == 3
    with pytest.raises(TypeError):
        HingeModule(index=1.5)  # type: ignore[arg-type]


def test_tutorial_manual_assembly() -> None:
    core = CoreModule(index=0)
    left_arm = HingeModule(index=1)
    right_arm = HingeModule(index=2)
    right_arm.rotate(180)
    left_foot = BrickModule(index=3)
    right_foot = BrickModule(index=4)
    core.sites[ModuleFaces.LEFT].attach_body(body=left_arm.body, prefix="left_arm")
    core.sites[ModuleFaces.RIGHT].attach_body(body=right_arm.body, prefix="right_arm")
    left_arm.sites[ModuleFaces.FRONT].attach_body(body=left_foot.body, prefix="left_foot")
    right_arm.sites[ModuleFaces.FRONT].attach_body(body=right_foot.body, prefix="right_foot")

    model, data = _compile(core)
    assert model.nbody == 10
    assert model.nu == 2
    names = [model.body(i).name for i in range(model.nbody)]
    assert names == [
        "world",
        "core",
        "left_armhinge",
        "left_armstator",
        "left_armrotor",
        "left_footbrick",
        "right_armhinge",
        "right_armstator",
        "right_armrotor",
        "right_footbrick",
    ]
    # Both arms point outward because of the site orientations.
    assert data.xpos[model.body("left_footbrick").id][0] < -0.1
    assert data.xpos[model.body("right_footbrick").id][0] > 0.1
    # rotate(180) flips the right hinge's joint axis.
    assert data.xaxis[model.joint("left_armservo").id][2] == pytest.approx(1.0)
    assert data.xaxis[model.joint("right_armservo").id][2] == pytest.approx(-1.0)


def test_importing_modules_package_is_cheap() -> None:
    code = (
        "import sys; import ariel.body_phenotypes.robogen_lite.modules as m; "
        "assert 'mujoco' not in sys.modules; m.HingeModule; assert 'mujoco' in sys.modules; "
        "bad = [n for n in ('torch', 'matplotlib', 'rerun') if n in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
