"""A node gene of a CPPN-NEAT genome."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Node"]

NODE_TYPES = ("input", "hidden", "output")


@dataclass
class Node:
    """Node ``_id`` of type ``typ`` ("input", "hidden" or "output"), with an activation NAME
    (a key of ``ACTIVATION_FUNCTIONS``; None for inputs) and a bias."""

    _id: int
    typ: str
    activation: str | None
    bias: float

    def copy(self) -> Node:
        return Node(self._id, self.typ, self.activation, self.bias)
