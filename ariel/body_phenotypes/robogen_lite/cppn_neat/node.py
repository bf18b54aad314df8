"""A node gene of a CPPN-NEAT genome."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Node"]

NODE_TYPES = ("input", "hidden", "output")


@dataclass
class Node:
    """A node gene of a CPPN-NEAT genome.

    Attributes:
        _id: The node id.
        typ: "input", "hidden" or "output".
        activation: Name of the activation function (a key of ``ACTIVATION_FUNCTIONS``);
            None for inputs.
        bias: Bias added to the node's weighted input sum.
    """

    _id: int
    typ: str
    activation: str | None
    bias: float

    def copy(self) -> Node:
        return Node(self._id, self.typ, self.activation, self.bias)
