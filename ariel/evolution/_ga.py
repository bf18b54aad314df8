"""The genetic algorithm over bodies (``body.optimizer = "ga"``, the default).

Generation 0 is ``body.population`` random genotypes. Every later generation breeds
``body.offspring`` children: tournament selection (``body.tournament`` bodies drawn without
replacement, the best wins), crossover with probability ``body.crossover_rate`` (a second
tournament for the other parent), then mutation, all by the encoder's own operators. Survivors:
``plus`` keeps the best ``body.population`` of parents and children (mu + lambda),
``generational`` the best of the children only (mu, lambda). Eiben & Smith, *Introduction to
Evolutionary Computing* (2015), ch. 5.

Child j of generation g draws from its own stream (``variation``, g, j), random genotype i
from (``body-init``, i): no draw depends on another, so results never depend on the order in
which work is done.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Protocol, TypedDict

import numpy as np

from ariel.evolution._optimizer import Proposal, ranked
from ariel.evolution._seeds import derive_rng
from ariel.evolution._state import Body

if TYPE_CHECKING:
    from ariel.evolution._config import BodyConfig
    from ariel.plugins import BodyEncoder

__all__ = [
    "GAState",
    "GeneticAlgorithm",
    "TournamentBreeder",
    "breed",
    "random_proposals",
    "tournament_children",
]


class GAState(TypedDict):
    """The GA's state (`GeneticAlgorithm.state`): the generation its next `ask` breeds."""

    generation: int


class TournamentBreeder(Protocol):
    """What `tournament_children` reads of a population optimizer (the GA, novelty search)."""

    @property
    def _population(self) -> list[Body]: ...
    @property
    def encoder(self) -> BodyEncoder: ...
    @property
    def seed(self) -> int: ...
    @property
    def generation(self) -> int: ...
    @property
    def settings(self) -> BodyConfig: ...
    def tournament(self, rng: np.random.Generator) -> Body: ...


def random_proposals(encoder: BodyEncoder, seed: int, n: int) -> list[Proposal]:
    """``n`` random genotypes, genotype i from its own stream."""
    return [
        Proposal(encoder.random_genotype(derive_rng(seed, "body-init", i)), []) for i in range(n)
    ]


def breed(
    encoder: BodyEncoder,
    rng: np.random.Generator,
    pick: Callable[[np.random.Generator], Body],
    crossover_rate: float,
    can_cross: bool,
) -> Proposal:
    """One child: ``pick(rng)`` a parent, perhaps a second one and crossover, then mutation."""
    first = pick(rng)
    if can_cross and rng.random() < crossover_rate:
        second = pick(rng)
        genotype = encoder.crossover(first.genotype, second.genotype, rng)
        parents = [first.body_id, second.body_id]
    else:
        genotype, parents = first.genotype, [first.body_id]
    return Proposal(encoder.mutate(genotype, rng), parents)


def tournament_children(optimizer: TournamentBreeder, n: int) -> list[Proposal]:
    """``ask(n)`` of a population optimizer (the GA, novelty search): ``n`` random genotypes
    before its first population, else ``n`` children, child j from its own stream
    (``variation``, generation, j), parents drawn by ``optimizer.tournament``."""
    if not optimizer._population:
        return random_proposals(optimizer.encoder, optimizer.seed, n)
    return [
        breed(
            optimizer.encoder,
            derive_rng(optimizer.seed, "variation", optimizer.generation, j),
            optimizer.tournament,
            optimizer.settings.crossover_rate,
            len(optimizer._population) > 1,
        )
        for j in range(n)
    ]


class GeneticAlgorithm:
    """Tournament selection, crossover, mutation and mu+lambda (or generational) survival.

    Made by the plugin registry (``body_optimizers.make("ga", ...)``) with the keywords every
    body optimizer takes.

    Args:
        encoder: The run's body encoder plugin (its ``random_genotype``, ``crossover`` and
            ``mutate`` make the genotypes).
        seed: The run seed; every draw derives from it (`derive_rng`).
        maximise: Whether higher fitness is better.
        settings: The config's ``[body]`` section (a `BodyConfig`): its ``population``,
            ``tournament``, ``crossover_rate`` and ``survivors`` are used.
        **options: ``body.optimizer_options``; the GA takes none.

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
            raise TypeError(f"the ga takes no body.optimizer_options, got {sorted(options)}")
        self.encoder = encoder
        self.seed = seed
        self.maximise = maximise
        self.settings = settings
        self.generation = 0  # the generation the next `ask` breeds
        self._population: list[Body] = []

    @property
    def population(self) -> list[Body]:
        return list(self._population)

    def tournament(self, rng: np.random.Generator) -> Body:
        population = self._population
        size = min(self.settings.tournament, len(population))
        picks = rng.choice(len(population), size=size, replace=False)
        return ranked([population[i] for i in sorted(picks)], self.maximise)[0]

    def ask(self, n: int) -> list[Proposal]:
        return tournament_children(self, n)

    def tell(self, bodies: Sequence[Body]) -> None:
        children = list(bodies)
        if not self._population:
            survivors = children
        else:
            generational = self.settings.survivors == "generational"
            pool = children if generational else self._population + children
            survivors = ranked(pool, self.maximise)[: self.settings.population]
        self._population = survivors
        self.generation += 1

    def state(self) -> GAState:
        return {"generation": self.generation}

    def restore(self, state: GAState, population: Sequence[Body]) -> None:
        self.generation = int(state["generation"])
        self._population = list(population)
