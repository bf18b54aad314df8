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
