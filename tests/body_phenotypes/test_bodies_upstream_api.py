"""Upstream body API gaps: graph files, VectorDecoder, ModuleInstance, keyword aliases."""

from __future__ import annotations

import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.config import (
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.decoders import _blueprint, hi_prob_decoding
from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import HighProbabilityDecoder
from ariel.body_phenotypes.robogen_lite.decoders.vector_decoding import VectorDecoder
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule
from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS


@pytest.mark.parametrize("module", [_blueprint, hi_prob_decoding])
def test_graph_json_round_trip_from_both_homes(module, tmp_path: Path) -> None:
    graph = PREBUILT_GRAPHS["gecko"]()
    module.save_graph_as_json(graph, tmp_path / "g.json")
    back = module.load_graph_from_json(tmp_path / "g.json")
    assert isinstance(back, nx.DiGraph) and not back.is_multigraph()
    assert sorted(back.nodes(data=True)) == sorted(
        (n, {k: getattr(v, "name", v) for k, v in a.items()}) for n, a in graph.nodes(data=True)
    )
    assert {(u, v): a["face"] for u, v, a in back.edges(data=True)} == {
        (u, v): getattr(a["face"], "name", a["face"]) for u, v, a in graph.edges(data=True)
    }
    assert module.save_graph_as_json(graph, None) is None  # upstream: no file, no error


def test_draw_graph_saves_a_png(tmp_path: Path) -> None:
    target = tmp_path / "gecko.png"
    hi_prob_decoding.draw_graph(PREBUILT_GRAPHS["gecko"](), "gecko", target, dpi=50)
    assert target.stat().st_size > 1000
    assert "matplotlib" in sys.modules


def test_vector_decoder_equals_the_high_probability_decoder() -> None:
    rng = np.random.default_rng(0)
    n = 8
    t, c, r = rng.random((n, 4)), rng.random((n, n, 6)), rng.random((n, 3))
    expected = HighProbabilityDecoder(n).probability_matrices_to_graph(t, c, r)
    graph = VectorDecoder(n).vectors_to_graph(t.ravel(), c.ravel(), r.ravel())
    assert nx.utils.graphs_equal(graph, expected)
    with pytest.raises(ValueError, match="type_vector has 3 values"):
        VectorDecoder(n).vectors_to_graph(np.ones(3), c, r)


def test_module_instance_is_a_pydantic_model() -> None:
    from ariel.body_phenotypes.robogen_lite.config import ModuleInstance

    module = ModuleInstance(
        type=ModuleType.HINGE, rotation=ModuleRotationsIdx.DEG_90, links={ModuleFaces.FRONT: 2}
    )
    assert module.type is ModuleType.HINGE and module.links == {ModuleFaces.FRONT: 2}
    assert ModuleInstance.model_validate(module.model_dump()) == module
    with pytest.raises(ValueError):
        ModuleInstance(type="not a type", rotation=0, links={})


def test_rotate_accepts_upstreams_angle_keyword() -> None:
    hinge = HingeModule(1)
    hinge.rotate(angle=45)
    assert hinge.rotation == 45.0
    hinge.rotate(degrees=90)
    assert hinge.rotation == 90.0
    CoreModule(0).rotate(angle=0)
    with pytest.raises(TypeError, match="alias 'angle'"):
        hinge.rotate(degrees=1, angle=2)


# --- upstream's decoder steps and helpers, by upstream's names ------------------------------


def _spaces(n: int = 6, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.random((n, 4)), rng.random((n, n, 6)) ** 3, rng.random((n, 3))


@pytest.mark.parametrize(
    ("cls", "decode"),
    [
        (HighProbabilityDecoder, "decode_probability_to_graph"),
        (VectorDecoder, "decode_vector_to_graph"),
    ],
)
def test_decoder_steps_one_by_one_equal_the_whole_decode(cls, decode: str) -> None:
    t, c, r = _spaces()
    expected = HighProbabilityDecoder(6).probability_matrices_to_graph(t, c, r)
    decoder = cls(6)
    decoder.type_p_space, decoder.conn_p_space, decoder.rot_p_space = t.copy(), c.copy(), r.copy()
    decoder.apply_connection_constraints()
    diagonal = decoder.conn_p_space[np.arange(6), np.arange(6)]
    assert not diagonal.any() and not decoder.conn_p_space[:, 0].any()
    assert decoder.type_p_space[0, ModuleType.CORE.value] == 1.0
    assert not decoder.type_p_space[1:, ModuleType.CORE.value].any()
    decoder.set_module_types_and_rotations()
    assert decoder.type_dict[0] is ModuleType.CORE and len(decoder.rot_dict) == 6
    assert all(isinstance(v, ModuleRotationsIdx) for v in decoder.rot_dict.values())
    getattr(decoder, decode)()
    assert 0 in decoder.nodes and isinstance(decoder.edges, list)
    decoder.generate_networkx_graph()
    assert nx.utils.graphs_equal(decoder.graph, expected)
    assert list(decoder.graph.nodes(data=True)) == list(expected.nodes(data=True))


def test_decoder_steps_refuse_missing_state_in_one_line() -> None:
    decoder = HighProbabilityDecoder(4)
    with pytest.raises(ValueError, match="conn_p_space is not set") as info:
        decoder.apply_connection_constraints()
    assert "\n" not in str(info.value)
    decoder.conn_p_space = np.ones((4, 4, 6))
    with pytest.raises(ValueError, match="type_dict is not set"):
        decoder.decode_probability_to_graph()
    decoder.type_p_space = np.ones((3, 4))
    with pytest.raises(ValueError, match=r"type_p_space must have shape \(4, 4\)"):
        decoder.apply_connection_constraints()
    # Skipping the constraints lets the core be picked as a child: refused, not decoded.
    decoder = HighProbabilityDecoder(3)
    decoder.type_p_space, decoder.rot_p_space = np.ones((3, 4)), np.ones((3, 3))
    decoder.conn_p_space = np.ones((3, 3, 6))
    decoder.set_module_types_and_rotations()
    with pytest.raises(ValueError, match="call apply_connection_constraints"):
        decoder.decode_probability_to_graph()


def test_assign_symbols_from_range() -> None:
    assign = VectorDecoder(2).assign_symbols_from_range
    # Equal intervals; a value on a border takes the lower symbol; 0 the first, 1 the last.
    assert assign([0.0, 1 / 3, 0.34, 0.7, 1.0], ["a", "b", "c"]) == ["a", "a", "b", "c", "c"]
    assert assign(np.array([0.24, 0.26]), ["a", "b"], weight=[1, 3]) == ["a", "b"]
    assert assign([0.2, 0.8], [[1, 2], ("x", "y", "z")]) == [1, "z"]
    assert assign([0.5], [[1, 2]], weight=[[3, 1]]) == [1]
    assert assign([0.3, 0.7], "XYZ") == assign([0.3, 0.7], "XYZ", weight=[1.0, 1.0, 1.0])
    for bad in ([1.5], [-0.1], [np.nan]):
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            assign(bad, ["a", "b"])
    with pytest.raises(ValueError, match="one per value"):
        assign([0.1, 0.2], [["a"]])
    with pytest.raises(ValueError, match="weight has 1 values for 2 symbols"):
        assign([0.1], ["a", "b"], weight=[1.0])
    with pytest.raises(ValueError, match="not all zero"):
        assign([0.1], ["a", "b"], weight=[0.0, 0.0])
