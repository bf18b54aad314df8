"""NaCPG, the torch tutorial API over the numpy kernel: a function of simulated time,
reproducible seeding without global side effects, parameter get/set, persistence."""

from __future__ import annotations

import copy
import math
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from ariel.simulation.controllers import cpg_kernel as ck
from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
from ariel.simulation.controllers.simple_cpg import SimpleCPG


def make_cpg(n: int = 8, **kwargs) -> NaCPG:
    kwargs.setdefault("seed", 7)
    return NaCPG(create_fully_connected_adjacency(n), **kwargs)


def test_fully_connected_adjacency() -> None:
    assert create_fully_connected_adjacency(3) == {0: [1, 2], 1: [0, 2], 2: [0, 1]}
    assert create_fully_connected_adjacency(0) == {}
    with pytest.raises(ValueError, match="from 0 to"):
        create_fully_connected_adjacency(-1)


def test_tutorial_attributes() -> None:
    cpg = make_cpg(8)
    assert isinstance(cpg, torch.nn.Module)
    assert cpg.n == 8
    assert cpg.num_of_parameters == 40
    assert cpg.num_of_parameter_groups == 5
    assert list(cpg.parameter_groups) == ["phase", "w", "amplitudes", "ha", "b"]
    for param in cpg.parameter_groups.values():
        assert isinstance(param, torch.nn.Parameter)
        assert not param.requires_grad
        assert param.shape == (8,)
    assert sum(p.numel() for p in cpg.parameters()) == 40
    assert cpg.clamping_error == 0.0
    assert cpg.angle_history == []
    out = cpg.forward(time=0.0)
    assert out.dtype == torch.float32
    assert out.shape == (8,)


def test_initial_distributions() -> None:
    cpg = NaCPG({i: [] for i in range(2000)}, seed=1)  # uncoupled: cheap to build
    for name in ("phase", "w", "amplitudes"):
        values = cpg.parameter_groups[name].numpy()
        assert np.all(np.abs(values) <= 2 * math.pi) and values.max() > 5.5
    assert 0.8 < cpg.ha.numpy().std() < 1.2
    assert np.all(np.abs(cpg.b.numpy()) <= 0.1)


def test_seeded_is_reproducible_and_leaves_global_rng_alone() -> None:
    torch.manual_seed(123)
    expected_next = torch.rand(3)
    torch.manual_seed(123)
    a = make_cpg(seed=42)
    b = make_cpg(seed=42)
    assert torch.equal(torch.rand(3), expected_next)  # global RNG untouched
    assert torch.equal(a.get_flat_params(), b.get_flat_params())
    np.testing.assert_array_equal(a.initial_state.xy, b.initial_state.xy)
    assert torch.equal(a.forward(2.0), b.forward(2.0))
    assert not torch.equal(make_cpg(seed=43).get_flat_params(), a.get_flat_params())


def test_unseeded_follows_torch_manual_seed() -> None:
    torch.manual_seed(42)
    a = make_cpg(seed=None)
    torch.manual_seed(42)
    b = make_cpg(seed=None)
    c = make_cpg(seed=None)  # global RNG moved on
    assert torch.equal(a.get_flat_params(), b.get_flat_params())
    np.testing.assert_array_equal(a.initial_state.xy_dot_old, b.initial_state.xy_dot_old)
    assert not torch.equal(b.get_flat_params(), c.get_flat_params())


def _outputs_at(cpg: NaCPG, period: float, duration: float = 6.0) -> dict[int, np.ndarray]:
    """Call forward every ``period`` seconds (time accumulated like data.time); key: time in ms."""
    out = {}
    t = 0.0
    for _ in range(round(duration / period) + 1):
        out[round(t * 1000)] = cpg.forward(time=t).numpy().copy()
        t += period
    return out


def test_output_does_not_depend_on_control_period() -> None:
    cpg = make_cpg()
    runs = [_outputs_at(cpg, period) for period in (0.02, 0.1, 0.05)]
    common = sorted(set(runs[0]) & set(runs[1]) & set(runs[2]))
    assert len(common) == 61  # every 0.1 s over 6 s
    for key in common:
        np.testing.assert_allclose(runs[0][key], runs[1][key], rtol=0, atol=1e-9)
        np.testing.assert_allclose(runs[2][key], runs[1][key], rtol=0, atol=1e-9)
    assert not np.allclose(runs[1][0], runs[1][3000])  # it does oscillate


def test_forward_matches_vectorised_kernel_bit_for_bit() -> None:
    cpg = make_cpg()
    times = np.arange(150) * 0.1
    outputs = np.stack([cpg.forward(time=t).numpy() for t in times])
    targets = ck.cpg_targets(
        cpg.get_flat_params().numpy(), cpg.initial_state, times, alpha=cpg.alpha, dt=cpg.dt
    )
    np.testing.assert_array_equal(outputs, targets.astype(np.float32))


def test_forward_zero_and_earlier_time_reset() -> None:
    cpg = make_cpg()
    first = cpg.forward(0.0)
    at_one = cpg.forward(1.0)
    cpg.forward(3.0)
    assert torch.equal(cpg.forward(1.0), at_one)  # earlier time: restart, integrate again
    assert torch.equal(cpg.forward(0.0), first)  # zero: back to the initial state
    np.testing.assert_array_equal(cpg.xy.numpy(), cpg.initial_state.xy)
    assert torch.equal(cpg.forward(1.0), at_one)


def test_forward_none_takes_one_step() -> None:
    cpg = make_cpg()
    cpg.forward(0.0)
    for _ in range(5):
        stepped = cpg.forward()
    assert torch.equal(stepped, make_cpg().forward(0.05))


def test_forward_rejects_nan_and_negative_time() -> None:
    cpg = make_cpg()
    with pytest.raises(ValueError, match="NaN"):
        cpg.forward(float("nan"))
    with pytest.raises(ValueError, match=">= 0"):
        cpg.forward(-1.0)


def test_hard_bounds_clamping_error_and_tracking() -> None:
    cpg = make_cpg(hard_bounds=(-0.2, 0.2), angle_tracking=True)
    raw = make_cpg(hard_bounds=None)
    for t in (0.0, 0.5, 1.0):
        out = cpg.forward(t)
        unclipped = raw.forward(t).double().numpy()
        assert out.abs().max() <= 0.2 + 1e-7
        assert cpg.clamping_error == pytest.approx(
            np.abs(unclipped - np.clip(unclipped, -0.2, 0.2)).sum(), abs=1e-5
        )
    assert cpg.clamping_error > 0
    assert len(cpg.angle_history) == 3
    assert cpg.angle_history[-1] == pytest.approx(out.tolist())
    cpg.forward(0.0)  # a reset clears the history
    assert len(cpg.angle_history) == 1


@pytest.mark.parametrize("kind", ["list", "ndarray", "tensor32", "tensor64"])
def test_set_flat_params_accepts_common_types(kind: str) -> None:
    cpg = make_cpg(4)
    values = np.linspace(-1.0, 1.0, 20)
    given = {
        "list": values.tolist(),
        "ndarray": values,
        "tensor32": torch.tensor(values, dtype=torch.float32),
        "tensor64": torch.tensor(values),
    }[kind]
    cpg.set_flat_params(given)
    expected = values.astype(np.float32).astype(np.float64) if kind == "tensor32" else values
    np.testing.assert_array_equal(cpg.get_flat_params().numpy(), expected)
    np.testing.assert_array_equal(cpg.w.numpy(), expected[4:8])  # group order
    np.testing.assert_array_equal(cpg.b.numpy(), expected[16:20])


def test_flat_params_round_trip_exactly() -> None:
    a, b = make_cpg(seed=1), make_cpg(seed=2)
    b.set_flat_params(a.get_flat_params())
    b.set_initial_state(*a.initial_state)
    assert torch.equal(a.forward(2.5), b.forward(2.5))


def test_wrong_sizes_and_groups_raise() -> None:
    cpg = make_cpg(8)
    with pytest.raises(ValueError, match=r"expected 40 parameters.*got 39"):
        cpg.set_flat_params(np.zeros(39))
    with pytest.raises(ValueError, match="needs 8 values; got 3"):
        cpg.set_params_by_group("phase", [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="unknown parameter group 'omega'"):
        cpg.set_params_by_group("omega", np.zeros(8))
    with pytest.raises(ValueError, match="NaN or inf"):
        cpg.set_flat_params(np.full(40, np.nan))
    with pytest.raises(ValueError, match=r"xy must have shape \(8, 2\)"):
        cpg.set_initial_state(np.zeros((3, 2)), np.zeros((8, 2)))
    with pytest.raises(TypeError, match="adjacency_dict"):
        NaCPG([[1], [0]])


def test_set_by_group_and_dict() -> None:
    cpg = make_cpg(3)
    cpg.set_params_by_group("amplitudes", [0.1, 0.2, 0.3])
    cpg.set_param_with_dict({"ha": np.ones(3), "b": torch.zeros(3)})
    np.testing.assert_array_equal(cpg.amplitudes.numpy(), [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(cpg.ha.numpy(), [1, 1, 1])
    np.testing.assert_array_equal(cpg.b.numpy(), [0, 0, 0])


def test_b_offsets_the_output() -> None:
    cpg = make_cpg(4, hard_bounds=None)
    base = cpg.forward(1.0).double().numpy()
    cpg.set_params_by_group("b", cpg.b.numpy() + np.array([0.1, -0.2, 0.3, 0.0]))
    shifted = cpg.forward(1.0).double().numpy()
    np.testing.assert_allclose(shifted - base, [0.1, -0.2, 0.3, 0.0], atol=1e-6)


def test_parameter_change_restarts_from_initial_state() -> None:
    cpg = make_cpg()
    cpg.forward(0.0)
    cpg.forward(2.0)
    with torch.no_grad():
        cpg.phase[0] += 0.5  # an in-place edit is noticed, too
    fresh = make_cpg()
    fresh.set_flat_params(cpg.get_flat_params())
    assert torch.equal(cpg.forward(2.1), fresh.forward(2.1))
    cpg.phase.data = torch.zeros(8, dtype=torch.float64)  # replaced storage
    fresh.set_params_by_group("phase", np.zeros(8))
    assert torch.equal(cpg.forward(2.2), fresh.forward(2.2))


def test_reset_and_initial_state() -> None:
    cpg = make_cpg()
    state = cpg.initial_state
    assert state.xy.shape == state.xy_dot_old.shape == (8, 2)
    state.xy[:] = 0  # a copy: editing it changes nothing
    assert np.any(cpg.initial_state.xy != 0)
    cpg.forward(1.0)
    cpg.reset()
    np.testing.assert_array_equal(cpg.xy.numpy(), cpg.initial_state.xy)
    new_xy = np.full((8, 2), 0.5)
    cpg.initial_state = (new_xy, np.zeros((8, 2)))
    np.testing.assert_array_equal(cpg.initial_state.xy, new_xy)


def test_save_load_round_trip(tmp_path: Path) -> None:
    a, b = make_cpg(seed=3), make_cpg(seed=4)
    path = tmp_path / "cpg.pt"
    a.save(path)
    b.load(path)
    assert torch.equal(a.get_flat_params(), b.get_flat_params())
    assert torch.equal(a.forward(1.5), b.forward(1.5))
    # A file holding only the five groups (upstream's format) loads too.
    torch.save({name: p.detach().float() for name, p in a.parameter_groups.items()}, path)
    c = make_cpg(seed=5)
    c.load(path)
    np.testing.assert_allclose(c.get_flat_params().numpy(), a.get_flat_params().numpy(), atol=1e-6)


def test_copies_behave_like_the_original() -> None:
    cpg = make_cpg()
    cpg.forward(1.0)
    for clone in (copy.deepcopy(cpg), pickle.loads(pickle.dumps(cpg))):
        assert torch.equal(clone.forward(2.0), make_cpg().forward(2.0))


def test_term_helpers() -> None:
    assert NaCPG.term_a(0.1, 2.0) == pytest.approx(0.1 * (1 - 4.0))
    assert NaCPG.zeta(0.5, 3.0) == pytest.approx(0.5)
    assert NaCPG.zeta(0.5, -3.0) == pytest.approx(1.5)
    assert NaCPG.term_b(1.0, 2.0) == pytest.approx(2.0)  # w / (zeta + 1e-9)


def test_kernel_and_controller_modules_do_not_import_torch() -> None:
    code = (
        "import sys\n"
        "import ariel.simulation.controllers.cpg_kernel\n"
        "import ariel.simulation.controllers.controller\n"
        "import ariel.simulation.controllers\n"
        "import ariel.simulation.tasks\n"
        "import ariel.utils.runners, ariel.utils.tracker\n"
        "assert 'torch' not in sys.modules, 'torch imported'\n"
        "from ariel.simulation.controllers import NaCPG\n"
        "assert 'torch' in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


@pytest.mark.parametrize("make", [make_cpg, lambda: SimpleCPG(create_fully_connected_adjacency(3))])
def test_a_time_far_ahead_is_refused_not_integrated_for_hours(make) -> None:
    """forward(time) integrates to ``time``: an epoch or wall-clock time hung for hours."""
    cpg = make()
    name = type(cpg).__name__
    for far, said in (
        (1.7e9, "170,000,000,000 steps"),
        (1e300, r"1e\+302 steps"),
        (1e308, "more than 1e308 steps"),
    ):
        with pytest.raises(
            ValueError, match=rf"{name}.forward\(time\): .*{said}.* at most 1,000,000"
        ):
            cpg.forward(far)  # 1e308: an OverflowError; 1e300: a 300-digit count
    with pytest.raises(ValueError, match="finite"):
        cpg.forward(float("nan"))
    assert cpg.forward(0.05).shape == (cpg.n if hasattr(cpg, "n") else 3,)
