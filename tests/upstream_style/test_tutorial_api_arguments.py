"""Bad arguments to the tutorial API are refused in one line naming the argument (and what is
allowed), never by numpy, torch or MuJoCo from deep inside, nor accepted to fail later."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
import pytest
import torch

from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding
from ariel.ec.genotypes.nde.encoder import MAX_MODULES
from ariel.simulation.controllers.cpg_kernel import MAX_CPG_NODES, fully_connected_adjacency_matrix
from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
from ariel.simulation.environments import (
    AmphitheatreTerrainWorld,
    CraterTerrainWorld,
    RuggedTerrainWorld,
)
from ariel.utils.runners import simple_runner
from ariel.utils.tracker import Tracker


def _refused(
    exc: type[Exception], match: str, call: Callable, *args: object, **kwargs: object
) -> None:
    with pytest.raises(exc, match=match) as info:
        call(*args, **kwargs)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("seed", ["x", -1, 1.5, True])
@pytest.mark.parametrize(
    "world", [RuggedTerrainWorld, CraterTerrainWorld, AmphitheatreTerrainWorld]
)
def test_terrain_world_seed(world: type, seed: object) -> None:
    _refused(ValueError, f"{world.__name__}: seed must be None or an int >= 0", world, seed=seed)


def test_nacpg_seed_and_adjacency_size() -> None:
    _refused(ValueError, "NaCPG: seed must be None or an int", NaCPG, {0: []}, seed="x")
    for make, name in (
        (create_fully_connected_adjacency, "num_nodes"),
        (fully_connected_adjacency_matrix, "n"),
    ):
        for bad in ("8", 2.0, True):
            _refused(TypeError, f"{name} must be an int from 0 to {MAX_CPG_NODES}", make, bad)
        for bad in (-1, MAX_CPG_NODES + 1, 10**9):  # 10**9 nodes: 10**18 couplings, no memory
            _refused(ValueError, f"{name} must be from 0 to {MAX_CPG_NODES}", make, bad)
    assert create_fully_connected_adjacency(np.int64(2)) == {0: [1], 1: [0]}
    assert fully_connected_adjacency_matrix(np.int64(2)).tolist() == [[0, 1], [1, 0]]


def test_nde_number_of_modules_has_the_encoders_limit() -> None:
    for n in (MAX_MODULES + 1, 10**9):
        _refused(
            ValueError,
            f"number_of_modules must be <= {MAX_MODULES}",
            NeuralDevelopmentalEncoding,
            number_of_modules=n,
        )


def test_tracker_refuses_unknown_attributes_when_made() -> None:
    _refused(
        ValueError,
        r"'nonsense'.*allowed: .*xpos",
        Tracker,
        mujoco.mjtObj.mjOBJ_GEOM,
        "core",
        ["nonsense"],
    )
    Tracker(mujoco.mjtObj.mjOBJ_BODY, "core", ["xpos", "subtree_com"])  # body attributes


def test_cpg_time_must_be_a_number() -> None:
    cpg = NaCPG(create_fully_connected_adjacency(3), seed=1)
    expected = cpg.forward(time=0.5)
    for time in (np.float32(0.5), np.float64(0.5), torch.tensor(0.5), 0.5):
        assert torch.equal(cpg.forward(time=time), expected)
    cpg.forward(time=1)
    for time in ("1", True, np.bool_(True)):
        _refused(TypeError, "NaCPG.forward: time must be a number", cpg.forward, time=time)


def test_runner_duration_must_be_a_number() -> None:
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    simple_runner(model, data, duration=np.float32(0.01))
    assert data.time == pytest.approx(0.01)
    for duration in ("5", True):
        _refused(TypeError, "duration must be a number", simple_runner, model, data, duration)
