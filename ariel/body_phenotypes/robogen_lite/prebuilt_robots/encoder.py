"""The ``prebuilt`` body encoder: a fixed named body (``"gecko"``, ``"spider"``, ...).

For brain-only experiments: the genotype is the body's name and cannot vary, so
``evolvable`` is False and `mutate`/`crossover` refuse. Registered as ``"prebuilt"`` in
``ariel._builtin_names``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NoReturn

from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS, PREBUILT_ROBOTS
from ariel.errors import cannot_vary

if TYPE_CHECKING:
    import networkx as nx
    import numpy as np

    from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule

__all__ = ["PrebuiltEncoder"]


class PrebuiltEncoder:
    """A fixed named body (``"gecko"``, ``"spider"``, ...); the genotype is the name.

    ``random_genotype`` gives ``"gecko"`` (the rng is not used): the default body.
    """

    name = "prebuilt"
    evolvable = False

    def __init__(self) -> None:
        pass

    @staticmethod
    def _check(genotype: Any) -> str:
        if not isinstance(genotype, str) or genotype not in PREBUILT_ROBOTS:
            raise ValueError(
                f"unknown prebuilt body {genotype!r}; known: {', '.join(sorted(PREBUILT_ROBOTS))}"
            )
        return genotype

    def random_genotype(self, rng: np.random.Generator) -> str:
        return "gecko"

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> NoReturn:
        cannot_vary(self.name)

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> NoReturn:
        cannot_vary(self.name)

    def build(self, genotype: Any) -> CoreModule:
        """The exact prebuilt body (a CoreModule), which a graph cannot always express."""
        return PREBUILT_ROBOTS[self._check(genotype)]()

    def decode(self, genotype: Any) -> nx.DiGraph:
        name = self._check(genotype)
        if name not in PREBUILT_GRAPHS:
            raise ValueError(
                f"prebuilt body {name!r} has no graph form; bodies with one: "
                f"{', '.join(sorted(PREBUILT_GRAPHS))}"
            )
        return PREBUILT_GRAPHS[name]()
