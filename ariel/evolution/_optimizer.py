"""The body optimizer interface: ask for genotypes, tell how the bodies did.

In the shape of pyribs' schedulers and evosax's strategies. The run driver asks for
``body.population`` genotypes in generation 0 and ``body.offspring`` in every later one,
builds a body from each, learns each body's brain (a `BrainOptimizer`, CMA-ES by default:
``brain.optimizer``, ``ariel.evolution._brain``), and tells the optimizer the
bodies (fitness = best brain's fitness, morphology descriptors, status). What the optimizer
keeps (`BodyOptimizer.population`: a GA's survivors, a MAP-Elites archive's elites) is what the
next generation breeds from and what the bodies table marks ``selected``.

An optimizer is made by ``body_optimizers.make(name, encoder=..., seed=..., maximise=...,
settings=..., **options)``: ``encoder`` the run's body encoder, ``seed`` the run seed (every
random draw derives from it), ``maximise`` the fitness direction, ``settings`` the config's
``[body]`` section (population, offspring, tournament, crossover_rate, survivors), and
``options`` the config's ``body.optimizer_options``. Its state is plain data (`state` /
`restore`), stored in the checkpoint; its bodies are stored by the driver.

A quality-diversity optimizer (`ArchiveOptimizer`: ``map_elites``, ``novelty``) also keeps an
archive of elites, which the driver records after every generation: its rows (the ``archive``
table), its description (run.json's ``archive``: a grid's bins or a CVT's centroids, what
readers draw it from), its QD metrics (the progress line) and ``qd_offset``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ariel.evolution._brain import fitness_rank

if TYPE_CHECKING:
    from ariel.evolution._state import Body

__all__ = ["ArchiveOptimizer", "BodyOptimizer", "Proposal", "ranked"]


@dataclass(frozen=True)
class Proposal:
    """A genotype the optimizer asks to evaluate, and the bodies it was made from.

    Attributes:
        genotype: The genotype to build a body from, in the run's body encoder's format.
        parent_ids: The ids of the bodies it was bred from (e.g. ``["b000003"]``, two for a
            crossover); empty for a random genotype.
    """

    genotype: object
    parent_ids: list[str]


@runtime_checkable
class BodyOptimizer(Protocol):
    """Ask / tell over bodies; see the module docstring."""

    @property
    def population(self) -> list[Body]:
        """The bodies kept after the last `tell` (what the next `ask` breeds from)."""
        ...

    def ask(self, n: int) -> list[Proposal]:
        """``n`` new genotypes (random ones while the population is empty)."""
        ...

    def tell(self, bodies: Sequence[Body]) -> None:
        """The bodies made from the last `ask`, with their fitness and descriptors."""
        ...

    def state(self) -> Mapping[str, object]:
        """Plain data (JSON-able) that `restore` takes back."""
        ...

    # Any: what `state` gave, read back from the checkpoint's JSON; its shape is the
    # optimizer's own (a TypedDict such as `GAState`), which a protocol cannot name for all.
    def restore(self, state: Any, population: Sequence[Body]) -> None:
        """Continue from `state` and the population kept when it was taken."""
        ...


@runtime_checkable
class ArchiveOptimizer(BodyOptimizer, Protocol):
    """A `BodyOptimizer` with an archive of elites; see the module docstring."""

    qd_offset: float  # the fitness that counts as nothing in the QD-score

    def archive_rows(self) -> Sequence[Mapping[str, object]]:
        """One row of the ``archive`` table per filled cell (``cell``, ``body_id``,
        ``fitness``, ``objective``, ``measures``, ``grid``), in cell order."""
        ...

    def archive_description(self) -> Mapping[str, object]:
        """Plain JSON: ``kind`` (``"grid"`` or ``"cvt"``), ``measures``, ``ranges``, and a
        grid's ``bins`` or a CVT's ``cells`` and ``centroids`` (in the measures' units)."""
        ...

    def stats(self) -> dict[str, float]:
        """``coverage``, ``qd_score``, ``norm_qd_score``, ``cells``, ``filled`` (and more)."""
        ...


def ranked(bodies: Sequence[Body], maximise: bool) -> list[Body]:
    """Best first (failed bodies last); ties go to the older body (smaller number)."""
    return sorted(bodies, key=lambda b: (fitness_rank(b.fitness, maximise), b.number))
