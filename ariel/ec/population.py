"""`Population`: a list of `Individual` objects with upstream ARIEL's chainable queries.

It is a real ``list`` (so code written for upstream's older ``list[Individual]`` populations,
``random.shuffle(population)`` included, keeps working); every query returns a new
`Population` and leaves the original alone. Importing this module imports no database library.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any, Literal, SupportsIndex, overload

from ariel.ec._arguments import whole
from ariel.ec._rng import SeedLike, resolve_rng

if TYPE_CHECKING:
    from ariel.ec.individual import Individual

__all__ = ["Population"]

SortOrder = Literal["max", "min"]


def _sort_value(individual: Individual, attribute: str) -> float | None:
    """``attribute`` as a float, or ``None`` when missing, unset or not a number."""
    try:
        value = getattr(individual, attribute)
    except (AttributeError, ValueError):  # ValueError: the fitness property before evaluation
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(number) else number


def _check_order(sort: str) -> None:
    if sort not in ("max", "min"):
        raise ValueError(f"sort must be 'max' or 'min', not {sort!r}")


class Population(list):
    """Ordered container of individuals: ``alive``, ``evaluated``, ``best(...)``, ``where(...)``.

    Args:
        individuals: the individuals, in order; by default none.
    """

    def __init__(self, individuals: Iterable[Individual] = ()) -> None:
        super().__init__(individuals)

    # -- sequence protocol: slices and sums stay populations ---------------------------------

    @overload
    def __getitem__(self, index: SupportsIndex) -> Individual: ...
    @overload
    def __getitem__(self, index: slice) -> Population: ...
    def __getitem__(self, index: SupportsIndex | slice) -> Any:
        if isinstance(index, slice):
            return Population(super().__getitem__(index))
        return super().__getitem__(index)

    def __add__(self, other: Iterable[Individual]) -> Population:  # type: ignore[override]
        return Population([*self, *other])

    def __repr__(self) -> str:
        return f"Population(n={len(self)})"

    @property
    def population(self) -> list[Individual]:
        """The individuals as a plain list (upstream's attribute name)."""
        return list(self)

    @property
    def size(self) -> int:
        """Number of individuals, ``len(self)``."""
        return len(self)

    def to_list(self) -> list[Individual]:
        """A plain list of the individuals (a shallow copy)."""
        return list(self)

    def copy(self) -> Population:
        """A shallow copy, still a `Population`."""
        return Population(self)

    @classmethod
    def empty(cls) -> Population:
        """A population with no individuals."""
        return cls()

    # -- queries (new populations) -------------------------------------------------------

    def where(self, predicate: Callable[[Individual], bool]) -> Population:
        """The individuals for which ``predicate(individual)`` is true."""
        return Population(ind for ind in self if predicate(ind))

    @property
    def alive(self) -> Population:
        """Individuals with ``alive=True``."""
        return self.where(lambda ind: ind.alive)

    @property
    def dead(self) -> Population:
        """Individuals with ``alive=False``."""
        return self.where(lambda ind: not ind.alive)

    @property
    def unevaluated(self) -> Population:
        """Individuals that still need a fitness (``requires_eval=True``)."""
        return self.where(lambda ind: ind.requires_eval)

    @property
    def evaluated(self) -> Population:
        """Individuals with a fitness (``requires_eval=False``)."""
        return self.where(lambda ind: not ind.requires_eval)

    def sort(  # type: ignore[override]
        self,
        *,
        sort: SortOrder = "max",
        attribute: str = "fitness_",
        key: Callable[[Individual], Any] | None = None,
        reverse: bool | None = None,
    ) -> Population | None:
        """A new population ordered by ``attribute`` (``"max"``: largest first).

        Individuals without a value (unevaluated ones) come last in either order. Called with
        ``key=`` or ``reverse=`` it is ``list.sort``: sorts in place and returns ``None``, as
        code written for plain-list populations expects.
        """
        if key is not None or reverse is not None:
            super().sort(key=key, reverse=bool(reverse))  # type: ignore[arg-type]
            return None
        _check_order(sort)
        valued = [(v, ind) for ind in self if (v := _sort_value(ind, attribute)) is not None]
        missing = [ind for ind in self if _sort_value(ind, attribute) is None]
        valued.sort(key=lambda pair: pair[0], reverse=sort == "max")  # stable: ties keep order
        return Population([ind for _, ind in valued] + missing)

    def best(
        self,
        *,
        sort: SortOrder = "max",
        attribute: str = "fitness_",
        n: int = 1,
    ) -> Population:
        """The ``n`` best individuals by ``attribute`` (``"max"``: largest values first)."""
        n = whole("n", n)
        ordered = self.sort(sort=sort, attribute=attribute)
        assert ordered is not None
        return ordered[:n]

    def sample(self, n: int, *, seed: SeedLike = None) -> Population:
        """Up to ``n`` individuals drawn without replacement (all of them if ``n >= len``).

        ``seed``: an int or numpy Generator; ``None`` draws from Python's ``random``, as
        upstream does (so ``random.seed`` / `set_seed` make it repeat).
        """
        k = min(whole("n", n), len(self))
        if seed is None:
            return Population(random.sample(list(self), k))
        items = list(self)
        picks = resolve_rng(seed).choice(len(items), size=k, replace=False)
        return Population(items[int(i)] for i in picks)

    def shuffle(self, *, seed: SeedLike = None) -> Population:
        """A new population with the same individuals in random order (see `sample`)."""
        return self.sample(len(self), seed=seed)
