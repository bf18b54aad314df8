"""Random search over bodies (``body.optimizer = "random"``): the baseline.

Every generation is brand-new random genotypes from the encoder's own sampler
(``random_genotype``), the one generation 0 of every optimizer draws from: ``body.population``
in generation 0, ``body.offspring`` in each later one. Nothing is bred, so no body has
parents (and ``brain.inherit`` has nothing to inherit): each body learns its brain with CMA-ES
from scratch. The best ``body.population`` bodies seen so far are kept, so the run's best so
far, its population after selection and its report mean what they mean for the GA. With the
same budget it is the "random search over bodies and brains" that an evolutionary method must
beat (Bergstra & Bengio 2012 make the case for random search as the baseline).

Random genotype i of the run (counting every generation's bodies in order) draws from stream
(``body-init``, i), as generation 0 of the GA and MAP-Elites does: generation 0 is the same
bodies under every optimizer (common random numbers across the conditions of a campaign), and
no two generations draw the same genotypes. ``ask`` changes nothing; ``tell`` moves the count
on, so the state is two counters and a resumed run asks what an uninterrupted one would.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, TypedDict

from ariel.evolution._optimizer import Proposal, ranked
from ariel.evolution._seeds import derive_rng
from ariel.evolution._state import Body

if TYPE_CHECKING:
    from ariel.evolution._config import BodyConfig
    from ariel.plugins import BodyEncoder

__all__ = ["RandomSearch", "RandomSearchState"]


class RandomSearchState(TypedDict):
    """Random search's state (`RandomSearch.state`): the generation its next `ask` draws and
    the random genotypes told so far."""

    generation: int
    drawn: int


class RandomSearch:
    """New random genotypes every generation; the best ``body.population`` bodies kept.

    Made by the plugin registry (``body_optimizers.make("random", ...)``) with the keywords
    every body optimizer takes.

    Args:
        encoder: The run's body encoder plugin (its ``random_genotype`` makes the genotypes).
        seed: The run seed; random genotype i draws from ``derive_rng(seed, "body-init", i)``.
        maximise: Whether higher fitness is better.
        settings: The config's ``[body]`` section (a `BodyConfig`): its ``population`` (the
            bodies kept) is used.
        **options: ``body.optimizer_options``; random search takes none.

    Raises:
        TypeError: When any ``options`` are given.
    """

    def __init__(
        self,
        *,
        encoder: BodyEncoder,
        seed: int,
        maximise: bool,
        settings: BodyConfig,
        **options: object,
    ) -> None:
        if options:
            raise TypeError(f"random takes no body.optimizer_options, got {sorted(options)}")
        self.encoder = encoder
        self.seed = seed
        self.maximise = maximise
        self.settings = settings
        self.generation = 0  # the generation the next `ask` draws
        self.drawn = 0  # random genotypes told so far: the next one is number `drawn`
        self._population: list[Body] = []

    @property
    def population(self) -> list[Body]:
        return list(self._population)

    def ask(self, n: int) -> list[Proposal]:
        return [
            Proposal(self.encoder.random_genotype(derive_rng(self.seed, "body-init", i)), [])
            for i in range(self.drawn, self.drawn + n)
        ]

    def tell(self, bodies: Sequence[Body]) -> None:
        pool = self._population + list(bodies)
        self._population = ranked(pool, self.maximise)[: self.settings.population]
        self.drawn += len(bodies)
        self.generation += 1

    def state(self) -> RandomSearchState:
        return {"generation": self.generation, "drawn": self.drawn}

    def restore(self, state: RandomSearchState, population: Sequence[Body]) -> None:
        self.generation = int(state["generation"])
        self.drawn = int(state["drawn"])
        self._population = list(population)
