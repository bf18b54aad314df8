"""Decoders from genotype outputs to robot graphs: `HighProbabilityDecoder` (NDE matrices),
`VectorDecoder` (flat vectors), `MorphologyDecoderBestFirst` (CPPN genomes; in
``decoders.cppn_best_first``).

Like upstream, the graph file helpers are re-exported here too (``draw_graph`` imports
matplotlib only when called).
"""

from ariel.body_phenotypes.robogen_lite.decoders._blueprint import (
    Blueprint,
    draw_graph,
    load_graph_from_json,
    save_graph_as_json,
)
from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import HighProbabilityDecoder
from ariel.body_phenotypes.robogen_lite.decoders.vector_decoding import VectorDecoder

__all__ = [
    "Blueprint",
    "HighProbabilityDecoder",
    "VectorDecoder",
    "draw_graph",
    "load_graph_from_json",
    "save_graph_as_json",
]
