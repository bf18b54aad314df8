"""Upstream ARIEL's EA engine (`ariel.ec`): Individual on SQLite, Population, EAOperation, EA."""

from __future__ import annotations

import random
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from sqlmodel import Session, create_engine, select

import ariel.ec
from ariel.ec import EA, Archive, EAOperation, EASettings, EAStep, Individual, Population, config


def _ind(genotype: list[float], fitness: float | None = None, **tags: object) -> Individual:
    ind = Individual()
    ind.genotype = genotype
    if fitness is not None:
        ind.fitness = fitness
    ind.tags = dict(tags)
    return ind


# -- the problem every EA test runs: maximise -sum(x^2) over 4 genes ---------------------------


@EAOperation
def evaluate(population: Population) -> Population:
    for ind in population.unevaluated:
        ind.fitness = -float(np.sum(np.square(ind.genotype)))
    return population


@EAOperation
def offspring(population: Population, sigma: float = 0.3, seed: int = 0) -> Population:
    rng = np.random.default_rng(seed + len(population))
    for parent in population.best(n=3):
        child = _ind((np.asarray(parent.genotype) + rng.normal(0, sigma, 4)).tolist())
        child.tags = {"parent": parent.id}
        population.append(child)
    return population


@EAOperation
def truncate(population: Population, keep: int = 6) -> Population:
    for ind in population.sort(sort="max")[keep:]:
        ind.alive = False
    return population


def _run_ea(tmp_path: Path, name: str = "db.db", steps: int = 5) -> EA:
    rng = np.random.default_rng(3)
    start = evaluate(Population(_ind(rng.uniform(-2, 2, 4).tolist()) for _ in range(6)))
    ops = [offspring(sigma=0.3), evaluate, truncate(keep=6)]
    ea = EA(start, ops, num_steps=steps, db_file_path=tmp_path / name, quiet=True)
    ea.run()
    return ea


# -- Individual ------------------------------------------------------------------------------


def test_individual_defaults_and_properties_follow_upstream() -> None:
    ind = Individual()
    assert (ind.id, ind.alive, ind.time_of_birth, ind.time_of_death) == (None, True, -1, -1)
    assert ind.requires_eval and ind.requires_init and ind.tags == {}
    with pytest.raises(ValueError, match="before evaluation"):
        _ = ind.fitness
    with pytest.raises(ValueError, match="before initialisation"):
        _ = ind.genotype
    ind.fitness = 3  # stored as float, marks evaluated
    assert ind.fitness == 3.0 and isinstance(ind.fitness_, float) and not ind.requires_eval
    ind.genotype = np.arange(6).reshape(2, 3)  # numpy is stored as JSON lists
    assert ind.genotype == [[0, 1, 2], [3, 4, 5]] and not ind.requires_init
    ind.tags = {"a": 1}
    ind.tags = {"b": 2}  # setting merges
    assert ind.tags == {"a": 1, "b": 2}
    assert Individual().tags == {}  # no shared mutable default


@pytest.mark.parametrize("bad", [float("nan"), "1.0", None])
def test_bad_fitness_is_refused_with_a_clear_error(bad: object) -> None:
    with pytest.raises((ValueError, TypeError), match="fitness must be"):
        Individual().fitness = bad  # type: ignore[assignment]


def test_individuals_round_trip_through_sqlite(tmp_path: Path) -> None:
    ea = EA(
        Population([_ind([[1, 2], [3, 4]], 0.5, kind="a"), _ind([0.25, -1.5], -2.0, n=[1, 2])]),
        [evaluate],
        num_steps=0,
        db_file_path=tmp_path / "db.db",
        quiet=True,
        first_generation_id=7,
    )
    written = [ind.model_dump() for ind in ea.population]
    # Read back the way a `simulate_from_db` script does: its own engine and sqlmodel select.
    with Session(create_engine(f"sqlite:///{tmp_path / 'db.db'}")) as s:
        read = [ind.model_dump() for ind in s.exec(select(Individual).order_by(Individual.id))]
    assert read == written
    assert read[0]["genotype_"] == [[1, 2], [3, 4]] and read[1]["tags_"] == {"n": [1, 2]}
    assert read[0]["time_of_birth"] == read[0]["time_of_death"] == 7
    columns = {
        r[1] for r in sqlite3.connect(tmp_path / "db.db").execute("PRAGMA table_info(individual)")
    }
    assert columns == {
        "id", "alive", "time_of_birth", "time_of_death", "requires_eval", "fitness_",
        "requires_init", "genotype_", "tags_",
    }  # fmt: skip


def test_tags_changed_in_place_are_saved(tmp_path: Path) -> None:
    @EAOperation
    def mark(population: Population) -> Population:
        for ind in population:
            ind.tags["seen"] = ind.tags.get("seen", 0) + 1  # in place, as upstream's guide does
        return population

    ea = EA(Population([_ind([1.0], 1.0)]), [mark], num_steps=3, db_file_path=tmp_path / "d.db")
    ea.run()
    assert Archive(tmp_path / "d.db").best_individual("max").tags == {"seen": 3}


# -- Population ------------------------------------------------------------------------------


def test_population_queries_return_new_populations() -> None:
    a, b, c, d = _ind([1], 1.0), _ind([2], 5.0), _ind([3]), _ind([4], -2.0)
    d.alive = False
    pop = Population([a, b, c, d])
    assert pop.alive.to_list() == [a, b, c] and pop.dead.to_list() == [d]
    assert pop.evaluated.to_list() == [a, b, d] and pop.unevaluated.to_list() == [c]
    assert pop.where(lambda i: i.genotype[0] > 2).to_list() == [c, d]
    assert isinstance(pop[1:], Population) and isinstance(pop + pop, Population)
    assert pop[0] is a and len(pop + pop) == 8 and pop.size == 4 and repr(pop) == "Population(n=4)"
    assert pop.to_list() == [a, b, c, d]  # the original is untouched by every query
    assert Population.empty().size == 0 and not Population.empty()


def test_sort_and_best_put_unevaluated_last_in_both_directions() -> None:
    a, b, c, d = _ind([1], 1.0), _ind([2], 5.0), _ind([3]), _ind([4], -2.0)
    pop = Population([a, b, c, d])
    assert pop.sort(sort="max").to_list() == [b, a, d, c]
    assert pop.sort(sort="min").to_list() == [d, a, b, c]  # upstream puts c first here
    assert pop.best(sort="min", n=2).to_list() == [d, a]
    assert pop.best(attribute="fitness", n=4).to_list() == [b, a, d, c]  # property raising: last
    assert pop.best(sort="max", attribute="time_of_birth", n=1).to_list() == [a]  # ties: stable
    with pytest.raises(ValueError, match="sort must be 'max' or 'min'"):
        pop.sort(sort="best")  # type: ignore[arg-type]


def test_sort_with_key_is_list_sort_in_place() -> None:
    pop = Population([_ind([3], 3.0), _ind([1], 1.0), _ind([2], 2.0)])
    assert pop.sort(key=lambda i: i.fitness, reverse=True) is None
    assert [i.fitness for i in pop] == [3.0, 2.0, 1.0]


def test_sample_and_shuffle_repeat_with_a_seed() -> None:
    pop = Population(_ind([i], float(i)) for i in range(20))
    first = [i.genotype for i in pop.sample(5, seed=7)]
    assert first == [i.genotype for i in pop.sample(5, seed=7)]
    assert len({g[0] for g in first}) == 5  # without replacement
    assert len(pop.sample(50)) == 20
    random.seed(1)
    again = [i.genotype for i in pop.shuffle()]
    random.seed(1)
    assert [i.genotype for i in pop.shuffle()] == again  # None: Python's random, as upstream
    assert sorted(again) == sorted(i.genotype for i in pop)


# -- EAOperation -----------------------------------------------------------------------------


def test_eaoperation_binds_arguments_and_runs_on_a_population() -> None:
    @EAOperation
    def scale(population: Population, factor: float = 2.0) -> Population:
        for ind in population:
            ind.fitness = ind.fitness * factor
        return population

    bound = scale(factor=10.0)
    assert isinstance(bound, EAOperation) and repr(bound) == "scale(factor=10.0)"
    out = bound(Population([_ind([1], 1.5)]))
    assert isinstance(out, Population) and out[0].fitness == 15.0
    assert scale(Population([_ind([1], 1.5)]))[0].fitness == 3.0  # defaults
    with pytest.raises(TypeError, match="scale"):
        scale(nonsense=1)  # wrong keyword: caught when configuring


def test_eaoperation_checks_annotations_and_result() -> None:
    def untyped(population, k=1):  # type: ignore[no-untyped-def]
        return population

    def returns_int(population: Population) -> int:
        return 1

    def postponed(population: "Population") -> "Population":  # noqa: UP037
        return population

    with pytest.raises(TypeError, match="first argument as Population"):
        EAOperation(untyped)
    with pytest.raises(TypeError, match="return as Population"):
        EAOperation(returns_int)
    EAOperation(postponed)  # string annotations are accepted (upstream refuses them)

    @EAOperation
    def forgets_return(population: Population) -> Population:
        population.append(_ind([1]))  # and returns None

    with pytest.raises(TypeError, match="returned NoneType; it must return the Population"):
        forgets_return(Population())


def test_eastep_accepts_both_upstream_forms() -> None:
    def double(population: Population, k: int = 2) -> Population:
        return Population(list(population) * k)

    assert len(EAStep("double", double)(Population([_ind([1])]))) == 2
    assert len(EAStep(double, k=3)(Population([_ind([1])]))) == 3


# -- EA --------------------------------------------------------------------------------------


def test_ea_improves_and_records_lifetimes(tmp_path: Path) -> None:
    ea = _run_ea(tmp_path)
    assert ea.current_generation == 5 and ea.size == 6
    best, worst = ea.get_solution("best"), ea.get_solution("worst")
    median = ea.get_solution("median")
    assert best.fitness >= median.fitness >= worst.fitness  # maximising (config default)
    archive = Archive(tmp_path / "db.db")
    assert best.fitness == archive.best_individual("max").fitness
    assert archive.generation_range == (0, 5) and archive.size == 6 + 5 * 3
    for gen in range(6):  # the population at the end of each generation has 6 members
        alive_at_end = [i for i in archive.by_generation(gen) if i.time_of_death > gen or i.alive]
        assert len(alive_at_end) == 6
    children = archive.by_generation(5).where(lambda i: "parent" in i.tags)
    assert all(i.time_of_birth >= 1 for i in children)


def test_get_solution_respects_minimisation(tmp_path: Path) -> None:
    pop = Population([_ind([1], 3.0), _ind([2], 1.0), _ind([3], 2.0)])
    ea = EA(pop, [evaluate], num_steps=0, db_file_path=tmp_path / "a.db", is_maximisation=False)
    assert [ea.get_solution(m).fitness for m in ("best", "median", "worst")] == [1.0, 2.0, 3.0]
    ea.is_maximisation = True  # upstream had these two the wrong way round
    assert [ea.get_solution(m).fitness for m in ("best", "worst")] == [3.0, 1.0]
    with pytest.raises(ValueError, match="mode must be"):
        ea.get_solution("top")  # type: ignore[arg-type]


def test_ea_reads_the_module_config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "is_maximisation", False)
    monkeypatch.setattr(config, "num_steps", 2)
    monkeypatch.setattr(config, "output_folder", tmp_path / "out")
    ea = EA(Population([_ind([1], 2.0), _ind([2], 1.0)]), [evaluate], quiet=True)
    assert ea.num_steps == 2 and ea.get_solution().fitness == 1.0
    assert ea.db_file_path == tmp_path / "out" / "database.db" and ea.db_file_path.is_file()
    assert ariel.ec.config is config


def test_same_seed_same_run(tmp_path: Path) -> None:
    a, b = _run_ea(tmp_path, "a.db"), _run_ea(tmp_path, "b.db")
    rows_a = [i.model_dump() for i in Archive(tmp_path / "a.db").by_generation(5)]
    rows_b = [i.model_dump() for i in Archive(tmp_path / "b.db").by_generation(5)]
    assert rows_a == rows_b and a.get_solution().fitness == b.get_solution().fitness


def test_restart_continues_from_the_population_at_the_end_of_a_generation(
    tmp_path: Path,
) -> None:
    _run_ea(tmp_path, "first.db", steps=4)
    ea = EA(
        None,
        [offspring(sigma=0.3), evaluate, truncate(keep=6)],
        restart=(tmp_path / "first.db", 2),
        num_steps=1,
        db_file_path=tmp_path / "second.db",
        quiet=True,
    )
    assert ea.current_generation == 3 and len(ea.population) == 6  # not those killed in gen 2
    survivors = Archive(tmp_path / "first.db").by_generation(3)
    expected = sorted(i.fitness for i in survivors if i.time_of_birth <= 2)
    assert sorted(i.fitness for i in ea.population) == expected
    ea.run()
    assert ea.current_generation == 4 and ea.size == 6


def test_ea_bad_input_gives_one_line_errors(tmp_path: Path) -> None:
    pop = Population([_ind([1], 1.0)])
    with pytest.raises(ValueError, match="operations is required"):
        EA(pop, None, db_file_path=tmp_path / "x.db")
    with pytest.raises(ValueError, match="initial population, or restart"):
        EA(None, [evaluate], db_file_path=tmp_path / "x.db")
    with pytest.raises(ValueError, match="also this run's db_file_path"):
        EA(None, [evaluate], restart=tmp_path / "x.db", db_file_path=tmp_path / "x.db")
    with pytest.raises(FileNotFoundError, match="restart database not found"):
        EA(None, [evaluate], restart=tmp_path / "missing.db", db_file_path=tmp_path / "x.db")
    with pytest.raises(ValueError, match="db_handling must be 'delete' or 'halt'"):
        EA(pop, [evaluate], db_file_path=tmp_path / "x.db", db_handling="keep")  # type: ignore
    EA(pop, [evaluate], db_file_path=tmp_path / "x.db", quiet=True)
    with pytest.raises(FileExistsError, match="db_handling is 'halt'"):
        EA(pop, [evaluate], db_file_path=tmp_path / "x.db", db_handling="halt")


def test_easettings_defaults_and_env_override(monkeypatch: pytest.MonkeyPatch) -> None:
    s = EASettings()
    assert (s.quiet, s.is_maximisation, s.num_steps, s.target_population_size) == (
        False,
        True,
        100,
        100,
    )
    assert s.db_file_path == Path.cwd() / "__data__" / "database.db" and s.db_handling == "delete"
    monkeypatch.setenv("ARIEL_EC_NUM_STEPS", "7")
    monkeypatch.setenv("NUM_STEPS", "9")  # upstream's bare name is not read
    assert EASettings().num_steps == 7
    with pytest.raises(ValueError, match="db_handling"):
        EASettings(db_handling="keep")  # type: ignore[arg-type]
    monkeypatch.setenv("ARIEL_EC_NUM_STEPS", "abc")  # was pydantic's 4 lines and a web link
    with pytest.raises(
        ValueError, match=r"^ariel.ec config num_steps \(ARIEL_EC_NUM_STEPS\): .*'abc'$"
    ):
        EASettings()
    with pytest.raises(
        ValueError, match=r"^ariel.ec config num_steps .*equal to 0; got -1$"
    ) as error:
        config.num_steps = -1
    assert "\n" not in str(error.value) and config.num_steps >= 0


def test_archive_queries_repeat_with_a_seed(tmp_path: Path) -> None:
    _run_ea(tmp_path)
    archive = Archive(tmp_path / "db.db")
    fits = [i.fitness for i in archive.random_population(5, seed=3)]
    assert fits == [i.fitness for i in archive.random_population(5, seed=3)] and len(fits) == 5
    hof = archive.hall_of_fame(4, "max")
    assert [i.fitness for i in hof] == sorted((i.fitness for i in hof), reverse=True)
    assert all(i.id is None for i in hof)  # fresh copies, ready to re-insert
    winners = archive.tournament_population(3, tournament_size=2, fitness_mode="max", seed=1)
    assert len(winners) == 3
    stats = archive.fitness_stats()
    assert stats["min"] <= stats["median"] <= stats["max"] == hof[0].fitness
    band = archive.fitness_percentile_population(25, 75)
    assert all(stats["min"] <= i.fitness <= stats["max"] for i in band) and 0 < len(band) < 21
    with pytest.raises(FileNotFoundError, match="archive database not found"):
        Archive(tmp_path / "nope.db")


def test_individuals_from_another_run_seed_a_new_run(tmp_path: Path) -> None:
    first = _run_ea(tmp_path, "first.db", steps=2)
    champion = first.get_solution()
    second = EA(Population([champion]), [evaluate], num_steps=1, db_file_path=tmp_path / "b.db")
    second.run()  # upstream: StaleDataError (it UPDATEs a row of the first database)
    (copy,) = Archive(tmp_path / "b.db").by_generation(1)
    assert (copy.fitness, copy.genotype, copy.time_of_birth) == (
        champion.fitness,
        champion.genotype,
        0,
    )


def test_a_population_that_cannot_be_saved_leaves_the_old_database_whole(tmp_path: Path) -> None:
    """The default db_handling="delete" removed the old file before the population was
    checked: a malformed population cost a whole earlier run."""
    _run_ea(tmp_path, "keep.db", steps=1)

    def rows() -> int:
        with sqlite3.connect(tmp_path / "keep.db") as db:
            return db.execute("select count(*) from individual").fetchone()[0]

    before = rows()
    with pytest.raises(TypeError, match=r"population\[0\] must be an Individual, not int"):
        EA([1, 2], [evaluate], quiet=True, db_file_path=tmp_path / "keep.db")  # type: ignore
    with pytest.raises(ValueError, match=r"cannot save the population to .*keep.db: ") as error:
        EA([Individual(alive="x")], [evaluate], quiet=True, db_file_path=tmp_path / "keep.db")
    assert "\n" not in str(error.value) and before == rows() > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.db"]  # no half-made file left
    EA(Population([_ind([1.0], 1.0)]), [evaluate], quiet=True, db_file_path=tmp_path / "keep.db")
    assert rows() == 1  # a good population still replaces it


@pytest.mark.parametrize("content", [b"", b"not a database\n" * 40])
def test_a_file_that_is_not_an_ea_database_is_one_line(tmp_path: Path, content: bytes) -> None:
    bad = tmp_path / "bad.db"
    bad.write_bytes(content)
    for call in (
        lambda: Archive(bad),
        lambda: EA(None, [evaluate], restart=bad, db_file_path=tmp_path / "new.db"),
    ):
        with pytest.raises(ValueError, match="is not an EA database ariel can read") as error:
            call()
        assert "\n" not in str(error.value) and "sqlalche.me" not in str(error.value)


def test_archive_counts_are_whole_numbers_from_zero(tmp_path: Path) -> None:
    _run_ea(tmp_path, steps=1)
    archive = Archive(tmp_path / "db.db")
    with pytest.raises(ValueError, match="n must be a whole number >= 0, not -1"):
        archive.hall_of_fame(-1)  # SQL's LIMIT -1 returned every individual
    assert len(archive.tournament_population(0)) == 0
    assert len(archive.hall_of_fame(np.int64(2))) == 2


def test_replacing_a_database_drops_its_old_write_ahead_log(tmp_path: Path) -> None:
    """Another program's WAL beside the old file was applied to the new one: 53 rows read back
    where 2 were saved. A folder as db_file_path left a hidden half-made file beside it."""
    _run_ea(tmp_path, "wal.db", steps=1)
    with sqlite3.connect(tmp_path / "wal.db") as db:
        db.execute("pragma journal_mode=wal")
    writer = sqlite3.connect(tmp_path / "wal.db")
    writer.execute("pragma wal_autocheckpoint=0")
    writer.executemany(
        "insert into individual (alive, time_of_birth, time_of_death, requires_eval, "
        "requires_init, tags_) values (1, 0, 0, 1, 1, '{}')",
        [()] * 50,
    )
    writer.commit()
    assert (tmp_path / "wal.db-wal").stat().st_size > 0
    EA(
        Population([_ind([1.0], 1.0), _ind([2.0], 2.0)]),
        [evaluate],
        quiet=True,
        db_file_path=tmp_path / "wal.db",
    )
    writer.close()
    with sqlite3.connect(tmp_path / "wal.db") as db:
        assert db.execute("select count(*) from individual").fetchone()[0] == 2
    (tmp_path / "adir.db").mkdir()
    with pytest.raises(IsADirectoryError, match="is a folder: name a database file"):
        EA(
            Population([_ind([1.0], 1.0)]),
            [evaluate],
            quiet=True,
            db_file_path=tmp_path / "adir.db",
        )
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_archive_queries_take_numpy_integers_and_refuse_a_foreign_table(tmp_path: Path) -> None:
    _run_ea(tmp_path, steps=2)
    archive = Archive(tmp_path / "db.db")
    assert len(archive.by_generation(np.int64(0))) == len(archive.by_generation(0)) > 0
    window = (np.int64(0), np.int64(1))
    assert (
        len(archive.hall_of_fame(50, birth_range=window))
        == len(archive.hall_of_fame(50, birth_range=(0, 1)))
        > 0
    )
    foreign = tmp_path / "foreign.db"
    with sqlite3.connect(foreign) as db:
        db.execute("create table individual (name text)")
    with pytest.raises(ValueError, match="is not an EA database ariel can read") as error:
        Archive(foreign)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("bounds", [(0, float("nan")), (0,), (None, 1), (5, 1)])
def test_an_archive_range_that_is_no_range_is_one_line(tmp_path: Path, bounds: object) -> None:
    """(0, nan) matched nothing without a word; (0,) and (None, 1) were Python's own errors."""
    _run_ea(tmp_path, steps=1)
    with pytest.raises(ValueError, match="range must be \\(low, high\\)"):
        Archive(tmp_path / "db.db").hall_of_fame(5, birth_range=bounds)  # type: ignore[arg-type]
