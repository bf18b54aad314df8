"""Tests for the Neural Developmental Encoding (torch module and numpy forward)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import torch

from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding
from ariel.ec.genotypes.nde.numpy_forward import nde_forward_numpy, validate_genotype

N = 20
G = 64


def _genotype(seed: int, size: int = G) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.random(size).astype(np.float32) for _ in range(3)]


def _state_equal(a: torch.nn.Module, b: torch.nn.Module) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)


def _outputs_equal(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


@pytest.fixture(scope="module")
def nde() -> NeuralDevelopmentalEncoding:
    return NeuralDevelopmentalEncoding(number_of_modules=N, seed=123)


def test_output_shapes_dtype_and_range(nde: NeuralDevelopmentalEncoding) -> None:
    out = nde.forward(_genotype(0))
    assert isinstance(out, list)
    assert [m.shape for m in out] == [(20, 4), (20, 20, 6), (20, 3)]
    for m in out:
        assert isinstance(m, np.ndarray)
        assert m.dtype == np.float32
        assert np.all(m > 0.0)
        assert np.all(m < 1.0)


def test_tutorial_call_with_global_rng() -> None:
    rng = np.random.default_rng(seed=42)
    genotype = [rng.random(G).astype(np.float32) for _ in range(3)]
    nde = NeuralDevelopmentalEncoding(number_of_modules=N)
    p = nde.forward(genotype)
    assert [m.shape for m in p] == [(20, 4), (20, 20, 6), (20, 3)]


def test_architecture_attributes(nde: NeuralDevelopmentalEncoding) -> None:
    assert nde.number_of_modules == N
    assert nde.genotype_size == G
    assert nde.type_p_shape == (N, 4)
    assert nde.conn_p_shape == (N, N, 6)
    assert nde.rot_p_shape == (N, 3)
    assert nde.output_layers == [nde.type_p_out, nde.conn_p_out, nde.rot_p_out]
    assert nde.output_shapes == [(N, 4), (N, N, 6), (N, 3)]
    assert isinstance(nde.relu, torch.nn.ReLU)
    assert isinstance(nde.tanh, torch.nn.Tanh)
    assert isinstance(nde.sigmoid, torch.nn.Sigmoid)
    # Upstream's state_dict keys, so upstream NDE.pth files load.
    assert list(nde.state_dict()) == [
        f"{layer}.{kind}"
        for layer in ("fc1", "fc2", "fc3", "fc4", "type_p_out", "conn_p_out", "rot_p_out")
        for kind in ("weight", "bias")
    ]
    assert all(not p.requires_grad for p in nde.parameters())


def test_parameter_counts_n20(nde: NeuralDevelopmentalEncoding) -> None:
    counts = {
        name: sum(p.numel() for p in getattr(nde, name).parameters())
        for name in ("fc1", "fc2", "fc3", "fc4", "type_p_out", "conn_p_out", "rot_p_out")
    }
    assert counts == {
        "fc1": 4160,
        "fc2": 2080,
        "fc3": 2112,
        "fc4": 8320,
        "type_p_out": 10320,
        "conn_p_out": 309600,
        "rot_p_out": 7740,
    }


def test_weights_follow_default_linear_init(nde: NeuralDevelopmentalEncoding) -> None:
    for layer in (nde.fc1, nde.fc2, nde.conn_p_out):
        bound = 1.0 / np.sqrt(layer.in_features)
        for p in (layer.weight, layer.bias):
            assert float(p.abs().max()) <= bound
            # Uniform over the whole range, not a tiny or constant init.
            assert float(p.abs().max()) > 0.9 * bound
            assert float(p.std()) > 0.5 * bound


def test_same_seed_is_bit_for_bit_reproducible() -> None:
    a = NeuralDevelopmentalEncoding(N, seed=7)
    b = NeuralDevelopmentalEncoding(N, seed=7)
    assert _state_equal(a, b)
    g = _genotype(1)
    assert _outputs_equal(a.forward(g), b.forward(g))
    # Repeated calls on one instance give the same result.
    assert _outputs_equal(a.forward(g), a.forward(g))


def test_different_seeds_differ() -> None:
    a = NeuralDevelopmentalEncoding(N, seed=7)
    b = NeuralDevelopmentalEncoding(N, seed=8)
    assert not _state_equal(a, b)
    g = _genotype(1)
    assert not np.array_equal(a.forward(g)[1], b.forward(g)[1])


def test_seed_none_honours_torch_manual_seed() -> None:
    torch.manual_seed(42)
    a = NeuralDevelopmentalEncoding(N)
    torch.manual_seed(42)
    b = NeuralDevelopmentalEncoding(N)
    assert _state_equal(a, b)
    g = _genotype(2)
    assert _outputs_equal(a.forward(g), b.forward(g))
    # Without reseeding, the global RNG moves on and the next NDE differs.
    c = NeuralDevelopmentalEncoding(N)
    assert not _state_equal(a, c)


def test_seeded_init_matches_global_rng_after_manual_seed() -> None:
    torch.manual_seed(5)
    global_rng = NeuralDevelopmentalEncoding(N)
    private = NeuralDevelopmentalEncoding(N, seed=5)
    assert _state_equal(global_rng, private)


def test_seed_does_not_touch_global_rng() -> None:
    torch.manual_seed(0)
    before = torch.get_rng_state().clone()
    nde = NeuralDevelopmentalEncoding(N, seed=99)
    nde.forward(_genotype(3))
    assert torch.equal(torch.get_rng_state(), before)


def test_seed_none_draws_from_global_rng() -> None:
    torch.manual_seed(0)
    before = torch.get_rng_state().clone()
    NeuralDevelopmentalEncoding(N)
    assert not torch.equal(torch.get_rng_state(), before)


@pytest.mark.parametrize(
    "make",
    [
        lambda g: [list(map(float, c)) for c in g],
        lambda g: tuple(torch.from_numpy(c) for c in g),
        lambda g: np.stack(g),
        lambda g: torch.from_numpy(np.stack(g)),
        lambda g: [c.astype(np.float64) for c in g],
    ],
    ids=["lists", "tensors", "array_3xG", "tensor_3xG", "float64"],
)
def test_accepted_genotype_forms(nde: NeuralDevelopmentalEncoding, make) -> None:
    g = _genotype(4)
    assert _outputs_equal(nde.forward(make(g)), nde.forward(g))


def test_chromosomes_map_to_their_heads(nde: NeuralDevelopmentalEncoding) -> None:
    g = _genotype(5)
    other = _genotype(6)
    base = nde.forward(g)
    # Changing only the rotation chromosome changes only the rotation output.
    changed = nde.forward([g[0], g[1], other[2]])
    assert np.array_equal(changed[0], base[0])
    assert np.array_equal(changed[1], base[1])
    assert not np.array_equal(changed[2], base[2])


def test_custom_genotype_size() -> None:
    nde = NeuralDevelopmentalEncoding(number_of_modules=3, genotype_size=10, seed=1)
    out = nde.forward(_genotype(0, size=10))
    assert [m.shape for m in out] == [(3, 4), (3, 3, 6), (3, 3)]
    assert nde.fc1.in_features == 10


@pytest.mark.parametrize(
    ("genotype", "match"),
    [
        (lambda: _genotype(0)[:2], "exactly 3 chromosomes"),
        (lambda: [*_genotype(0), _genotype(1)[0]], "exactly 3 chromosomes"),
        (lambda: [np.zeros(G), np.zeros(G - 1), np.zeros(G)], "chromosome 1 .*length 64"),
        (lambda: [np.zeros(G), np.zeros(G), np.zeros((2, G))], "chromosome 2 .*length 64"),
        (lambda: np.zeros((3, G + 1)), "length 64"),
        (lambda: np.zeros((2, G)), "exactly 3 chromosomes"),
        (lambda: np.zeros(3 * G), r"shape \(3, 64\)"),
        (lambda: [np.full(G, np.nan), np.zeros(G), np.zeros(G)], "chromosome 0 .*NaN or inf"),
        (lambda: [np.zeros(G), np.zeros(G), np.r_[np.inf, np.zeros(G - 1)]], "NaN or inf"),
        (lambda: [np.zeros(G), np.zeros(G), np.full(G, 1e300)], "NaN or inf"),
        (lambda: [np.zeros(G), ["a"] * G, np.zeros(G)], "chromosome 1 must be numeric"),
        (lambda: [np.zeros(G), [None] * G, np.zeros(G)], "chromosome 1 must be numeric"),
        (lambda: [np.zeros(G), np.zeros(G, dtype=complex), np.zeros(G)], "numeric"),
        (lambda: 5, "sequence of 3 chromosomes"),
        (lambda: "abc", "sequence of 3 chromosomes"),
    ],
)
def test_bad_genotypes_raise(nde: NeuralDevelopmentalEncoding, genotype, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        nde.forward(genotype())
    with pytest.raises(ValueError, match=match):
        nde_forward_numpy(nde.to_numpy_weights(), genotype())


def test_error_messages_are_one_line(nde: NeuralDevelopmentalEncoding) -> None:
    with pytest.raises(ValueError) as info:
        nde.forward([np.zeros(G), ["x"] * G, np.zeros(G)])
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"number_of_modules": 0}, ValueError, "number_of_modules must be >= 1"),
        ({"number_of_modules": -3}, ValueError, "number_of_modules must be >= 1"),
        ({"number_of_modules": 5, "genotype_size": 0}, ValueError, "genotype_size must be >= 1"),
        ({"number_of_modules": 2.5}, TypeError, "number_of_modules must be an int"),
        ({"number_of_modules": True}, TypeError, "number_of_modules must be an int"),
        ({"number_of_modules": 5, "seed": -1}, ValueError, "seed must be None or an int"),
        ({"number_of_modules": 5, "seed": 1.5}, ValueError, "seed must be None or an int"),
    ],
)
def test_bad_constructor_arguments(kwargs: dict, exc: type, match: str) -> None:
    with pytest.raises(exc, match=match):
        NeuralDevelopmentalEncoding(**kwargs)


def test_numpy_integer_sizes_are_accepted() -> None:
    nde = NeuralDevelopmentalEncoding(np.int64(4), np.int32(8), seed=np.int64(3))
    assert nde.number_of_modules == 4
    assert nde.seed == 3


@pytest.mark.parametrize(("n", "g", "seed"), [(20, 64, 0), (5, 64, 1), (30, 64, 2), (7, 12, 3)])
def test_numpy_forward_matches_torch(n: int, g: int, seed: int) -> None:
    nde = NeuralDevelopmentalEncoding(n, genotype_size=g, seed=seed)
    weights = nde.to_numpy_weights()
    assert all(w.dtype == np.float32 for w in weights.values())
    for k in range(10):
        genotype = _genotype(100 * seed + k, size=g)
        t_out = nde.forward(genotype)
        n_out = nde_forward_numpy(weights, genotype)
        for a, b in zip(t_out, n_out, strict=True):
            assert b.shape == a.shape
            assert b.dtype == np.float32
            assert float(np.max(np.abs(a - b))) < 1e-6


def test_numpy_forward_extreme_inputs_no_warnings(nde: NeuralDevelopmentalEncoding) -> None:
    weights = nde.to_numpy_weights()
    genotype = [np.full(G, 1e4), np.full(G, -1e4), np.zeros(G)]
    with np.errstate(all="raise"):
        out = nde_forward_numpy(weights, genotype)
    ref = nde.forward(genotype)
    for a, b in zip(ref, out, strict=True):
        assert np.all(np.isfinite(b))
        assert float(np.max(np.abs(a - b))) < 1e-6


def test_numpy_weights_are_copies(nde: NeuralDevelopmentalEncoding) -> None:
    weights = nde.to_numpy_weights()
    weights["fc1.weight"][:] = 0.0
    assert float(nde.fc1.weight.abs().sum()) > 0.0


def test_numpy_forward_missing_weights() -> None:
    with pytest.raises(ValueError, match="missing"):
        nde_forward_numpy({}, _genotype(0))


def test_validate_genotype_returns_float32_array() -> None:
    out = validate_genotype([[1, 2], [3, 4], [5, 6]], 2)
    assert out.dtype == np.float32
    assert out.shape == (3, 2)
    assert out.tolist() == [[1, 2], [3, 4], [5, 6]]


def test_save_load_roundtrip(tmp_path, nde: NeuralDevelopmentalEncoding) -> None:
    path = tmp_path / "NDE.pth"
    nde.save(path)
    # Plain state_dict on disk (upstream format).
    assert set(torch.load(path, weights_only=True)) == set(nde.state_dict())
    other = NeuralDevelopmentalEncoding(N, seed=456)
    assert not _state_equal(other, nde)
    assert other.load(path) is other
    assert _state_equal(other, nde)
    assert all(not p.requires_grad for p in other.parameters())
    restored = NeuralDevelopmentalEncoding.from_file(path)
    assert restored.number_of_modules == N
    assert restored.genotype_size == G
    g = _genotype(9)
    assert _outputs_equal(restored.forward(g), nde.forward(g))


def test_load_rejects_wrong_size(tmp_path, nde: NeuralDevelopmentalEncoding) -> None:
    path = tmp_path / "NDE.pth"
    nde.save(path)
    with pytest.raises(RuntimeError, match="size mismatch"):
        NeuralDevelopmentalEncoding(5, seed=0).load(path)


def test_numpy_forward_module_does_not_import_torch() -> None:
    code = (
        "import sys; import ariel.ec.genotypes.nde.numpy_forward; "
        "import ariel.ec.genotypes.nde; "
        "assert 'torch' not in sys.modules, 'torch was imported'"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"number_of_modules": 1}, "number_of_modules must be 2 to 200, not 1"),
        ({"number_of_modules": 1200}, "number_of_modules must be 2 to 200, not 1200"),
        ({"genotype_size": 0}, "genotype_size must be 1 to 4096, not 0"),
        ({"genotype_size": 10**6}, "genotype_size must be 1 to 4096"),
    ],
)
def test_the_run_encoder_bounds_its_sizes_before_it_allocates(options: dict, match: str) -> None:
    """1,200 modules took 9 GB (the NDE's connection layer grows with its square) before a
    run could say anything."""
    from ariel.ec.genotypes.nde.encoder import NDEEncoder

    with pytest.raises(ValueError, match=match):
        NDEEncoder(**options)
