"""Upstream ARIEL's earlier EA API (``from ariel.ec.a004 import EA, EAStep, EASettings``).

Course material from 2025 uses it: ``EA(population_list, operations=[EAStep("name", f)],
num_of_generations=100)`` with settings in this module's own ``config`` (which has
``num_of_generations`` where the current API has ``num_steps``). It runs on the current engine;
`fetch_population` keeps its old signature and puts the best individual first.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal

from pydantic import Field
from sqlmodel import col, select

from ariel.ec import _settings, ea as _ea
from ariel.ec._db import session
from ariel.ec._operation import EAStep
from ariel.ec.individual import Individual
from ariel.ec.population import Population

__all__ = ["EA", "EASettings", "EAStep", "Individual", "Population", "config"]


class EASettings(_settings.EASettings):
    """The current settings plus the old name for the number of generations.

    Each field can be overridden by an ``ARIEL_EC_<NAME>`` environment variable, as in
    `ariel.ec.EASettings`.

    Attributes:
        quiet: silence the EA's console output and progress bar.
        is_maximisation: ``True`` if a higher fitness is better.
        first_generation_id: the generation number of the initial population.
        num_steps: unused by the old `EA`, which reads ``num_of_generations`` instead.
        target_population_size: copied to ``EA.target_population_size`` for operations to read
            (>= 0).
        output_folder: the folder of the database file.
        db_file_name: the database file's name inside ``output_folder``.
        db_handling: ``"delete"`` an existing database file, or ``"halt"`` with
            ``FileExistsError``.
        num_of_generations: generations `EA.run` performs when the old `EA` is not given
            ``num_of_generations`` (>= 0).
    """

    num_of_generations: int = Field(default=100, ge=0)


#: This module's settings; the old `EA` reads these.
config: EASettings = EASettings()


class EA(_ea.EA):
    """The old constructor on the current engine (database path and handling from ``config``).

    Settings not given as arguments (and the database path, database handling and fitness
    direction always) come from this module's ``config``, not from ``ariel.ec.config``.

    Args:
        population: the initial individuals (a list or a `Population`).
        operations: the per-generation pipeline: `EAStep`s, `EAOperation`s or plain functions
            ``Population -> Population``, applied in order.
        num_of_generations: generations `run` performs; ``None`` reads
            ``config.num_of_generations``.
        first_generation_id: the generation number of the initial population; ``None`` reads
            ``config.first_generation_id``.
        quiet: silence console output and the progress bar; ``None`` reads ``config.quiet``.
    """

    def __init__(
        self,
        population: Sequence[Individual],
        operations: Sequence[Callable[..., Any]],
        num_of_generations: int | None = None,
        *,
        first_generation_id: int | None = None,
        quiet: bool | None = None,
    ) -> None:
        super().__init__(
            Population(population),
            operations,
            num_steps=config.num_of_generations
            if num_of_generations is None
            else num_of_generations,
            first_generation_id=first_generation_id,
            quiet=config.quiet if quiet is None else quiet,
            db_file_path=config.db_file_path,
            db_handling=config.db_handling,
            is_maximisation=config.is_maximisation,
        )
        self.target_population_size = config.target_population_size

    @property
    def num_of_generations(self) -> int:
        """The old name of ``num_steps``."""
        return self.num_steps

    @property
    def population_size(self) -> int:
        """The old name of ``size``: living individuals, read from the database."""
        return self.size

    def commit_population(self) -> None:
        """Save the current population (the old name of the commit)."""
        self._commit()

    def fetch_population(  # type: ignore[override]
        self,
        best_comes: Literal["first", "last"] | None = "first",
        *,
        only_alive: bool = True,
        already_evaluated: bool | None = None,
        custom_logic: tuple[Any, ...] | None = None,
        requires_eval: bool | None = None,
    ) -> None:
        """Reload the population, best first (``"first"``), best last, or stored order (None)."""
        if best_comes not in ("first", "last", None):
            raise ValueError(f"best_comes must be 'first', 'last' or None, not {best_comes!r}")
        statement = select(Individual)
        if only_alive:
            statement = statement.where(col(Individual.alive))
        if already_evaluated is not None:
            statement = statement.where(Individual.requires_eval != already_evaluated)
        if requires_eval is not None:
            statement = statement.where(Individual.requires_eval == requires_eval)
        if custom_logic:
            statement = statement.where(*custom_logic)  # upstream built this and dropped it
        if best_comes is not None:
            descending = self.is_maximisation == (best_comes == "first")
            fitness = col(Individual.fitness_)
            statement = statement.order_by(fitness.desc() if descending else fitness.asc())
        with session(self.engine) as s:
            self.population = Population(s.exec(statement.order_by(col(Individual.id))).all())
