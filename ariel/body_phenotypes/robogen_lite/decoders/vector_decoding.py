"""`VectorDecoder`: the greedy decoder for flat vectors (upstream's ``vector_decoding``).

Upstream's version stops at a debugging ``exit()``; here the three vectors are the
probability spaces of `HighProbabilityDecoder`, flat or shaped (type ``N*4``, connection
``N*N*6``, rotation ``N*3``), and decode exactly as it does. Upstream's helpers are here under
their names: `assign_symbols_from_range`, and the steps `apply_connection_constraints`,
`set_module_types_and_rotations`, `decode_vector_to_graph` and `generate_networkx_graph`
(the `HighProbabilityDecoder`'s).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, TypeVar

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    NUM_OF_FACES,
    NUM_OF_ROTATIONS,
    NUM_OF_TYPES_OF_MODULES,
)
from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import (
    _as_probability_array,
    _GreedyDecoder,
)

__all__ = ["VectorDecoder"]

T = TypeVar("T")


def _shaped(name: str, vector: Any, shape: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(vector, dtype=np.float64)
    if array.size != int(np.prod(shape)):
        raise ValueError(
            f"{name} has {array.size} values; {int(np.prod(shape))} are needed (shape {shape})"
        )
    return array.reshape(shape)


def _weights(weight: Any, count: int, where: str) -> np.ndarray:
    """``weight`` normalised to sum 1 (one-line errors for a bad length, sign or sum)."""
    try:
        w = np.asarray(weight, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"weight{where} must be numbers: {exc}") from None
    if w.size != count:
        raise ValueError(f"weight{where} has {w.size} values for {count} symbols")
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weight{where} must be finite, non-negative and not all zero")
    return w / w.sum()


class VectorDecoder(_GreedyDecoder):
    """``VectorDecoder(num_modules).vectors_to_graph(type_vector, connection_vector,
    rotation_vector)`` -> robot graph (values in [0, 1], as probabilities)."""

    _ENTRY = "vectors_to_graph"

    def assign_symbols_from_range(
        self,
        vector: Any,
        symbols: Sequence[T] | Sequence[Sequence[T]],
        weight: Sequence[float] | Sequence[Sequence[float]] | None = None,
    ) -> list[T]:
        """Map each value in [0, 1] to a symbol: [0, 1] is cut into one interval per symbol,
        as wide as its weight (equal without ``weight``), and a value takes the symbol of the
        interval it falls in (a value on a border takes the lower one; 0 the first, 1 the last).

        ``symbols`` is one list for every value, or one list per value (a list of lists,
        tuples or arrays; ``weight`` is then one list per value too).
        """
        values = np.asarray(vector, dtype=np.float64)
        if values.ndim > 1:
            raise ValueError(f"vector must be one-dimensional; got shape {values.shape}")
        values = values.ravel()
        if not np.all((values >= 0.0) & (values <= 1.0)):  # NaN fails too
            raise ValueError("all values in the vector must lie in [0, 1]")
        if len(symbols) == 0:
            raise ValueError("symbols must not be empty")
        per_element = isinstance(symbols[0], (list, tuple, np.ndarray))
        if per_element and len(symbols) != values.size:
            raise ValueError(
                f"symbols has {len(symbols)} lists for {values.size} values; give one per value"
            )
        result: list[T] = []
        for i, value in enumerate(values.tolist()):
            current: Sequence[T] = symbols[i] if per_element else symbols  # type: ignore[assignment]
            count = len(current)
            if count == 0:
                raise ValueError(f"symbols[{i}] is empty" if per_element else "symbols is empty")
            if weight is None:
                w = np.full(count, 1.0 / count)
            else:
                w = _weights(
                    weight[i] if per_element else weight, count, f"[{i}]" if per_element else ""
                )
            index = int(np.searchsorted(np.cumsum(w), value, side="left"))
            result.append(current[min(index, count - 1)])
        return result

    def vectors_to_graph(
        self, type_vector: Any, connection_vector: Any, rotation_vector: Any
    ) -> nx.DiGraph:
        """Decode the three vectors (flat or shaped) to a robot tree, as the
        `HighProbabilityDecoder` decodes the same numbers as matrices."""
        n = self.num_modules
        self.type_vector = _shaped("type_vector", type_vector, (n, NUM_OF_TYPES_OF_MODULES))
        self.connection_vector = _shaped(
            "connection_vector", connection_vector, (n, n, NUM_OF_FACES)
        )
        self.rotation_vector = _shaped("rotation_vector", rotation_vector, (n, NUM_OF_ROTATIONS))
        self._set_spaces(
            _as_probability_array("type_vector", self.type_vector, self.type_vector.shape),
            _as_probability_array(
                "connection_vector", self.connection_vector, self.connection_vector.shape
            ),
            _as_probability_array(
                "rotation_vector", self.rotation_vector, self.rotation_vector.shape
            ),
        )
        self.apply_connection_constraints()
        self.set_module_types_and_rotations()
        self.decode_vector_to_graph()
        self.generate_networkx_graph()
        return self.graph

    def decode_vector_to_graph(self) -> None:
        """Grow the tree over ``conn_p_space`` (after the two constraint steps): fills
        ``nodes`` and ``edges``."""
        self._grow()
