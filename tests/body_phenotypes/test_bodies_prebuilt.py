"""Prebuilt bodies: the gecko's exact numbers, every prebuilt compiles, random_spider20 seeds."""

from __future__ import annotations

import math
import random
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS, PREBUILT_ROBOTS
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.random_20 import random_spider20
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.spider import spider
from ariel.body_phenotypes.robogen_lite.prebuilt_robots.spider_with_blocks import (
    body_spider,
    body_spider45,
)

GECKO_ACTUATORS = [
    "neckservo",
    "spineservo",
    "fl_legservo",
    "fl_flipperservo",
    "fr_legservo",
    "fr_flipperservo",
    "bl_legservo",
    "br_legservo",
]

_CORNERS = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)


def _geom_corners(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    points = [
        data.geom_xpos[i] + (_CORNERS * model.geom_size[i]) @ data.geom_xmat[i].reshape(3, 3).T
        for i in range(model.ngeom)
        if model.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX
    ]
    return np.concatenate(points)


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) for i in range(count)]


def test_gecko_compiled_alone() -> None:
    body = gecko()
    assert isinstance(body, CoreModule)
    model = body.spec.compile()
    assert model.nbody == 32
    assert model.ngeom == 23
    assert model.njnt == 8
    assert model.nu == 8
    assert model.nexclude == 8
    assert _names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu) == GECKO_ACTUATORS
    assert float(model.body_mass.sum()) == pytest.approx(1.81, abs=1e-9)
    # Top-down attachment: names never compound.
    bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
    assert "abdomenbrick" in bodies
    assert not any(name.startswith("neckabdomen") for name in bodies)
    # Only the core's own elements mention "core" (trackers bind to the geom "core").
    assert _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom).count("core") == 1
    assert [n for n in bodies if "core" in n] == ["core"]


def test_gecko_shape_and_no_self_contacts() -> None:
    model = gecko().spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0
    corners = _geom_corners(model, data)
    assert corners[:, 2].min() == pytest.approx(-0.05 - 0.05 * math.sqrt(2))  # -0.1207
    np.testing.assert_allclose(corners[:, 0].min(), -0.40, atol=1e-9)
    np.testing.assert_allclose(corners[:, 0].max(), 0.40, atol=1e-9)
    butt = data.xpos[model.body("buttbrick").id]
    np.testing.assert_allclose(butt, [0, 0.5, -0.05], atol=1e-9)


def test_gecko_under_a_free_joint_one_cm_above_the_floor() -> None:
    # The lowest geom point of the gecko at the origin, computed from the geometry itself.
    alone = gecko().spec.compile()
    alone_data = mujoco.MjData(alone)
    mujoco.mj_kinematics(alone, alone_data)
    lowest = _geom_corners(alone, alone_data)[:, 2].min()
    assert lowest == pytest.approx(-0.1207, abs=1e-4)

    world = mujoco.MjSpec()
    world.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    holder = world.worldbody.add_body(name="holder", pos=[0, 0, 0.01 - lowest])
    holder.add_freejoint()
    holder.add_site(name="mount").attach_body(body=gecko().body, prefix="robot1_")
    model = world.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.nu == 8
    assert model.nq == 15
    assert model.nv == 14
    assert data.xpos[model.body("holder").id][2] == pytest.approx(0.130711, abs=1e-6)
    np.testing.assert_allclose(
        data.geom_xpos[model.geom("robot1_core").id], [0, 0.1, 0.130711], atol=1e-6
    )
    assert _geom_corners(model, data)[:, 2].min() == pytest.approx(0.01)


def test_spider_actuators_and_mass() -> None:
    model = spider().spec.compile()
    expected = [f"l{k}_{j}servo" for k in range(1, 5) for j in (1, 2)]
    assert _names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu) == expected
    assert float(model.body_mass.sum()) == pytest.approx(1.0 + 8 * 0.06 + 4 * 0.055)


def test_spider_with_blocks_and_spider45() -> None:
    plain = body_spider().spec.compile()
    assert plain.nu == 8
    assert "C-FH-B-H-B-brick" in _names(plain, mujoco.mjtObj.mjOBJ_BODY, plain.nbody)
    yawed_core = body_spider45()
    np.testing.assert_allclose(
        yawed_core.body.quat, [math.cos(math.pi / 8), 0, 0, math.sin(math.pi / 8)]
    )
    yawed = yawed_core.spec.compile()
    assert yawed.nbody == plain.nbody
    assert float(yawed.body_mass.sum()) == pytest.approx(float(plain.body_mass.sum()))


@pytest.mark.parametrize("name", sorted(PREBUILT_ROBOTS))
def test_every_prebuilt_compiles_and_moves(name: str) -> None:
    body = PREBUILT_ROBOTS[name]()
    assert isinstance(body, CoreModule)
    model = body.spec.compile()
    assert model.nu > 0
    assert model.nu == model.njnt
    assert float(model.body_mass.sum()) > 1.0


def test_prebuilt_registry_names() -> None:
    expected = {"gecko", "spider", "spider_with_blocks", "spider45", "random_spider20"}
    assert expected | {"baby_a", "baby_b"} <= set(PREBUILT_ROBOTS)
    assert PREBUILT_ROBOTS["gecko"].__name__ == "gecko"


def _fingerprint(core: CoreModule) -> tuple:
    model = core.spec.compile()
    return (
        tuple(_names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)),
        model.body_pos.round(9).tobytes(),
        model.body_quat.round(9).tobytes(),
    )


def test_random_spider20_is_reproducible_per_seed() -> None:
    first = random_spider20(seed=1337)
    model = first.spec.compile()
    bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
    modules = [n for n in bodies if n == "core" or n.endswith(("hinge", "brick"))]
    assert len(modules) == 20
    assert _fingerprint(first) == _fingerprint(random_spider20(seed=1337))
    assert _fingerprint(random_spider20()) == _fingerprint(first)  # default seed 1337
    assert _fingerprint(random_spider20(seed=7)) != _fingerprint(first)


def test_random_spider20_without_seed_follows_the_global_random_generator() -> None:
    state = random.getstate()
    try:
        random.seed(5)
        first = _fingerprint(random_spider20(seed=None))
        random.seed(5)
        assert _fingerprint(random_spider20(seed=None)) == first
    finally:
        random.setstate(state)


@pytest.mark.parametrize("name", sorted(PREBUILT_GRAPHS))
def test_prebuilt_graph_matches_the_prebuilt_body(name: str) -> None:
    from_graph = construct_mjspec_from_graph(PREBUILT_GRAPHS[name]()).spec.compile()
    built = PREBUILT_ROBOTS[name]().spec.compile()
    assert from_graph.nu == built.nu
    assert from_graph.nbody == built.nbody
    assert float(from_graph.body_mass.sum()) == pytest.approx(float(built.body_mass.sum()))
    # Same shape: the same geom boxes in space (mirrored joint axes aside).
    data_graph, data_built = mujoco.MjData(from_graph), mujoco.MjData(built)
    mujoco.mj_kinematics(from_graph, data_graph)
    mujoco.mj_kinematics(built, data_built)

    def rows(points: np.ndarray) -> np.ndarray:
        return np.array(sorted(map(tuple, points.round(9) + 0.0)))

    np.testing.assert_allclose(rows(data_graph.geom_xpos), rows(data_built.geom_xpos), atol=1e-9)


def test_gecko_graph_total_mass() -> None:
    model = construct_mjspec_from_graph(PREBUILT_GRAPHS["gecko"]()).spec.compile()
    assert model.nu == 8
    assert float(model.body_mass.sum()) == pytest.approx(1.81)


def test_importing_prebuilt_registry_is_cheap() -> None:
    code = (
        "import sys; from ariel.body_phenotypes.robogen_lite.prebuilt_robots import "
        "PREBUILT_ROBOTS; assert 'mujoco' not in sys.modules, 'mujoco imported'; "
        "bad = [n for n in ('torch', 'matplotlib', 'rerun') if n in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
