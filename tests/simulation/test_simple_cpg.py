"""SimpleCPG and get_state_from_data (upstream's simple_cpg and controllers.utils)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch

from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
from ariel.simulation.controllers.simple_cpg import SimpleCPG, create_fully_connected_adjacency
from ariel.simulation.controllers.utils.data_get import get_state_from_data
from ariel.simulation.environments import SimpleFlatWorld


def test_parameters_shapes_and_seed() -> None:
    cpg = SimpleCPG(create_fully_connected_adjacency(8), seed=3)
    assert cpg.n == 8 and cpg.num_of_parameters == 40 and cpg.num_of_parameter_groups == 5
    assert list(cpg.parameter_groups) == ["phase", "w", "amplitudes", "ha", "b"]
    assert torch.equal(
        cpg.get_flat_params(),
        SimpleCPG(create_fully_connected_adjacency(8), seed=3).get_flat_params(),
    )
    assert not torch.equal(
        cpg.get_flat_params(),
        SimpleCPG(create_fully_connected_adjacency(8), seed=4).get_flat_params(),
    )
    assert torch.all(cpg.w >= -2) and torch.all(cpg.w <= 6)


def test_output_is_bounded_and_a_function_of_time() -> None:
    cpg = SimpleCPG(create_fully_connected_adjacency(4), seed=0)
    cpg.set_flat_params(np.r_[np.zeros(4), np.full(4, 6.0), np.ones(4), np.zeros(4), np.zeros(4)])
    out = torch.stack([cpg(t) for t in np.arange(0, 3, 0.05)])
    assert out.shape == (60, 4) and out.dtype == torch.float32
    assert torch.all(out.abs() <= np.pi / 2 + 1e-6)
    assert out[:, 0].std() > 0.1  # it oscillates
    assert torch.equal(cpg(1.0), cpg(1.0)) and torch.equal(cpg(0.0), out[0])
    coarse = SimpleCPG(create_fully_connected_adjacency(4), seed=0)
    coarse.set_flat_params(cpg.get_flat_params())
    assert torch.equal(coarse(2.0), cpg(2.0))  # the same time, whatever the call rate


def test_set_params_errors() -> None:
    cpg = SimpleCPG(create_fully_connected_adjacency(2), seed=0)
    with pytest.raises(ValueError, match="Expected 10"):
        cpg.set_flat_params([1.0, 2.0])
    with pytest.raises(ValueError, match="does not exist"):
        cpg.set_params_by_group("nope", [1.0, 2.0])
    cpg.set_param_with_dict({"w": [1.0, 2.0]})
    assert cpg.w.tolist() == [1.0, 2.0]


def test_get_state_from_data() -> None:
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=(0, 0, 0), rotation=(0, 0, 90))
    model = world.spec.compile()
    data = mujoco.MjData(model)
    data.qpos[3:7] = -data.qpos[3:7]  # the same orientation, the other sign
    data.qpos[7:] = np.arange(8) * 0.1
    state = get_state_from_data(data)
    assert state.shape == (3 + 8,)
    assert np.allclose(state[:3], [0, 0, np.sin(np.pi / 4)])  # w made positive first
    assert np.allclose(state[3:], np.arange(8) * 0.1)
