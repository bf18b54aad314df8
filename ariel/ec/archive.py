"""`Archive`: read-only queries on the database of a finished (or running) EA.

Individuals come back as fresh, unsaved copies (``id=None``), ready to be put into a new
population. Random picks take ``seed=`` (upstream uses SQLite's unseedable ``random()``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
from sqlalchemy import Engine, func
from sqlmodel import col, select

from ariel.ec._arguments import whole
from ariel.ec._db import fresh_copy, readable_engine, session
from ariel.ec._rng import SeedLike, resolve_rng
from ariel.ec.individual import Individual
from ariel.ec.population import Population

__all__ = ["Archive"]

FitnessMode = Literal["min", "max"]
Range = tuple[float, float] | None


def _range(name: str, bounds: object) -> tuple[float, float]:
    """``(low, high)`` as two numbers, low <= high, neither NaN (which matched nothing)."""
    try:
        lo, hi = (float(bound) for bound in bounds)  # type: ignore[union-attr]
    except (TypeError, ValueError):  # (0,), (None, 1), "ab"
        raise ValueError(f"{name} range must be (low, high), two numbers, not {bounds!r}") from None
    if math.isnan(lo) or math.isnan(hi) or lo > hi:
        raise ValueError(f"{name} range must be (low, high) with low <= high, not {bounds!r}")
    return lo, hi


def _check_mode(fitness_mode: str) -> None:
    if fitness_mode not in ("min", "max"):
        raise ValueError(f"fitness_mode must be 'min' or 'max', not {fitness_mode!r}")


class Archive:
    """Queries on the SQLite database an `EA` wrote (``db_path``).

    Args:
        db_path: the database file, e.g. an `EA`'s ``db_file_path``.

    Raises:
        FileNotFoundError: ``db_path`` is not an existing file.
        ValueError: ``db_path`` is not an EA database (no ``individual`` table, not SQLite).
    """

    def __init__(self, db_path: Path | str) -> None:
        self.db_path = Path(db_path)
        if not self.db_path.is_file():
            raise FileNotFoundError(f"archive database not found: {self.db_path}")
        self.engine: Engine = readable_engine(self.db_path, "archive database")

    # -- helpers -------------------------------------------------------------------------

    @staticmethod
    def _filters(
        statement: Any,
        *,
        birth_range: Range = None,
        death_range: Range = None,
        fitness_range: Range = None,
        alive: bool | None = None,
    ) -> Any:
        """``statement`` restricted to evaluated individuals and the given inclusive ranges."""
        statement = statement.where(Individual.requires_eval == False)  # noqa: E712
        if alive is not None:
            statement = statement.where(Individual.alive == alive)
        for column, bounds in (
            (Individual.time_of_birth, birth_range),
            (Individual.time_of_death, death_range),
            (Individual.fitness_, fitness_range),
        ):
            if bounds is not None:  # as plain numbers: SQLite matched no NumPy integer
                lo, hi = _range(column.key, bounds)
                statement = statement.where(col(column) >= lo).where(col(column) <= hi)
        return statement

    def _rows(self, statement: Any) -> list[Individual]:
        with session(self.engine) as s:
            return [fresh_copy(row) for row in s.exec(statement).all()]

    def _ranked(self, fitness_mode: FitnessMode, limit: int | None, **filters: Any) -> Population:
        _check_mode(fitness_mode)
        order = (
            col(Individual.fitness_).asc()
            if fitness_mode == "min"
            else col(Individual.fitness_).desc()
        )
        statement = self._filters(select(Individual), **filters).order_by(order, col(Individual.id))
        if limit is not None:
            statement = statement.limit(limit)
        return Population(self._rows(statement))

    # -- single individuals --------------------------------------------------------------

    def random_individual(
        self,
        *,
        birth_range: Range = None,
        death_range: Range = None,
        fitness_range: Range = None,
        only_dead: bool = False,
        seed: SeedLike = None,
    ) -> Individual:
        """One uniformly drawn evaluated individual; ``ValueError`` if none match."""
        picked = self.random_population(
            1,
            birth_range=birth_range,
            death_range=death_range,
            fitness_range=fitness_range,
            only_dead=only_dead,
            seed=seed,
        )
        if not picked:
            raise ValueError(f"no evaluated individuals in {self.db_path} match the filters")
        return picked[0]

    def best_individual(
        self,
        fitness_mode: FitnessMode = "min",
        *,
        birth_range: Range = None,
        death_range: Range = None,
    ) -> Individual:
        """The individual with the lowest (``"min"``) or highest (``"max"``) fitness."""
        ranked = self._ranked(fitness_mode, 1, birth_range=birth_range, death_range=death_range)
        if not ranked:
            raise ValueError(f"no evaluated individuals in {self.db_path} match the filters")
        return ranked[0]

    # -- populations ---------------------------------------------------------------------

    def random_population(
        self,
        n: int,
        *,
        birth_range: Range = None,
        death_range: Range = None,
        fitness_range: Range = None,
        only_dead: bool = False,
        seed: SeedLike = None,
    ) -> Population:
        """Up to ``n`` evaluated individuals drawn without replacement."""
        n = whole("n", n)
        ids_query = self._filters(
            select(Individual.id),
            birth_range=birth_range,
            death_range=death_range,
            fitness_range=fitness_range,
            alive=False if only_dead else None,
        ).order_by(col(Individual.id))
        with session(self.engine) as s:
            ids = list(s.exec(ids_query).all())
        chosen = resolve_rng(seed).choice(len(ids), size=min(n, len(ids)), replace=False)
        wanted = [ids[int(i)] for i in chosen]
        with session(self.engine) as s:
            stored = s.exec(select(Individual).where(col(Individual.id).in_(wanted))).all()
            by_id = {row.id: fresh_copy(row) for row in stored}
        return Population(by_id[i] for i in wanted)

    def hall_of_fame(
        self,
        n: int = 10,
        fitness_mode: FitnessMode = "min",
        *,
        birth_range: Range = None,
        death_range: Range = None,
    ) -> Population:
        """The ``n`` best individuals of all time, best first."""
        n = whole("n", n)
        return self._ranked(fitness_mode, n, birth_range=birth_range, death_range=death_range)

    def tournament_population(
        self,
        n: int,
        tournament_size: int = 3,
        fitness_mode: FitnessMode = "min",
        *,
        birth_range: Range = None,
        death_range: Range = None,
        pool_multiplier: int = 4,
        seed: SeedLike = None,
    ) -> Population:
        """``n`` winners of tournaments of ``tournament_size`` over a random pool of
        ``n * pool_multiplier`` archived individuals."""
        _check_mode(fitness_mode)
        n = whole("n", n)
        pool_multiplier = whole("pool_multiplier", pool_multiplier, 1)
        if n == 0:
            return Population([])
        rng = resolve_rng(seed)
        pool = self.random_population(
            n * pool_multiplier, birth_range=birth_range, death_range=death_range, seed=rng
        )
        if not pool:
            raise ValueError(f"no evaluated individuals in {self.db_path} match the filters")
        if not 1 <= tournament_size <= len(pool):
            raise ValueError(f"tournament_size must be in [1, pool size {len(pool)}]")
        pick = min if fitness_mode == "min" else max
        winners = []
        for _ in range(n):
            entrants = rng.choice(len(pool), size=tournament_size, replace=False)
            winners.append(pick((pool[int(i)] for i in entrants), key=lambda ind: ind.fitness_))
        return Population(winners)

    def by_generation(self, generation: int) -> Population:
        """Every evaluated individual present during ``generation`` (born <= it <= died)."""
        generation = whole("generation", generation)  # np.int64(0) matched no row
        return Population(
            self._rows(
                self._filters(select(Individual))
                .where(Individual.time_of_birth <= generation)
                .where(Individual.time_of_death >= generation)
                .order_by(col(Individual.id))
            )
        )

    def fitness_percentile_population(
        self,
        lo_pct: float = 25.0,
        hi_pct: float = 75.0,
        n: int | None = None,
        *,
        fitness_mode: FitnessMode = "min",
        birth_range: Range = None,
        seed: SeedLike = None,
    ) -> Population:
        """Individuals whose fitness lies between two percentiles (``n``: a random subset)."""
        _check_mode(fitness_mode)
        if not 0 <= lo_pct <= hi_pct <= 100:
            raise ValueError(f"need 0 <= lo_pct <= hi_pct <= 100, got {lo_pct}, {hi_pct}")
        everyone = self._rows(
            self._filters(select(Individual), birth_range=birth_range).order_by(col(Individual.id))
        )
        if not everyone:
            return Population()
        fitness = np.array([ind.fitness_ for ind in everyone], dtype=float)
        lo, hi = np.percentile(fitness, [lo_pct, hi_pct])
        band = Population(ind for ind, f in zip(everyone, fitness) if lo <= f <= hi)
        return band if n is None else band.sample(n, seed=resolve_rng(seed))

    # -- statistics ----------------------------------------------------------------------

    @property
    def size(self) -> int:
        """Number of evaluated individuals stored."""
        with session(self.engine) as s:
            return s.exec(self._filters(select(func.count(col(Individual.id))))).one()

    @property
    def generation_range(self) -> tuple[int, int]:
        """(earliest birth, latest death) generation in the database; (0, 0) when empty."""
        with session(self.engine) as s:
            first = s.exec(select(func.min(Individual.time_of_birth))).one()
            last = s.exec(select(func.max(Individual.time_of_death))).one()
        return (first or 0, last or 0)

    def fitness_stats(self, birth_range: Range = None) -> dict[str, float]:
        """min, max, mean, std and median fitness (all NaN when nothing matches)."""
        with session(self.engine) as s:
            values = s.exec(
                self._filters(select(Individual.fitness_), birth_range=birth_range)
            ).all()
        f = np.array(values, dtype=float)
        if f.size == 0:
            return dict.fromkeys(("min", "max", "mean", "std", "median"), math.nan)
        return {
            "min": float(f.min()),
            "max": float(f.max()),
            "mean": float(f.mean()),
            "std": float(f.std()),
            "median": float(np.median(f)),
        }
