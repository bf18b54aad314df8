"""Tests for the HighProbabilityDecoder (probability matrices -> robot tree)."""

from __future__ import annotations

import itertools
import subprocess
import sys

import mujoco
import networkx as nx
import numpy as np
import pytest
import torch

from ariel.body_phenotypes.robogen_lite import constructor
from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    ALLOWED_ROTATIONS,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.decoders import (
    HighProbabilityDecoder,
    hi_prob_decoding as hpd_module,
)
from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding
from ariel.ec.genotypes.nde.numpy_forward import nde_forward_numpy

CORE, BRICK, HINGE, NONE = (t.value for t in ModuleType)
FRONT, BACK, RIGHT, LEFT, TOP, BOTTOM = (f.value for f in ModuleFaces)


def _types(*rows: int) -> np.ndarray:
    """Type matrix where module i prefers type rows[i] (0.9 vs 0.1 elsewhere)."""
    t = np.full((len(rows), 4), 0.1)
    t[np.arange(len(rows)), rows] = 0.9
    return t


def _decode(types, conn, rots=None) -> tuple[nx.DiGraph, HighProbabilityDecoder]:
    n = len(types)
    if rots is None:
        rots = np.full((n, 3), 0.2)
    dec = HighProbabilityDecoder(num_modules=n)
    return dec.probability_matrices_to_graph(types, conn, rots), dec


def _edges(graph: nx.DiGraph) -> list[tuple[int, int, str]]:
    """Graph edges, sorted (networkx iterates edges grouped by source, not insertion order)."""
    return sorted((u, v, d["face"]) for u, v, d in graph.edges(data=True))


def _decoding_order(dec: HighProbabilityDecoder) -> list[tuple[int, int, str]]:
    return [(p, c, f.name) for p, c, f in dec.edges]


def _reference_decode(type_p, conn_p, rot_p) -> tuple[dict, list]:
    """Literal, loop-by-loop transcription of upstream's algorithm (slow, for comparison)."""
    n = type_p.shape[0]
    type_p, conn_p, rot_p = type_p.copy(), conn_p.copy(), rot_p.copy()
    for i in range(n):
        for f in range(6):
            conn_p[i, i, f] = 0.0
    type_p[:, CORE] = 0.0
    type_p[0, CORE] = 1.0
    conn_p[:, 0, :] = 0.0
    types = {i: ModuleType(int(np.argmax(type_p[i]))) for i in range(n)}
    for i in range(n):
        if types[i] is ModuleType.NONE:
            conn_p[i, :, :] = 0.0
            conn_p[:, i, :] = 0.0
        for face in ModuleFaces:
            if face not in ALLOWED_FACES[types[i]]:
                conn_p[i, :, face.value] = 0.0
        for rot in ModuleRotationsIdx:
            if rot not in ALLOWED_ROTATIONS[types[i]]:
                rot_p[i, rot.value] = 0.0
    rots = {i: ModuleRotationsIdx(int(np.argmax(rot_p[i]))) for i in range(n)}
    candidates = [i for i in range(n) if types[i] is not ModuleType.NONE]
    instantiated = {0}
    available = np.zeros_like(conn_p)
    available[0] = 1.0
    edges = []
    for _ in candidates:
        masked = conn_p * available
        best, best_val = None, 0.0
        for p, c, f in itertools.product(range(n), range(n), range(6)):
            if masked[p, c, f] > best_val:
                best, best_val = (p, c, f), masked[p, c, f]
        if best is None:
            break
        p, c, f = best
        edges.append((p, c, ModuleFaces(f).name))
        instantiated.add(c)
        conn_p[p, :, f] = 0.0
        conn_p[:, c, :] = 0.0
        available[c] = 1.0
    nodes = {i: (types[i].name, rots[i].name) for i in sorted(instantiated)}
    return nodes, edges


# --- hand-made cases -------------------------------------------------------------------


def test_core_only_when_all_connections_are_zero() -> None:
    graph, dec = _decode(_types(BRICK, BRICK, HINGE), np.zeros((3, 3, 6)))
    assert list(graph.nodes(data=True)) == [(0, {"type": "CORE", "rotation": "DEG_0"})]
    assert graph.number_of_edges() == 0
    assert dec.nodes == {0}
    assert dec.edges == []


def test_occupied_face_moves_second_child_to_next_best_face() -> None:
    conn = np.zeros((3, 3, 6))
    conn[0, 1, FRONT] = 0.9
    conn[0, 2, FRONT] = 0.8  # FRONT is taken by module 1 first
    conn[0, 2, BACK] = 0.5
    graph, _ = _decode(_types(CORE, BRICK, BRICK), conn)
    assert _edges(graph) == [(0, 1, "FRONT"), (0, 2, "BACK")]


def test_single_parent_and_disallowed_faces() -> None:
    conn = np.zeros((3, 3, 6))
    conn[0, 1, LEFT] = 0.9
    conn[1, 2, TOP] = 0.95  # a hinge may only be a parent through FRONT: dropped
    conn[1, 2, FRONT] = 0.8
    conn[0, 2, RIGHT] = 0.7  # loses to 0.8; module 2 gets exactly one parent
    conn[0, 2, TOP] = 0.99  # the core never uses TOP/BOTTOM
    conn[0, 2, BOTTOM] = 0.99
    graph, dec = _decode(_types(CORE, HINGE, BRICK), conn)
    assert _edges(graph) == [(0, 1, "LEFT"), (1, 2, "FRONT")]
    assert dec.type_dict == {0: ModuleType.CORE, 1: ModuleType.HINGE, 2: ModuleType.BRICK}
    assert graph.nodes[1]["type"] == "HINGE"
    assert graph.nodes[2]["type"] == "BRICK"


def test_none_modules_and_unreachable_modules_are_dropped() -> None:
    conn = np.zeros((4, 4, 6))
    conn[0, 1, FRONT] = 0.99  # module 1 is NONE: never instantiated
    conn[1, 3, FRONT] = 0.9  # only reachable through the NONE module
    conn[0, 2, LEFT] = 0.5
    graph, dec = _decode(_types(CORE, NONE, BRICK, HINGE), conn)
    assert sorted(graph.nodes) == [0, 2]
    assert _edges(graph) == [(0, 2, "LEFT")]
    assert dec.type_dict[1] is ModuleType.NONE
    assert dec.nodes == {0, 2}


def test_child_waits_for_its_parent_to_be_instantiated() -> None:
    conn = np.zeros((3, 3, 6))
    conn[1, 2, FRONT] = 0.99  # best overall, but module 1 is not placed yet
    conn[0, 1, BACK] = 0.1
    conn[0, 2, RIGHT] = 0.05
    graph, dec = _decode(_types(CORE, BRICK, BRICK), conn)
    assert _edges(graph) == [(0, 1, "BACK"), (1, 2, "FRONT")]
    assert _decoding_order(dec) == [(0, 1, "BACK"), (1, 2, "FRONT")]


def test_ties_go_to_lowest_index_in_c_order() -> None:
    # Equal connection scores everywhere: (parent, child, face) picked in C order.
    conn = np.full((3, 3, 6), 0.5)
    types = np.array([[0.0, 0.5, 0.5, 0.5]] * 3)  # BRICK/HINGE/NONE tie -> BRICK
    rots = np.array([[0.3, 0.9, 0.9]] * 3)  # DEG_45/DEG_90 tie -> DEG_45; core forced DEG_0
    graph, dec = _decode(types, conn, rots)
    assert _edges(graph) == [(0, 1, "FRONT"), (0, 2, "BACK")]
    assert dict(graph.nodes(data="type")) == {0: "CORE", 1: "BRICK", 2: "BRICK"}
    assert dict(graph.nodes(data="rotation")) == {0: "DEG_0", 1: "DEG_45", 2: "DEG_45"}
    assert dec.rot_dict[0] is ModuleRotationsIdx.DEG_0


def test_core_is_only_module_zero() -> None:
    types = np.array([[0.1, 0.9, 0.0, 0.0], [0.99, 0.2, 0.1, 0.0], [0.99, 0.1, 0.3, 0.0]])
    conn = np.zeros((3, 3, 6))
    conn[0, 1, FRONT] = 0.6
    conn[1, 0, FRONT] = 0.9  # the core is never a child
    conn[0, 2, BACK] = 0.4
    graph, _ = _decode(types, conn)
    assert dict(graph.nodes(data="type")) == {0: "CORE", 1: "BRICK", 2: "HINGE"}
    assert _edges(graph) == [(0, 1, "FRONT"), (0, 2, "BACK")]


def test_disallowed_rotations_are_masked() -> None:
    rots = np.array([[0.1, 0.8, 0.9], [0.2, 0.3, 0.1], [0.1, 0.2, 0.7]])
    conn = np.zeros((3, 3, 6))
    conn[0, 1, FRONT] = 0.5
    conn[0, 2, LEFT] = 0.5
    graph, _ = _decode(_types(CORE, HINGE, BRICK), conn, rots)
    assert dict(graph.nodes(data="rotation")) == {0: "DEG_0", 1: "DEG_45", 2: "DEG_90"}


def test_single_module_body() -> None:
    graph, _ = _decode(np.array([[0.5, 0.5, 0.5, 0.5]]), np.ones((1, 1, 6)))
    assert list(graph.nodes(data="type")) == [(0, "CORE")]


def test_nodes_ascending_and_edges_in_decoding_order() -> None:
    conn = np.zeros((4, 4, 6))
    conn[0, 3, FRONT] = 0.9
    conn[3, 1, FRONT] = 0.8
    conn[0, 2, LEFT] = 0.7
    graph, dec = _decode(_types(CORE, BRICK, BRICK, BRICK), conn)
    assert list(graph.nodes) == [0, 1, 2, 3]
    assert _decoding_order(dec) == [
        (0, 3, "FRONT"),
        (3, 1, "FRONT"),
        (0, 2, "LEFT"),
    ]


# --- agreement with a literal transcription of upstream -------------------------------


@pytest.mark.parametrize("quantised", [False, True], ids=["continuous", "tie_heavy"])
def test_matches_reference_transcription(quantised: bool) -> None:
    rng = np.random.default_rng(2024 + quantised)
    for trial in range(40):
        n = int(rng.integers(1, 9))
        parts = [rng.random((n, 4)), rng.random((n, n, 6)), rng.random((n, 3))]
        if quantised:  # few distinct values: many ties and exact zeros
            parts = [np.floor(p * 3) / 3 for p in parts]
        graph, dec = _decode(*parts)
        nodes, edges = _reference_decode(*parts)
        got_nodes = {i: (d["type"], d["rotation"]) for i, d in graph.nodes(data=True)}
        assert got_nodes == nodes, trial
        assert list(graph.nodes) == sorted(nodes), trial
        assert _decoding_order(dec) == edges, trial
        assert _edges(graph) == sorted(edges), trial


# --- inputs and validation ---------------------------------------------------------------


def test_inputs_are_never_mutated() -> None:
    rng = np.random.default_rng(0)
    for dtype in (np.float32, np.float64):
        parts = [rng.random((6, 4)), rng.random((6, 6, 6)), rng.random((6, 3))]
        parts = [p.astype(dtype) for p in parts]
        copies = [p.copy() for p in parts]
        HighProbabilityDecoder(6).probability_matrices_to_graph(*parts)
        for p, c in zip(parts, copies, strict=True):
            assert p.dtype == dtype
            assert np.array_equal(p, c)


def test_accepts_nested_lists() -> None:
    rng = np.random.default_rng(1)
    parts = [rng.random((4, 4)), rng.random((4, 4, 6)), rng.random((4, 3))]
    g1, _ = _decode(*parts)
    g2, _ = _decode(*[p.tolist() for p in parts])
    assert list(g1.nodes(data=True)) == list(g2.nodes(data=True))
    assert _edges(g1) == _edges(g2)


def test_decoder_reuse_returns_fresh_graphs() -> None:
    rng = np.random.default_rng(2)
    dec = HighProbabilityDecoder(5)
    a = [rng.random((5, 4)), rng.random((5, 5, 6)), rng.random((5, 3))]
    g1 = dec.probability_matrices_to_graph(*a)
    snapshot = (list(g1.nodes(data=True)), _edges(g1))
    g2 = dec.probability_matrices_to_graph(np.zeros((5, 4)), np.zeros((5, 5, 6)), np.zeros((5, 3)))
    assert g2 is not g1
    assert (list(g1.nodes(data=True)), _edges(g1)) == snapshot
    assert list(g2.nodes) == [0]


@pytest.mark.parametrize(
    ("which", "shape"),
    [(0, (5, 3)), (0, (4, 4)), (1, (5, 5, 5)), (1, (5, 30)), (2, (5, 4)), (2, (15,))],
)
def test_wrong_shapes_raise(which: int, shape: tuple[int, ...]) -> None:
    parts = [np.zeros((5, 4)), np.zeros((5, 5, 6)), np.zeros((5, 3))]
    parts[which] = np.zeros(shape)
    names = ["type_probability_space", "connection_probability_space", "rotation_probability_space"]
    expected = [(5, 4), (5, 5, 6), (5, 3)][which]
    with pytest.raises(ValueError) as info:
        HighProbabilityDecoder(5).probability_matrices_to_graph(*parts)
    message = str(info.value)
    assert names[which] in message
    assert str(expected) in message
    assert str(shape) in message
    assert "\n" not in message


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("which", [0, 1, 2])
def test_non_finite_values_raise(which: int, bad: float) -> None:
    parts = [np.zeros((3, 4)), np.zeros((3, 3, 6)), np.zeros((3, 3))]
    parts[which].flat[1] = bad
    with pytest.raises(ValueError, match="NaN or inf"):
        HighProbabilityDecoder(3).probability_matrices_to_graph(*parts)


@pytest.mark.parametrize("bad", [-0.1, 1.5])
def test_values_outside_unit_interval_raise(bad: float) -> None:
    parts = [np.zeros((3, 4)), np.zeros((3, 3, 6)), np.zeros((3, 3))]
    parts[0][0, 1] = bad
    with pytest.raises(ValueError, match=r"must lie in \[0, 1\]"):
        HighProbabilityDecoder(3).probability_matrices_to_graph(*parts)


def test_non_numeric_input_raises() -> None:
    with pytest.raises(ValueError, match="numeric array"):
        HighProbabilityDecoder(1).probability_matrices_to_graph(
            [["a", "b", "c", "d"]], np.zeros((1, 1, 6)), np.zeros((1, 3))
        )


@pytest.mark.parametrize(("value", "exc"), [(0, ValueError), (-2, ValueError), (2.0, TypeError)])
def test_bad_num_modules(value, exc: type) -> None:
    with pytest.raises(exc, match="num_modules"):
        HighProbabilityDecoder(value)


def test_decoder_module_does_not_import_torch() -> None:
    assert "torch" not in hpd_module.__dict__
    code = (
        "import sys; import ariel.body_phenotypes.robogen_lite.decoders; "
        "assert 'torch' not in sys.modules, 'torch was imported'"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


# --- NDE -> decoder -> constructor, over many random genotypes ------------------------

NDE_SEEDS = (0, 1, 2, 3, 4)
NDE_SIZES = (5, 10, 20, 30)
GENOTYPES_PER_NDE = 25  # 5 seeds x 4 sizes x 25 = 500 genotypes


def _check_robot_tree(graph: nx.DiGraph, n: int) -> None:
    assert nx.is_arborescence(graph)
    assert graph.in_degree(0) == 0
    assert graph.number_of_nodes() <= n
    assert all(isinstance(i, int) and 0 <= i < n for i in graph.nodes)
    assert graph.nodes[0]["type"] == "CORE"
    for node, data in graph.nodes(data=True):
        module_type = ModuleType[data["type"]]
        assert module_type is not ModuleType.NONE
        assert (module_type is ModuleType.CORE) == (node == 0)
        assert ModuleRotationsIdx[data["rotation"]] in ALLOWED_ROTATIONS[module_type]
    used: set[tuple[int, str]] = set()
    for parent, _child, face in graph.edges(data="face"):
        parent_type = ModuleType[graph.nodes[parent]["type"]]
        assert ModuleFaces[face] in ALLOWED_FACES[parent_type]
        assert (parent, face) not in used  # no two children on one face
        used.add((parent, face))


@pytest.fixture
def one_torch_thread():
    """Run torch single-threaded, as workers do (DESIGN: limit BLAS/OpenMP threads to 1).

    The NDE's matmuls are tiny; with 2+ OpenMP threads on a busy 2-core machine the spinning
    worker threads slow each forward from ~0.3 ms to ~15 ms.
    """
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.mark.usefixtures("one_torch_thread")
def test_random_genotypes_decode_to_valid_trees_that_compile() -> None:
    sizes_seen = []
    count = 0
    for nde_seed, n in itertools.product(NDE_SEEDS, NDE_SIZES):
        nde = NeuralDevelopmentalEncoding(number_of_modules=n, seed=nde_seed)
        decoder = HighProbabilityDecoder(num_modules=n)
        for k in range(GENOTYPES_PER_NDE):
            rng = np.random.default_rng(10_000 * nde_seed + 100 * n + k)
            genotype = [rng.random(64) for _ in range(3)]
            graph = decoder.probability_matrices_to_graph(*nde.forward(genotype))
            _check_robot_tree(graph, n)
            core = constructor.construct_mjspec_from_graph(graph)
            model = core.spec.compile()
            assert model.nbody >= 2
            # One actuator per hinge.
            hinges = sum(1 for _, t in graph.nodes(data="type") if t == "HINGE")
            assert model.nu == hinges
            sizes_seen.append(graph.number_of_nodes())
            count += 1
    assert count == 500
    # Random genotypes give real bodies, not just cores.
    assert np.mean(sizes_seen) > 2.0
    assert max(sizes_seen) > 5


def test_same_seed_gives_the_same_robot_twice() -> None:
    def build(seed: int):
        nde = NeuralDevelopmentalEncoding(number_of_modules=20, seed=seed)
        rng = np.random.default_rng(42)
        genotype = [rng.random(64).astype(np.float32) for _ in range(3)]
        graph = HighProbabilityDecoder(20).probability_matrices_to_graph(*nde.forward(genotype))
        model = constructor.construct_mjspec_from_graph(graph).spec.compile()
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(model.nu)]
        return model, names, graph

    m1, names1, g1 = build(11)
    m2, names2, g2 = build(11)
    assert m1.nbody == m2.nbody
    assert np.array_equal(m1.body_mass, m2.body_mass)
    assert names1 == names2
    assert _edges(g1) == _edges(g2)
    m3, _, g3 = build(12)
    assert (m3.nbody, _edges(g3)) != (m1.nbody, _edges(g1))


def test_numpy_forward_decodes_to_the_same_graphs() -> None:
    nde = NeuralDevelopmentalEncoding(number_of_modules=20, seed=3)
    weights = nde.to_numpy_weights()
    decoder = HighProbabilityDecoder(20)
    for k in range(30):
        rng = np.random.default_rng(k)
        genotype = [rng.random(64) for _ in range(3)]
        g_torch = decoder.probability_matrices_to_graph(*nde.forward(genotype))
        g_numpy = decoder.probability_matrices_to_graph(*nde_forward_numpy(weights, genotype))
        # Float32 differences of ~1e-7 could in principle flip a near-tie; none here.
        assert list(g_torch.nodes(data=True)) == list(g_numpy.nodes(data=True))
        assert _edges(g_torch) == _edges(g_numpy)


def test_a_graph_asked_for_before_decoding_is_refused_not_empty() -> None:
    """Out of order, generate_networkx_graph gave an empty graph as if it were a body."""
    with pytest.raises(ValueError, match=r"no modules decoded yet.*probability_matrices_to_graph"):
        HighProbabilityDecoder(5).generate_networkx_graph()
