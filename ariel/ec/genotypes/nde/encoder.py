"""The ``nde`` body encoder: three float chromosomes -> NDE -> greedy decoder -> robot graph.

Its variation operators (Gaussian mutation, uniform crossover) live here, with the encoding
they vary. Registered as ``"nde"`` in ``ariel._builtin_names``. Imports numpy and
networkx only; torch is needed once per process, to initialise the NDE's weights.
"""

from __future__ import annotations

import functools
from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.decoders import HighProbabilityDecoder
from ariel.ec.genotypes.nde.numpy_forward import nde_forward_numpy
from ariel.utils import whole_numbers
from ariel.utils.interrupts import signals_deferred

__all__ = ["NDEEncoder"]

#: Chromosomes of an NDE genotype (module types, connections, rotations).
NUM_CHROMOSOMES = 3
#: The most modules a body may have: the NDE's connection layer has 128 x N x N x 6 weights
#: (1,200 modules took 9 GB before a run could say anything; 200 take about 120 MB).
MAX_MODULES = 200
#: The most genes a chromosome may have (the NDE's first layer has 64 weights a gene).
MAX_GENES = 4096


@functools.lru_cache(maxsize=8)
def _nde_weights(number_of_modules: int, genotype_size: int, nde_seed: int) -> dict:
    """NDE weights as numpy arrays, made once per process (torch only for the initialisation)."""
    # A stop signal during torch's C++ initialisation would abort the process: hold it back.
    with signals_deferred():
        import torch  # lazy: heavy optional library (see the module docstring)

        # lazy: the NDE is a torch module (heavy optional library)
        from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a second spinning OpenMP thread slows everything else down
    try:
        nde = NeuralDevelopmentalEncoding(number_of_modules, genotype_size, seed=nde_seed)
        return nde.to_numpy_weights()
    finally:
        torch.set_num_threads(threads)


class NDEEncoder:
    """Three float chromosomes -> NDE (fixed weights from ``nde_seed``) -> greedy decoder -> graph.

    Genes start uniform in [0, 1) as in the tutorials.

    Args:
        number_of_modules: the most modules a decoded body can have (2 to `MAX_MODULES`).
        genotype_size: genes per chromosome (1 to `MAX_GENES`); a genotype has shape
            ``(3, genotype_size)``.
        nde_seed: seeds the NDE's weights, which stay fixed for a whole run; only the genotype
            evolves.
        mutation_std: standard deviation of the Gaussian noise `mutate` adds.
        mutation_rate: the chance, in [0, 1], that `mutate` perturbs each gene (1.0: all of
            them; the expected fraction perturbed).

    Raises:
        TypeError: ``number_of_modules``, ``genotype_size`` or ``nde_seed`` is not an int
            (a float or a string is never truncated).
        ValueError: ``number_of_modules`` outside 2 to `MAX_MODULES`, ``genotype_size``
            outside 1 to `MAX_GENES`, or ``mutation_rate`` outside [0, 1].
    """

    name = "nde"
    evolvable = True

    def __init__(
        self,
        *,
        number_of_modules: int = 20,
        genotype_size: int = 64,
        nde_seed: int = 0,
        mutation_std: float = 0.1,
        mutation_rate: float = 1.0,
    ) -> None:
        whole_numbers(
            number_of_modules=number_of_modules, genotype_size=genotype_size, nde_seed=nde_seed
        )
        if not 2 <= int(number_of_modules) <= MAX_MODULES:
            raise ValueError(
                f"number_of_modules must be 2 to {MAX_MODULES}, not {number_of_modules!r} (the "
                f"NDE's weights grow with its square: {MAX_MODULES} take about 120 MB)"
            )
        if not 1 <= int(genotype_size) <= MAX_GENES:
            raise ValueError(f"genotype_size must be 1 to {MAX_GENES}, not {genotype_size!r}")
        if not 0.0 <= float(mutation_rate) <= 1.0:
            raise ValueError(f"mutation_rate must be in [0, 1], not {mutation_rate!r}")
        self.number_of_modules = int(number_of_modules)
        self.genotype_size = int(genotype_size)
        self.nde_seed = int(nde_seed)
        self.mutation_std = float(mutation_std)
        self.mutation_rate = float(mutation_rate)

    @property
    def genotype_shape(self) -> tuple[int, int]:
        """The shape of a genotype: checked when a fixed genotype is loaded (``body.genotype``)."""
        return (NUM_CHROMOSOMES, self.genotype_size)

    def _genes(self, genotype: Any) -> np.ndarray:
        """A float32 copy shaped ``(3, genotype_size)`` (never a view: inputs stay unchanged)."""
        genes = np.array(genotype, dtype=np.float32)
        if genes.size != NUM_CHROMOSOMES * self.genotype_size:
            raise ValueError(
                f"an 'nde' genotype has {NUM_CHROMOSOMES} chromosomes of {self.genotype_size} "
                f"genes; got shape {genes.shape}"
            )
        return genes.reshape(NUM_CHROMOSOMES, self.genotype_size)

    def random_genotype(self, rng: np.random.Generator) -> np.ndarray:
        return rng.random((NUM_CHROMOSOMES, self.genotype_size)).astype(np.float32)

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> np.ndarray:
        """Gaussian noise (``mutation_std``) on a ``mutation_rate`` fraction of the genes."""
        std = float(options.get("mutation_std", self.mutation_std))
        rate = float(options.get("mutation_rate", self.mutation_rate))
        genes = self._genes(genotype)
        noise = rng.normal(0.0, std, genes.shape)
        mask = rng.random(genes.shape) < rate
        return (genes + (noise * mask)).astype(np.float32)

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> np.ndarray:
        """Uniform crossover, chromosome-aligned gene by gene."""
        ga, gb = self._genes(a), self._genes(b)
        return np.where(rng.random(ga.shape) < 0.5, ga, gb)

    def decode(self, genotype: Any) -> nx.DiGraph:
        weights = _nde_weights(self.number_of_modules, self.genotype_size, self.nde_seed)
        matrices = nde_forward_numpy(weights, genotype)
        return HighProbabilityDecoder(self.number_of_modules).probability_matrices_to_graph(
            *matrices
        )
