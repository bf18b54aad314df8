"""`EA`: upstream ARIEL's generational EA engine, persisting every generation to SQLite.

Each `step` fetches the living individuals from the database, passes them through the
``operations`` in order, and commits the result (birth and death generations updated). The
fixes to upstream's behaviour (best/worst the right way round, restart from the population at
the end of a generation, in-place tag changes saved) are listed in docs/decisions.md.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from sqlalchemy import Engine, func, or_
from sqlalchemy.exc import StatementError
from sqlalchemy.orm.attributes import flag_modified
from sqlmodel import SQLModel, col, select

from ariel.ec._db import database_error, fresh_copy, open_engine, readable_engine, session
from ariel.ec._operation import EAOperation, EAStep, run_operation
from ariel.ec._settings import DBHandlingMode, EASettings, config
from ariel.ec.individual import Individual
from ariel.ec.population import Population

__all__ = ["EA", "DBHandlingMode", "EAOperation", "EASettings", "EAStep", "config"]

SolutionMode = Literal["best", "median", "worst"]
Restart = tuple[Path | str, int] | Path | str


def _load_restart(restart: Restart) -> tuple[Population, int]:
    """The evaluated population alive at the end of a stored generation, as fresh individuals."""
    if isinstance(restart, Path | str):
        path, generation = Path(restart), None
    elif isinstance(restart, tuple) and len(restart) == 2:
        path, generation = Path(restart[0]), int(restart[1])
    else:
        raise ValueError(f"restart must be a database path or (path, generation), not {restart!r}")
    if not path.is_file():
        raise FileNotFoundError(f"restart database not found: {path}")
    engine = readable_engine(path, "restart database")
    try:
        with session(engine) as s:
            if generation is None:
                generation = s.exec(select(func.max(Individual.time_of_death))).one()
                if generation is None:
                    raise ValueError(f"restart database {path} holds no individuals")
            # Alive at the END of the generation: killed in it (death == g, alive False) is out.
            rows = s.exec(
                select(Individual)
                .where(Individual.requires_eval == False)  # noqa: E712 (SQL expression)
                .where(Individual.time_of_birth <= generation)
                .where(
                    or_(
                        Individual.time_of_death > generation,
                        (Individual.time_of_death == generation) & col(Individual.alive),
                    )
                )
                .order_by(col(Individual.id))
            ).all()
    finally:
        engine.dispose()
    if not rows:
        raise ValueError(f"no evaluated individuals alive at generation {generation} in {path}")
    population = Population(fresh_copy(r, alive=True, time_of_death=-1) for r in rows)
    return population, generation


class EA:
    """Generational EA: ``operations`` applied to the living population once per step.

    Args:
        population: the initial population (required unless ``restart`` is given).
        operations: the per-generation pipeline: `EAOperation`s, `EAStep`s or plain functions
            ``Population -> Population``.
        restart: continue from a previous run's database: a path (its last generation) or
            ``(path, generation)``. Starts at that generation + 1 unless told otherwise.
        num_steps: generations `run` performs (a whole number >= 0); falls back on
            ``ariel.ec.config.num_steps``.
        first_generation_id: the generation number of the initial population (each `step`
            adds 1); falls back on ``restart``'s generation + 1, then on
            ``ariel.ec.config.first_generation_id``.
        quiet: silence console output and the progress bar; falls back on
            ``ariel.ec.config.quiet``.
        db_file_path: the SQLite file this run writes; falls back on
            ``ariel.ec.config.db_file_path``. Its folder is created if missing.
        db_handling: what to do if ``db_file_path`` exists: ``"delete"`` it or ``"halt"``;
            falls back on ``ariel.ec.config.db_handling``.
        is_maximisation: the fitness direction for `get_solution`; falls back on
            ``ariel.ec.config.is_maximisation`` (upstream reads only the latter).

    Raises:
        ValueError: ``operations`` is missing, neither ``population`` nor ``restart`` is given,
            ``num_steps`` is not a whole number >= 0, ``db_handling`` is unknown, or
            ``restart`` is malformed, names ``db_file_path`` itself, or holds no evaluated
            individual alive at that generation.
        TypeError: an entry of ``operations`` is not callable.
        FileExistsError: ``db_file_path`` exists and ``db_handling`` is ``"halt"``.
        FileNotFoundError: the ``restart`` database does not exist.
    """

    def __init__(
        self,
        population: Population | Sequence[Individual] | None = None,
        operations: Sequence[Callable[..., Any]] | None = None,
        *,
        restart: Restart | None = None,
        num_steps: int | None = None,
        first_generation_id: int | None = None,
        quiet: bool | None = None,
        db_file_path: Path | str | None = None,
        db_handling: DBHandlingMode | None = None,
        is_maximisation: bool | None = None,
    ) -> None:
        if operations is None:
            raise ValueError("operations is required: a list of EAOperation (Population -> ...)")
        bad = [op for op in operations if not callable(op)]
        if bad:
            raise TypeError(f"every operation must be callable; not callable: {bad!r}")
        target = Path(db_file_path or config.db_file_path)
        if restart is not None:
            source = Path(restart if isinstance(restart, Path | str) else restart[0])
            if source.resolve() == target.resolve():
                raise ValueError(
                    f"restart database {source} is also this run's db_file_path, which a new run "
                    "replaces: give the restarted run another db_file_path"
                )
            population, restart_generation = _load_restart(restart)
            if first_generation_id is None:
                first_generation_id = restart_generation + 1
        elif population is None:
            raise ValueError("give an initial population, or restart=<database path>")
        steps = config.num_steps if num_steps is None else num_steps
        if not isinstance(steps, int) or isinstance(steps, bool) or steps < 0:
            raise ValueError(f"num_steps must be a whole number >= 0, not {steps!r}")

        self.operations: list[Callable[..., Any]] = list(operations)
        self.is_maximisation: bool = (
            config.is_maximisation if is_maximisation is None else bool(is_maximisation)
        )
        self.target_population_size: int = config.target_population_size
        self.current_generation: int = (
            config.first_generation_id if first_generation_id is None else first_generation_id
        )
        self.num_steps: int = steps
        self.console = Console(quiet=config.quiet if quiet is None else quiet)
        self.db_file_path = target
        members = list(population)
        for k, ind in enumerate(members):
            if not isinstance(ind, Individual):
                raise TypeError(
                    f"population[{k}] must be an Individual, not {type(ind).__name__} {ind!r:.40}"
                )
        # Individuals saved in another database (e.g. another run's best) start as new rows.
        self.population = Population(
            ind if ind.id is None else fresh_copy(ind, time_of_birth=-1, time_of_death=-1)
            for ind in members
        )
        self.engine: Engine = self._setup_database(target, db_handling or config.db_handling)
        self.console.rule("[blue]EA Initialized")

    # -- database ------------------------------------------------------------------------

    def _setup_database(self, path: Path, db_handling: str) -> Engine:
        """A fresh database at ``path`` holding the initial population; an existing file is
        replaced or refused. The new one is written beside it and takes its place only once
        the population is saved: a population that cannot be saved leaves the old file whole.
        """
        if db_handling not in ("delete", "halt"):
            raise ValueError(f"db_handling must be 'delete' or 'halt', not {db_handling!r}")
        if path.exists() and db_handling == "halt":
            raise FileExistsError(f"database {path} exists and db_handling is 'halt'")
        if path.is_dir():  # the replace below would fail after the population was saved
            raise IsADirectoryError(f"db_file_path {path} is a folder: name a database file")
        path.parent.mkdir(parents=True, exist_ok=True)
        fresh = path.with_name(f".{path.name}.new-{os.getpid()}")
        fresh.unlink(missing_ok=True)
        self.engine = open_engine(fresh)
        try:
            SQLModel.metadata.create_all(self.engine)
            self._commit()
        except BaseException:
            self.engine.dispose()
            fresh.unlink(missing_ok=True)
            raise
        self.engine.dispose()
        if path.exists():
            self.console.log(f"Database {path} exists: replacing it (db_handling='delete')")
        # The old file's write-ahead log and journal would be applied to the new one (a WAL
        # left by another program read back as its rows)
        for suffix in ("-wal", "-shm", "-journal"):
            path.with_name(path.name + suffix).unlink(missing_ok=True)
        os.replace(fresh, path)
        return open_engine(path)

    def _commit(self) -> None:
        """Save the population: birth generation if unset, death generation = now."""
        try:
            self._save()
        except StatementError as error:
            where = f"cannot save the population to {self.db_file_path}"
            raise database_error(where, error) from None

    def _save(self) -> None:
        with session(self.engine) as s:
            for ind in self.population:
                if ind.time_of_birth == -1:
                    ind.time_of_birth = self.current_generation
                ind.time_of_death = self.current_generation
                s.add(ind)
                # Tags and genotypes changed in place are invisible to SQLAlchemy: mark them.
                flag_modified(ind, "tags_")
                flag_modified(ind, "genotype_")
            s.commit()

    def _fetch(
        self,
        *,
        sort: Literal["asc", "desc"] | None = None,
        only_alive: bool = True,
        requires_eval: bool | None = None,
    ) -> Population:
        statement = select(Individual)
        if only_alive:
            statement = statement.where(col(Individual.alive))
        if requires_eval is not None:
            statement = statement.where(Individual.requires_eval == requires_eval)
        if sort == "desc":
            statement = statement.order_by(col(Individual.fitness_).desc())
        elif sort == "asc":
            statement = statement.order_by(col(Individual.fitness_).asc())
        statement = statement.order_by(col(Individual.id))  # ties and no sort: stored order
        with session(self.engine) as s:
            return Population(s.exec(statement).all())

    def fetch_population(
        self, *, only_alive: bool = True, requires_eval: bool | None = None
    ) -> None:
        """Reload ``self.population`` from the database (living ones by default)."""
        self.population = self._fetch(only_alive=only_alive, requires_eval=requires_eval)

    @property
    def size(self) -> int:
        """Number of living individuals (read from the database)."""
        self.fetch_population()
        return len(self.population)

    def get_solution(self, mode: SolutionMode = "best", *, only_alive: bool = True) -> Individual:
        """The best, median or worst evaluated individual by fitness (per ``is_maximisation``)."""
        if mode not in ("best", "median", "worst"):
            raise ValueError(f"mode must be 'best', 'median' or 'worst', not {mode!r}")
        ranked = self._fetch(
            sort="desc" if self.is_maximisation else "asc",
            only_alive=only_alive,
            requires_eval=False,
        )
        if not ranked:
            raise ValueError("no evaluated individuals in the database yet")
        index = {"best": 0, "median": len(ranked) // 2, "worst": -1}[mode]
        return ranked[index]

    best = get_solution  # the name in upstream's earlier release

    # -- running -------------------------------------------------------------------------

    def step(self) -> None:
        """One generation: fetch the living, apply every operation in order, commit."""
        self.current_generation += 1
        self.fetch_population()
        for operation in self.operations:
            self.population = run_operation(operation, self.population)
        self._commit()

    def run(self) -> None:
        """``num_steps`` generations, with a progress bar unless quiet."""
        with Progress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeRemainingColumn(),
            console=self.console,
            disable=self.console.quiet,
        ) as progress:
            task = progress.add_task("Running EA", total=self.num_steps)
            for _ in range(self.num_steps):
                self.step()
                progress.advance(task)
        self.console.rule("[green]EA Finished")
