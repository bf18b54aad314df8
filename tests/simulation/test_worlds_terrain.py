"""Terrain: ground_height agrees with MuJoCo, terrains are reproducible, heightmaps and noise."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from ariel.simulation import environments
from ariel.simulation.environments import BaseWorld, OlympicArena
from ariel.simulation.environments.heightmaps import (
    amphitheater_heightmap,
    amphitheatre_heightmap,
    crater_heightmap,
    flat_heightmap,
    rugged_heightmap,
    smooth_edges_heightmap,
)
from ariel.simulation.environments.perlin import PerlinNoise

WORLD_CLASSES = [
    getattr(environments, name)
    for name in environments.__all__
    if issubclass(getattr(environments, name), BaseWorld) and name != "BaseWorld"
]
TERRAIN_CLASSES = [
    environments.RuggedTerrainWorld,
    environments.RuggedTiltedWorld,
    environments.CraterTerrainWorld,
    environments.AmphitheatreTerrainWorld,
    environments.OlympicArena,
]


def ray_ground(world: BaseWorld, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Ground height by casting a ray straight down in the compiled world (target excluded)."""
    model = world.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    target = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "target")
    geom = np.zeros(1, dtype=np.int32)
    heights = []
    for x, y in zip(xs, ys, strict=True):
        distance = mujoco.mj_ray(
            model, data, np.array([x, y, 20.0]), np.array([0.0, 0.0, -1.0]), None, 1, target, geom
        )
        assert distance >= 0, f"no ground under ({x}, {y})"
        heights.append(20.0 - distance)
    return np.array(heights)


@pytest.mark.parametrize("world_cls", WORLD_CLASSES, ids=lambda c: c.__name__)
def test_ground_height_agrees_with_mujoco_rays(world_cls):
    world = world_cls()
    rng = np.random.default_rng(0)
    if isinstance(world, OlympicArena):
        xs = rng.uniform(world.x_start + 0.01, world.x_end - 0.01, 60)
        ys = rng.uniform(-0.95, 0.95, 60)
    else:
        xs = rng.uniform(-4.8, 4.8, 60)
        ys = rng.uniform(-4.8, 4.8, 60)
    expected = ray_ground(world, xs, ys)
    assert world.ground_height(xs, ys) == pytest.approx(expected, abs=2e-3)
    # Tighter than the contract: the triangle interpolation matches MuJoCo's surface.
    assert np.max(np.abs(world.ground_height(xs, ys) - expected)) < 1e-5


def test_ground_height_is_vectorised():
    world = environments.RuggedTerrainWorld()
    x = np.linspace(-2, 2, 12).reshape(3, 4)
    heights = world.ground_height(x, 0.5)
    assert heights.shape == (3, 4)
    assert isinstance(world.ground_height(0.3, -0.2), float)
    assert heights[1, 2] == world.ground_height(x[1, 2], 0.5)


def test_tilted_and_flat_ground():
    assert environments.SimpleFlatWorld().ground_height(3.0, -2.0) == 0.0
    tilted = environments.SimpleTiltedWorld()
    assert tilted.ground_height(1.0, 2.0) == pytest.approx(2.0 * math.tan(math.radians(15)))
    flat_hfield = environments.CompoundWorld()
    assert np.all(flat_hfield.ground_height(np.arange(-3, 4), 1.0) == 0.0)


def hfield_data(world: BaseWorld) -> np.ndarray:
    return np.array(world.spec.hfields[0].userdata)


@pytest.mark.parametrize("world_cls", TERRAIN_CLASSES, ids=lambda c: c.__name__)
def test_terrain_is_deterministic_by_default(world_cls):
    first, second = world_cls(), world_cls()
    assert np.array_equal(hfield_data(first), hfield_data(second))
    assert np.ptp(hfield_data(first)) > 0  # not flat
    other = world_cls(seed=7)
    assert not np.array_equal(hfield_data(first), hfield_data(other))
    assert np.array_equal(hfield_data(other), hfield_data(world_cls(seed=7)))


def test_unseeded_terrain_differs():
    first = environments.RuggedTerrainWorld(seed=None)
    second = environments.RuggedTerrainWorld(seed=None)
    assert not np.array_equal(hfield_data(first), hfield_data(second))


def test_compound_world_takes_a_heightmap():
    heightmap = np.outer(np.linspace(0, 1, 20), np.ones(30))  # a ramp along y (rows)
    world = environments.CompoundWorld(floor_heightmap=heightmap, floor_size=(6, 4, 2))
    assert world.dims == (20, 30)
    model = world.spec.compile()
    assert (model.hfield_nrow[0], model.hfield_ncol[0]) == (20, 30)
    # The surface spans z in [0, depth / 2] from y = -2 to y = 2.
    assert world.ground_height(0.0, -2.0) == pytest.approx(0.0)
    assert world.ground_height(0.0, 2.0) == pytest.approx(1.0)
    assert world.ground_height(1.0, 0.0) == pytest.approx(0.5, abs=1e-6)
    with pytest.raises(ValueError, match="disagree"):
        environments.CompoundWorld(floor_heightmap=heightmap, dims=(10, 10))
    with pytest.raises(ValueError, match="2-D"):
        environments.CompoundWorld(floor_heightmap=np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        environments.CompoundWorld(floor_heightmap=np.full((4, 4), np.nan))


def test_crater_is_lowest_in_the_middle_and_amphitheatre_flat_there():
    crater = environments.CraterTerrainWorld()
    assert crater.ground_height(0.0, 0.0) < 0.3
    assert crater.ground_height(4.5, 4.5) > 0.7
    amphitheatre = environments.AmphitheatreTerrainWorld()
    centre = amphitheatre.ground_height(np.linspace(-0.8, 0.8, 9), 0.0)
    rim = amphitheatre.ground_height(np.linspace(-4.5, -4.0, 5), 0.0)
    assert centre.max() < rim.min()


def test_olympic_arena_layout():
    arena = OlympicArena()
    model = arena.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    height = 2.0 * math.sin(math.radians(15))
    assert arena.platform_height == pytest.approx(height)
    target = model.body("target").id
    assert data.xpos[target] == pytest.approx(arena.target_position)
    assert arena.target_position[0] > arena.x_incline_end
    marker = model.geom("target").id
    assert model.geom_bodyid[marker] == target
    assert (model.geom_contype[marker], model.geom_conaffinity[marker]) == (0, 0)
    assert model.geom_rgba[marker][3] > 0
    for name in ("wall_left_flat", "wall_right_incline", "wall_start", "wall_end"):
        assert model.geom(name).id >= 0
    # flat -> rugged -> incline -> platform along +x
    assert arena.ground_height(0.0, 0.0) == 0.0
    rugged = arena.ground_height(np.linspace(0.6, 2.4, 50), 0.0)
    assert np.ptp(rugged) > 0.02
    assert np.all(np.abs(rugged) <= arena.rugged_height)
    assert arena.ground_height(2.5 + math.cos(math.radians(15)), 0.0) == pytest.approx(
        math.sin(math.radians(15)),
    )
    assert arena.ground_height(arena.target_position[0], 0.3) == pytest.approx(height)
    # The rugged section is flush with the flat floor at its borders.
    assert arena.ground_height(0.5001, np.linspace(-0.9, 0.9, 7)) == pytest.approx(0, abs=1e-3)


# ---------------------------------------------------------------------------------------------
# Perlin noise and heightmap helpers
# ---------------------------------------------------------------------------------------------
def test_perlin_noise_is_seeded_and_shaped():
    grid = PerlinNoise(seed=1).as_grid(40, 30, scale=8.0)
    assert grid.shape == (30, 40)
    assert np.array_equal(grid, PerlinNoise(seed=1).as_grid(40, 30, scale=8.0))
    assert not np.array_equal(grid, PerlinNoise(seed=2).as_grid(40, 30, scale=8.0))
    assert np.all(np.abs(grid) <= 1.0)
    assert np.ptp(grid) > 0.3
    # Zero on the lattice points (every 8th pixel).
    assert np.allclose(grid[::8, ::8], 0.0)
    linear = PerlinNoise(seed=1).as_grid(40, 30, scale=8.0, normalize="linear")
    assert np.allclose(linear, grid * 0.5 + 0.5)
    clipped = PerlinNoise(seed=1).as_grid(40, 30, scale=8.0, normalize="clip")
    assert clipped.min() >= 0.0 and clipped.max() <= 1.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"width": 0, "height": 4}, "width"),
        ({"width": 4, "height": -1}, "height"),
        ({"width": 4, "height": 4, "scale": 0}, "scale"),
        ({"width": 4, "height": 4, "normalize": "zscore"}, "allowed: none, linear, clip"),
    ],
)
def test_perlin_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PerlinNoise(seed=0).as_grid(**kwargs)


def test_heightmap_helpers():
    assert np.array_equal(flat_heightmap((3, 5)), np.zeros((3, 5)))
    rugged = rugged_heightmap((20, 30), 4.0, seed=3)
    assert rugged.shape == (20, 30)
    assert np.array_equal(rugged, rugged_heightmap((20, 30), 4.0, seed=3))
    mask = smooth_edges_heightmap((21, 21), 0.2)
    assert np.all(mask[0] == 0) and np.all(mask[:, -1] == 0)
    assert mask[10, 10] == 1.0
    assert np.all((mask >= 0) & (mask <= 1))
    crater = crater_heightmap((41, 41), height_of_noise=0.0)
    assert np.unravel_index(np.argmin(crater), crater.shape) == (20, 20)
    arena = amphitheatre_heightmap((41, 41), height_of_noise=0.0, cone_height=2.0)
    assert arena[20, 20] == 0.0 and arena[0, 0] == 2.0
    # Upstream's spelling takes upstream's keywords and gives the same map.
    assert np.array_equal(
        amphitheater_heightmap(
            (41, 41), ring_inner_radius=0.1, ring_outer_radius=0.4, height_of_noise=0.0
        ),
        amphitheatre_heightmap((41, 41), inner_radius=0.1, outer_radius=0.4, height_of_noise=0.0),
    )
    with pytest.raises(ValueError, match="dims"):
        flat_heightmap((1, 5))
    with pytest.raises(ValueError, match="inner_radius"):
        amphitheatre_heightmap((5, 5), inner_radius=0.5, outer_radius=0.2)


def test_unseeded_terrain_follows_numpys_global_seed():
    """seed=None drew OS entropy: np.random.seed before it did not make it repeat."""
    np.random.seed(3)
    first = hfield_data(environments.RuggedTerrainWorld(seed=None))
    np.random.seed(3)
    assert np.array_equal(first, hfield_data(environments.RuggedTerrainWorld(seed=None)))


@pytest.mark.parametrize("seed", [-1, 1.5, True])
def test_the_olympic_arena_checks_its_seed_as_the_other_terrains(seed):
    """It took True, and -1 or 1.5 failed inside NumPy with its own words."""
    with pytest.raises(ValueError, match="OlympicArena: seed must be None or an int >= 0"):
        OlympicArena(seed=seed)


def test_a_world_option_called_name_reaches_the_world():
    """Registry.make took `name` itself: --set 'world.options={name="x"}' said "got multiple
    values for argument 'name'"."""
    from ariel.plugins import worlds

    assert worlds.make("flat", name="my-floor").name == "my-floor"
    from ariel.plugins import check_world

    check_world("flat", name="my-floor")  # the run's plugin check: it failed there too
