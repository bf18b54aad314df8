"""A connection gene of a CPPN-NEAT genome."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Connection"]


@dataclass
class Connection:
    """A weighted link ``in_id -> out_id`` of a CPPN-NEAT genome.

    Attributes:
        in_id: Id of the source node.
        out_id: Id of the target node.
        weight: Weight the source's output is multiplied by.
        enabled: Whether the link is expressed (a link split by an add-node mutation is
            disabled, not removed).
        innov_id: Innovation number (the key that lines genes up in crossover).
    """

    in_id: int
    out_id: int
    weight: float
    enabled: bool
    innov_id: int

    def copy(self) -> Connection:
        return Connection(self.in_id, self.out_id, self.weight, self.enabled, self.innov_id)
