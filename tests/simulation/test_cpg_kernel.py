"""The numpy NA-CPG kernel: agreement with a literal scalar implementation of upstream's update,
batch and chunking invariance (bit for bit), sampling semantics and input validation."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from ariel.simulation.controllers import cpg_kernel as ck


def reference_integrate(params, xy, xy_dot_old, adjacency, n_steps, alpha=0.1, dt=0.01):
    """Upstream's update written out per node with Python floats, one network."""
    n = len(xy)
    phase, w, _amplitudes, ha, _b = (list(params[k * n : (k + 1) * n]) for k in range(5))
    xy = [[float(v) for v in row] for row in xy]
    old = [[float(v) for v in row] for row in xy_dot_old]
    eps = 1e-9
    for _ in range(n_steps):
        terms = []
        for i in range(n):  # all from the pre-update state
            x, y = xy[i]
            r2 = x * x + y * y
            a = alpha * (1 - r2**2)
            zeta = 1 - ha[i] * (old[i][0] + eps) / (abs(old[i][0]) + eps)
            terms.append((a, w[i] / (zeta + eps)))
        for i in range(n):  # Gauss-Seidel: xy[j] for j < i is already updated
            a, bb = terms[i]
            x, y = xy[i]
            vx, vy = a * x - bb * y, bb * x + a * y
            for j in adjacency[i]:
                angle = phase[i] - phase[j]
                c, s = math.cos(angle), math.sin(angle)
                vx += c * xy[j][0] - s * xy[j][1]
                vy += s * xy[j][0] + c * xy[j][1]
            vx = min(max(vx, old[i][0] - 10), old[i][0] + 10)
            vy = min(max(vy, old[i][1] - 10), old[i][1] + 10)
            old[i] = [x, y]  # upstream's quirk: the previous STATE
            xy[i] = [x + dt * vx, y + dt * vy]
    return np.array(xy), np.array(old)


def _case(seed: int, n: int, kind: str):
    rng = np.random.default_rng(seed)
    params = ck.random_parameters(n, rng)
    state = ck.random_state(n, rng)
    if kind == "full":
        adjacency = {i: [j for j in range(n) if j != i] for i in range(n)}
    elif kind == "sparse":
        adjacency = {i: [j for j in range(n) if rng.random() < 0.5 and j != i] for i in range(n)}
    elif kind == "self":  # with self-coupling
        adjacency = {i: [j for j in range(n) if rng.random() < 0.6 or j == i] for i in range(n)}
    else:  # neighbours listed twice couple twice
        adjacency = {i: [j for j in range(n) if j != i] * 2 for i in range(n)}
    return params, state, adjacency


@pytest.mark.parametrize(
    ("seed", "n", "kind"),
    [(0, 8, "full"), (1, 3, "full"), (2, 5, "sparse"), (3, 1, "full"), (4, 8, "self"),
     (5, 12, "full"), (6, 6, "sparse"), (7, 2, "self"), (8, 4, "twice")],
)  # fmt: skip
def test_kernel_matches_scalar_reference(seed: int, n: int, kind: str) -> None:
    params, state, adjacency = _case(seed, n, kind)
    for steps in (1, 7, 100):
        ref_xy, ref_old = reference_integrate(params, *state, adjacency, steps)
        out = ck.integrate(params, state, steps, adjacency=adjacency)
        assert out.xy.shape == (n, 2)
        np.testing.assert_allclose(out.xy, ref_xy, rtol=0, atol=1e-12)
        np.testing.assert_allclose(out.xy_dot_old, ref_old, rtol=0, atol=1e-12)


def test_reference_and_kernel_really_move() -> None:
    # Guard against a vacuous comparison: the state changes and the clamp is exercised.
    params, state, adjacency = _case(0, 8, "full")
    out = ck.integrate(params, state, 100, adjacency=adjacency)
    assert np.abs(out.xy - state.xy).max() > 0.5
    norms = np.linalg.norm(ck.integrate(params, state, 1500).xy, axis=-1)
    assert 1.0 < norms.mean() < 5.0  # settles on a bounded cycle (upstream: ~2.7-2.9)


def test_default_adjacency_is_fully_connected() -> None:
    params, state, adjacency = _case(0, 6, "full")
    a = ck.integrate(params, state, 50, adjacency=adjacency)
    b = ck.integrate(params, state, 50)
    np.testing.assert_array_equal(a.xy, b.xy)
    np.testing.assert_array_equal(ck.adjacency_matrix(adjacency), 1 - np.eye(6))
    np.testing.assert_array_equal(ck.adjacency_matrix({0: [1, 1], 1: [0]}), [[0, 2], [1, 0]])


@pytest.mark.parametrize("kind", ["full", "sparse"])
def test_batch_equals_separate_runs_bit_for_bit(kind: str) -> None:
    rng = np.random.default_rng(11)
    n, batch = 8, 13
    params = ck.random_parameters(n, rng, size=batch)
    state = ck.random_state(n, rng)
    adjacency = _case(11, n, kind)[2]
    together = ck.integrate(params, state, 300, adjacency=adjacency)
    assert together.xy.shape == (batch, n, 2)
    for row in range(batch):
        alone = ck.integrate(params[row], state, 300, adjacency=adjacency)
        np.testing.assert_array_equal(alone.xy, together.xy[row])
        np.testing.assert_array_equal(alone.xy_dot_old, together.xy_dot_old[row])
    # Rows really differ (different parameters), so the comparison means something.
    assert not np.array_equal(together.xy[0], together.xy[1])


def test_per_row_initial_states() -> None:
    rng = np.random.default_rng(5)
    n = 4
    params = ck.random_parameters(n, rng, size=3)
    xy = rng.standard_normal((3, n, 2))
    old = rng.standard_normal((3, n, 2))
    together = ck.integrate(params, (xy, old), 40)
    for row in range(3):
        alone = ck.integrate(params[row], (xy[row], old[row]), 40)
        np.testing.assert_array_equal(alone.xy, together.xy[row])


def test_chunked_advance_equals_one_call_bit_for_bit() -> None:
    params, state, _ = _case(3, 8, "full")
    batch = np.stack([params, ck.random_parameters(8, 9)])
    whole = ck.NaCPGKernel(batch)
    whole.set_state(*state)
    whole.advance(500)
    pieces = ck.NaCPGKernel(batch)
    pieces.set_state(*state)
    for chunk in (1, 10, 0, 3, 250, 236):
        pieces.advance(chunk)
    np.testing.assert_array_equal(whole.state().xy, pieces.state().xy)
    np.testing.assert_array_equal(whole.state().xy_dot_old, pieces.state().xy_dot_old)
    # Reloading the same state mid-run (fresh accumulators) continues identically too.
    restarted = ck.NaCPGKernel(batch)
    restarted.set_state(*pieces.state())
    restarted.advance(100)
    whole.advance(100)
    np.testing.assert_array_equal(whole.state().xy, restarted.state().xy)


def test_kernel_survives_pickle_and_deepcopy() -> None:
    import copy

    params, state, _ = _case(2, 5, "full")
    kernel = ck.NaCPGKernel(params)
    kernel.set_state(*state)
    kernel.advance(20)
    clones = [pickle.loads(pickle.dumps(kernel)), copy.deepcopy(kernel)]
    for clone in clones:
        clone.advance(30)
        assert not np.array_equal(clone.state().xy, kernel.state().xy)
    kernel.advance(30)
    for clone in clones:
        np.testing.assert_array_equal(clone.state().xy, kernel.state().xy)


def test_cpg_targets_sampling_semantics() -> None:
    n, batch = 8, 4
    params = ck.random_parameters(n, 21, size=batch)
    state = ck.random_state(n, 22)
    times = np.arange(150) * 0.1  # 150 samples over 15 s, every 10 internal steps
    targets = ck.cpg_targets(params, state, times)
    assert targets.shape == (batch, 150, n)
    assert targets.dtype == np.float64
    assert np.all(np.abs(targets) <= math.pi / 2)
    # t = 0 is the output of the initial state; t = 1.0 is after 100 steps.
    np.testing.assert_array_equal(targets[:, 0], ck.angles(params, state.xy[None]))
    after = ck.integrate(params, state, 100)
    np.testing.assert_array_equal(targets[:, 10], ck.angles(params, after.xy))
    np.testing.assert_array_equal(targets[:, 10], ck.angles(params, after))  # a CPGState too
    # Order and repeats do not matter.
    shuffled = np.random.default_rng(0).permutation(150)
    np.testing.assert_array_equal(
        ck.cpg_targets(params, state, times[shuffled]), targets[:, shuffled]
    )
    repeated = ck.cpg_targets(params, state, [0.5, 0.5, 0.2])
    np.testing.assert_array_equal(repeated[:, 0], repeated[:, 1])
    np.testing.assert_array_equal(repeated[:, 2], targets[:, 2])
    # A 1-D parameter vector gives (T, n).
    assert ck.cpg_targets(params[0], state, times).shape == (150, n)
    np.testing.assert_array_equal(ck.cpg_targets(params[0], state, times), targets[0])


def test_step_count_is_floor_with_tolerance() -> None:
    # Accumulated float time (as MuJoCo's data.time) lands on the intended step.
    accumulated = 0.0
    for _ in range(50):
        accumulated += 0.002
    assert accumulated != 0.1
    assert int(ck.cpg_steps(accumulated, 0.01)) == 10
    np.testing.assert_array_equal(
        ck.cpg_steps([0.0, 0.009, 0.01, 0.0299999999999], 0.01), [0, 0, 1, 3]
    )
    with pytest.raises(ValueError, match=">= 0"):
        ck.cpg_steps([-0.5], 0.01)
    with pytest.raises(ValueError, match="finite"):
        ck.cpg_steps([np.nan], 0.01)


def test_b_is_an_output_offset() -> None:
    params, state, _ = _case(1, 4, "full")
    shifted = params.copy()
    shifted[16:20] += 0.3  # group b
    times = np.arange(20) * 0.05
    plain = ck.cpg_targets(params, state, times, hard_bounds=None)
    offset = ck.cpg_targets(shifted, state, times, hard_bounds=None)
    np.testing.assert_allclose(offset - plain, 0.3, atol=1e-12)


def test_hard_bounds_clip_and_none() -> None:
    params, state, _ = _case(0, 8, "full")
    times = np.arange(100) * 0.1
    raw = ck.cpg_targets(params, state, times, hard_bounds=None)
    assert np.abs(raw).max() > math.pi / 2  # random amplitudes saturate the default bounds
    clipped = ck.cpg_targets(params, state, times, hard_bounds=(-0.5, 0.25))
    np.testing.assert_array_equal(clipped, np.clip(raw, -0.5, 0.25))
    with pytest.raises(ValueError, match="hard_bounds"):
        ck.cpg_targets(params, state, times, hard_bounds=(1.0, -1.0))


def test_random_parameters_and_state() -> None:
    n = 1000
    params = ck.random_parameters(n, 3)
    groups = ck.split_parameters(params)
    assert list(groups) == ["phase", "w", "amplitudes", "ha", "b"]
    for name in ("phase", "w", "amplitudes"):
        assert np.all(np.abs(groups[name]) <= 2 * math.pi)
        assert groups[name].max() > 5.5 and groups[name].min() < -5.5
    assert 0.8 < groups["ha"].std() < 1.2
    assert np.all(np.abs(groups["b"]) <= 0.1)
    np.testing.assert_array_equal(params, ck.random_parameters(n, np.random.default_rng(3)))
    assert ck.random_parameters(4, 0, size=3).shape == (3, 20)
    state = ck.random_state(5, 1)
    assert state.xy.shape == state.xy_dot_old.shape == (5, 2)


def test_adjacency_validation() -> None:
    with pytest.raises(ValueError, match=r"keys must be 0\.\.2"):
        ck.adjacency_matrix({0: [1], 1: [0], 3: [0]})
    with pytest.raises(ValueError, match="lists node 5"):
        ck.adjacency_matrix({0: [5], 1: [0]})
    with pytest.raises(ValueError, match="expected 4"):
        ck.NaCPGKernel(ck.random_parameters(4, 0), {0: [1], 1: [0]})
    with pytest.raises(ValueError, match="square"):
        ck.adjacency_matrix(np.ones((2, 3)))
    matrix = ck.adjacency_matrix({0: [1, 2], 1: [], 2: [0]})
    np.testing.assert_array_equal(matrix, [[0, 1, 1], [0, 0, 0], [1, 0, 0]])


def test_input_validation() -> None:
    with pytest.raises(ValueError, match="5\\*n entries; got 7"):
        ck.NaCPGKernel(np.zeros(7))
    with pytest.raises(ValueError, match="NaN or inf"):
        ck.NaCPGKernel(np.full(10, np.nan))
    kernel = ck.NaCPGKernel(ck.random_parameters(2, 0))
    with pytest.raises(RuntimeError, match="set_state"):
        kernel.advance(1)
    with pytest.raises(ValueError, match="xy must have shape"):
        kernel.set_state(np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="dt must be"):
        ck.NaCPGKernel(ck.random_parameters(2, 0), dt=0.0)
    with pytest.raises(ValueError, match=">= 0"):
        ck.cpg_targets(ck.random_parameters(2, 0), ck.random_state(2, 0), [0.1, -1.0])
