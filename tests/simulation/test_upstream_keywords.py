"""Upstream keyword names, heightmap_functions and the spawn keywords."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
from ariel.simulation.environments import (
    AmphitheatreTerrainWorld,
    OlympicArena,
    SimpleFlatWorld,
    heightmap_functions,
    heightmaps,
)
from ariel.simulation.tasks import targeted_locomotion as tl


def test_olympic_arena_section_length_and_incline_axis() -> None:
    arena = OlympicArena(section_length=1.5, incline_axis="y")
    assert arena.rugged_length == arena.incline_length == 3.0
    with pytest.raises(ValueError, match="incline_axis must be 'y'"):
        OlympicArena(incline_axis="x")
    with pytest.raises(ValueError, match="not both"):
        OlympicArena(section_length=1.0, rugged_length=3.0)


def test_amphitheatre_ring_radii() -> None:
    world = AmphitheatreTerrainWorld(ring_inner_radius=0.1, ring_outer_radius=0.4)
    assert (world.inner_radius, world.outer_radius) == (0.1, 0.4)
    with pytest.raises(ValueError, match="not both"):
        AmphitheatreTerrainWorld(ring_inner_radius=0.1, inner_radius=0.15)


def test_targeted_locomotion_upstream_keywords() -> None:
    start, end, target = np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0])
    ours = tl.fitness_delta_distance(start, end, target)
    assert tl.fitness_delta_distance(initial_pos=start, final_pos=end, target_pos=target) == ours
    assert ours == pytest.approx(-1.0)
    assert tl.fitness_direct_path(
        initial_pos=start, final_pos=end, target_pos=target, total_path_length=2.0
    ) == pytest.approx(-0.5)
    assert tl.distance_to_target(initial_position=(0, 0), target_position=(3, 4)) == 5.0
    with pytest.raises(TypeError, match="give one"):
        tl.fitness_delta_distance(start, end, target_pos=target, target_position=target)


def test_heightmap_functions_is_heightmaps() -> None:
    assert heightmap_functions.flat_heightmap is heightmaps.flat_heightmap
    assert heightmap_functions.smooth_edges_heightmap((8, 8), 0.2).shape == (8, 8)


def test_spawn_keywords() -> None:
    world = SimpleFlatWorld(load_precompiled=True)
    world.spawn(gecko().spec, position=(0, 0, 0.5), correct_collision_with_floor=False)
    model = world.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.qpos[2] == pytest.approx(0.5)  # left where it was put
    lifted = SimpleFlatWorld()
    lifted.spawn(gecko().spec, position=(0, 0, 0))
    model = lifted.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.qpos[2] == pytest.approx(0.1307, abs=2e-3)


def test_every_class_in_environments_is_a_world_upstreams_way() -> None:
    """Upstream's tests instantiate every class found in the package (`Any` was one)."""
    import inspect

    from ariel.simulation import environments

    classes = dict(inspect.getmembers(environments, inspect.isclass))
    assert set(classes) == set(environments.__all__)
    for cls in classes.values():
        world = cls(load_precompiled=False)
        assert isinstance(world, environments.BaseWorld)


def test_heightmap_functions_has_upstreams_functions_by_name() -> None:
    import inspect

    from ariel.simulation import environments

    assert environments.heightmap_functions is heightmap_functions  # a package attribute
    functions = dict(inspect.getmembers(heightmap_functions, inspect.isfunction))
    assert {name: f.__name__ for name, f in functions.items()} == {
        name: name
        for name in (
            "amphitheater_heightmap",
            "crater_heightmap",
            "flat_heightmap",
            "rugged_heightmap",
            "smooth_edges_heightmap",
        )
    }
    arena = heightmap_functions.amphitheater_heightmap(
        (20, 20), ring_inner_radius=0.2, ring_outer_radius=0.45, cone_height=1.0, seed=1
    )
    assert np.array_equal(
        arena, heightmaps.amphitheatre_heightmap((20, 20), 0.2, 0.45, 1.0, seed=1)
    )
    rugged = heightmap_functions.rugged_heightmap((8, 9), scale_of_noise=4, normalize=None, seed=1)
    assert np.array_equal(rugged, heightmaps.rugged_heightmap((8, 9), 4, "none", seed=1))
