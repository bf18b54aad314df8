"""Neural Developmental Encoding (NDE) genotypes.

`NeuralDevelopmentalEncoding` (torch) is loaded lazily on first access, so importing
`ariel.ec.genotypes.nde.numpy_forward` (numpy only) never pulls in torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ariel.ec.genotypes.nde.nde import NeuralDevelopmentalEncoding

__all__ = ["NeuralDevelopmentalEncoding"]


def __getattr__(name: str) -> Any:
    if name == "NeuralDevelopmentalEncoding":
        # lazy: the NDE is a torch module (heavy optional library); see the module docstring
        from ariel.ec.genotypes.nde.nde import NeuralDevelopmentalEncoding

        return NeuralDevelopmentalEncoding
    msg = f"module {__name__!r} has no attribute {name!r}"
    raise AttributeError(msg)


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
