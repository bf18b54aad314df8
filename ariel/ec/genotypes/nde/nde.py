"""Neural Developmental Encoding (NDE): a frozen random network that maps a genotype of three
chromosomes to module-type, connection and rotation probability matrices.

The architecture and attribute names follow upstream ARIEL, so upstream `NDE.pth` state_dicts
load unchanged.
"""

from __future__ import annotations

import math
import numbers
from os import PathLike
from typing import Any, Self

import numpy as np
import torch
from torch import nn

from ariel.body_phenotypes.robogen_lite.config import (
    NUM_OF_FACES,
    NUM_OF_ROTATIONS,
    NUM_OF_TYPES_OF_MODULES,
)
from ariel.ec.genotypes.nde.numpy_forward import validate_genotype

__all__ = ["MAX_GENES", "MAX_MODULES", "NeuralDevelopmentalEncoding"]

#: The most modules an NDE describes: the `nde` body encoder's limit (``encoder.MAX_MODULES``,
#: which imports this module, so the value is repeated here). The connection layer has
#: 128 x N x N x 6 weights: 200 modules take about 120 MB.
MAX_MODULES = 200
#: The most genes a chromosome may have (``encoder.MAX_GENES``; 64 first-layer weights a gene).
MAX_GENES = 4096


def _check_positive_int(name: str, value: Any, limit: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        msg = f"{name} must be an int from 1 to {limit}; got {type(value).__name__} {value!r}"
        raise TypeError(msg)
    if value < 1:
        msg = f"{name} must be >= 1; got {value}"
        raise ValueError(msg)
    if value > limit:
        msg = f"{name} must be <= {limit} (the NDE's weights grow with it); got {value}"
        raise ValueError(msg)
    return int(value)


def _seeded_linear(in_features: int, out_features: int, generator: torch.Generator) -> nn.Linear:
    """An nn.Linear initialised exactly like PyTorch's default, but from `generator`.

    Mirrors `nn.Linear.reset_parameters` call for call, so the result equals what the global
    RNG would give after `torch.manual_seed(seed)`, without touching the global RNG.
    """
    layer = torch.nn.utils.skip_init(nn.Linear, in_features, out_features)
    nn.init.kaiming_uniform_(layer.weight, a=math.sqrt(5), generator=generator)
    bound = 1 / math.sqrt(in_features) if in_features > 0 else 0
    nn.init.uniform_(layer.bias, -bound, bound, generator=generator)
    return layer


class NeuralDevelopmentalEncoding(nn.Module):
    """Frozen MLP: genotype (3 chromosomes of `genotype_size`) -> three probability matrices.

    Each chromosome runs through a shared trunk (fc1..fc4), then through its own head with a
    sigmoid: chromosome 0 -> types (N, 4), 1 -> connections (N, N, 6), 2 -> rotations (N, 3).
    With `seed=None` the weights come from torch's global RNG (so `torch.manual_seed` makes
    them reproducible); with a seed they come from a private generator, bit for bit.

    Args:
        number_of_modules: N, the number of modules the output matrices describe (1 to
            `MAX_MODULES`).
        genotype_size: G, the genes per chromosome (1 to `MAX_GENES`).
        seed: ``None`` (weights from torch's global RNG) or an integer >= 0 (a private
            generator; the global RNG is left untouched).

    Raises:
        TypeError: ``number_of_modules`` or ``genotype_size`` is not an integer.
        ValueError: ``number_of_modules`` or ``genotype_size`` is out of range, or ``seed`` is
            neither ``None`` nor an integer >= 0.
    """

    def __init__(
        self, number_of_modules: int, genotype_size: int = 64, seed: int | None = None
    ) -> None:
        super().__init__()
        n = _check_positive_int("number_of_modules", number_of_modules, MAX_MODULES)
        g = _check_positive_int("genotype_size", genotype_size, MAX_GENES)
        if seed is not None:
            if (
                isinstance(seed, bool)
                or not isinstance(seed, numbers.Integral)
                or not 0 <= seed < 2**64
            ):
                msg = f"seed must be None or an int from 0 to 2**64 - 1; got {seed!r}"
                raise ValueError(msg)
            seed = int(seed)
        self.number_of_modules = n
        self.genotype_size = g
        self.seed = seed

        self.type_p_shape = (n, NUM_OF_TYPES_OF_MODULES)
        self.conn_p_shape = (n, n, NUM_OF_FACES)
        self.rot_p_shape = (n, NUM_OF_ROTATIONS)

        if seed is None:
            make = nn.Linear
        else:
            generator = torch.Generator(device="cpu")
            generator.manual_seed(seed)

            def make(i: int, o: int) -> nn.Linear:
                return _seeded_linear(i, o, generator)

        # Creation order matters: it fixes which random numbers each layer gets.
        self.fc1 = make(g, 64)
        self.fc2 = make(64, 32)
        self.fc3 = make(32, 64)
        self.fc4 = make(64, 128)
        self.type_p_out = make(128, math.prod(self.type_p_shape))
        self.conn_p_out = make(128, math.prod(self.conn_p_shape))
        self.rot_p_out = make(128, math.prod(self.rot_p_shape))

        self.relu = nn.ReLU()
        self.tanh = nn.Tanh()
        self.sigmoid = nn.Sigmoid()

        # Plain lists (not ModuleList) so the state_dict keys stay upstream's.
        self.output_layers = [self.type_p_out, self.conn_p_out, self.rot_p_out]
        self.output_shapes = [self.type_p_shape, self.conn_p_shape, self.rot_p_shape]

        # The NDE is a fixed mapping; only the genotype evolves.
        self.requires_grad_(False)

    def _trunk(self, x: torch.Tensor) -> torch.Tensor:
        x = self.relu(self.fc1(x))
        x = self.tanh(self.fc2(x))
        x = self.relu(self.fc3(x))
        return self.relu(self.fc4(x))

    def forward(self, genotype: Any) -> list[np.ndarray]:
        """Map a genotype (3 chromosomes, or a (3, G) array) to [(N,4), (N,N,6), (N,3)] float32
        arrays with values in (0, 1) (independent sigmoids, not normalised)."""
        x = torch.from_numpy(validate_genotype(genotype, self.genotype_size))
        with torch.no_grad():
            hidden = self._trunk(x)
            return [
                self.sigmoid(layer(hidden[k])).reshape(shape).numpy()
                for k, (layer, shape) in enumerate(
                    zip(self.output_layers, self.output_shapes, strict=True)
                )
            ]

    def to_numpy_weights(self) -> dict[str, np.ndarray]:
        """The weights as float32 numpy arrays (copies), for `nde_forward_numpy`."""
        return {
            name: value.detach().cpu().numpy().astype(np.float32, copy=True)
            for name, value in self.state_dict().items()
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Save the state_dict (same format as upstream's `NDE.pth`)."""
        torch.save(self.state_dict(), path)

    def load(self, path: str | PathLike[str]) -> Self:
        """Load a state_dict saved by `save` (or upstream) into this instance; returns self."""
        state = torch.load(path, map_location="cpu", weights_only=True)
        self.load_state_dict(state)
        self.requires_grad_(False)
        return self

    @classmethod
    def from_file(cls, path: str | PathLike[str]) -> Self:
        """Build an NDE from a saved state_dict, inferring its sizes from the weight shapes."""
        state = torch.load(path, map_location="cpu", weights_only=True)
        try:
            genotype_size = int(state["fc1.weight"].shape[1])
            number_of_modules = int(state["type_p_out.weight"].shape[0]) // (
                NUM_OF_TYPES_OF_MODULES
            )
        except (KeyError, IndexError, TypeError, AttributeError) as exc:
            msg = f"{path} does not hold an NDE state_dict (missing {exc})"
            raise ValueError(msg) from None
        # Constructing with a fixed seed avoids consuming the global RNG; weights are replaced.
        nde = cls(number_of_modules, genotype_size, seed=0)
        nde.load_state_dict(state)
        nde.requires_grad_(False)
        nde.seed = None
        return nde
