"""`VectorDecoder`: the greedy decoder for flat vectors (upstream's ``vector_decoding``).

Upstream's version stops at a debugging ``exit()``; here the three vectors are the
probability spaces of `HighProbabilityDecoder`, flat or shaped (type ``N*4``, connection
``N*N*6``, rotation ``N*3``), and decode exactly as it does.
"""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    NUM_OF_FACES,
    NUM_OF_ROTATIONS,
    NUM_OF_TYPES_OF_MODULES,
)
from ariel.body_phenotypes.robogen_lite.decoders._blueprint import Blueprint
from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import HighProbabilityDecoder

__all__ = ["VectorDecoder"]


def _shaped(name: str, vector: Any, shape: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(vector, dtype=np.float64)
    if array.size != int(np.prod(shape)):
        raise ValueError(
            f"{name} has {array.size} values; {int(np.prod(shape))} are needed (shape {shape})"
        )
    return array.reshape(shape)


class VectorDecoder(Blueprint):
    """``VectorDecoder(num_modules).vectors_to_graph(type_vector, connection_vector,
    rotation_vector)`` -> robot graph (values in [0, 1], as probabilities)."""

    def vectors_to_graph(
        self, type_vector: Any, connection_vector: Any, rotation_vector: Any
    ) -> nx.DiGraph:
        n = self.num_modules
        self.type_vector = _shaped("type_vector", type_vector, (n, NUM_OF_TYPES_OF_MODULES))
        self.connection_vector = _shaped(
            "connection_vector", connection_vector, (n, n, NUM_OF_FACES)
        )
        self.rotation_vector = _shaped("rotation_vector", rotation_vector, (n, NUM_OF_ROTATIONS))
        decoder = HighProbabilityDecoder(n)
        self.graph = decoder.probability_matrices_to_graph(
            self.type_vector, self.connection_vector, self.rotation_vector
        )
        self.type_dict, self.rot_dict = decoder.type_dict, decoder.rot_dict
        self.nodes, self.edges = decoder.nodes, decoder.edges
        return self.graph
