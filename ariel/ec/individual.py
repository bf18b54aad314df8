"""`Individual`: one candidate solution, stored as a row of the SQLite table ``individual``.

Same columns, defaults and properties as upstream ARIEL's (so a script that reads a run's
database back with sqlmodel keeps working), with three fixes listed in docs/decisions.md:
numpy genotypes are stored as nested lists, a NaN fitness is refused (SQLite would store it as
NULL and the individual would read back as "evaluated without a fitness"), and tags or genotypes
changed in place are saved too (the EA marks both columns dirty on every commit).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np
from sqlalchemy import JSON, Column
from sqlmodel import Field, SQLModel

__all__ = ["Individual", "JSONIterable", "JSONPrimitive", "JSONType", "to_json"]

JSONPrimitive = str | int | float | bool | None
JSONType = JSONPrimitive | Sequence[Any] | dict[str, Any]
JSONIterable = Sequence[JSONType] | dict[str, JSONType]


def to_json(value: Any) -> Any:
    """``value`` as plain JSON data: numpy arrays become nested lists, numpy scalars numbers.

    Args:
        value: any value; lists, tuples and dicts are converted recursively.

    Returns:
        The converted value: tuples become lists, anything else that is not numpy is returned
            unchanged.
    """
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [to_json(v) for v in value]
    if isinstance(value, dict):
        return {k: to_json(v) for k, v in value.items()}
    return value


class Individual(SQLModel, table=True):
    """A candidate solution: lifetime, fitness, genotype and free-form tags.

    Use the ``fitness``, ``genotype`` and ``tags`` properties; the raw columns (``fitness_``,
    ``genotype_``, ``tags_``) are for database queries. ``time_of_birth`` / ``time_of_death``
    are set by `EA` when it commits (first and last generation the individual was present).

    Attributes:
        id: the database row id; ``None`` until the individual is first saved.
        alive: whether it belongs to the living population; an operation sets ``False`` to
            remove it, and the EA fetches only living individuals for the next generation.
        time_of_birth: the generation it was first committed in (``-1`` before that).
        time_of_death: the last generation it was committed in (``-1`` before that).
        requires_eval: ``True`` until a fitness is assigned through ``fitness``.
        fitness_: the raw fitness column (``None`` before evaluation).
        requires_init: ``True`` while no (non-empty) genotype was assigned through ``genotype``.
        genotype_: the raw genotype column (JSON data, ``None`` before initialisation).
        tags_: the raw tags column: a JSON dictionary of free-form annotations.
    """

    id: int | None = Field(default=None, primary_key=True)
    alive: bool = Field(default=True, index=True)
    time_of_birth: int = Field(default=-1, index=True)
    time_of_death: int = Field(default=-1, index=True)
    requires_eval: bool = Field(default=True, index=True)
    fitness_: float | None = Field(default=None, index=True)
    requires_init: bool = Field(default=True, index=True)
    genotype_: Any = Field(default=None, sa_column=Column(JSON))
    tags_: dict = Field(default_factory=dict, sa_column=Column(JSON))

    @property
    def fitness(self) -> float:
        """The fitness; ``ValueError`` before the individual was evaluated."""
        if self.fitness_ is None:
            raise ValueError(f"fitness read before evaluation (individual id={self.id})")
        return self.fitness_

    @fitness.setter
    def fitness(self, value: float) -> None:
        """Store ``value`` and mark the individual evaluated (``requires_eval = False``)."""
        if not isinstance(value, numbers.Real) or isinstance(value, bool):
            raise TypeError(f"fitness must be a real number, not {value!r}")
        if math.isnan(value):
            raise ValueError(
                "fitness must be a number or ±inf, not NaN (SQLite stores NaN as NULL)"
            )
        self.fitness_ = float(value)
        self.requires_eval = False

    @property
    def genotype(self) -> Any:
        """The genotype (JSON data); ``ValueError`` before one was assigned."""
        if self.genotype_ is None:
            raise ValueError(f"genotype read before initialisation (individual id={self.id})")
        return self.genotype_

    @genotype.setter
    def genotype(self, value: Any) -> None:
        """Store ``value`` (numpy arrays as nested lists); empty values leave it uninitialised."""
        value = to_json(value)
        self.genotype_ = value
        self.requires_init = not bool(value)

    @property
    def tags(self) -> dict:
        """The tag dictionary itself (changing it in place is saved on the next commit)."""
        return self.tags_

    @tags.setter
    def tags(self, update: dict) -> None:
        """Merge ``update`` into the tags: given keys are overwritten, others kept."""
        if not isinstance(update, dict):
            raise TypeError(f"tags must be set from a dict (it is merged in), not {update!r}")
        self.tags_ = {**self.tags_, **to_json(update)}
