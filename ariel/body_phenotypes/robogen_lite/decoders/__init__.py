"""Decoders from genotype outputs (probability matrices) to robot graphs.

Like upstream, the graph JSON helpers are re-exported here too.
"""

from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import HighProbabilityDecoder
from ariel.body_phenotypes.robogen_lite.graph_io import load_graph_from_json, save_graph_as_json

__all__ = ["HighProbabilityDecoder", "load_graph_from_json", "save_graph_as_json"]
