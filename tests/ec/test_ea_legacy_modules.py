"""Upstream's earlier EA modules (ariel.ec.a000 ... a005), still used by 2025 course material."""

from __future__ import annotations

from pathlib import Path

import pytest

import ariel.ec
from ariel.ec import a000, a001, a003, a004, a005


def test_legacy_modules_export_the_current_objects() -> None:
    assert a000.IntegerMutator is ariel.ec.IntegerMutator
    assert a000.IntegersGenerator is ariel.ec.IntegersGenerator
    assert a001.Individual is a003.Individual is a004.Individual is ariel.ec.Individual
    assert a003.Population is a004.Population is ariel.ec.Population
    assert a005.Crossover is ariel.ec.Crossover
    assert a004.EAStep is ariel.ec.EAStep


def test_a004_ea_runs_a_course_style_loop(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(a004.config, "output_folder", tmp_path)
    monkeypatch.setattr(a004.config, "target_population_size", 6)

    def evaluate(population: list) -> list:  # old style: plain lists, no annotations needed
        for ind in population:
            if ind.requires_eval:
                ind.fitness = sum(ind.genotype)
        return population

    def breed(population: list) -> list:
        for parent in list(population):
            child = a001.Individual()
            child.genotype = a000.IntegerMutator.integer_creep(parent.genotype, 1, 1.0, seed=7)
            population.append(child)
        return population

    def survive(population: list) -> list:
        ranked = sorted(population, key=lambda i: i.fitness, reverse=True)
        for ind in ranked[a004.config.target_population_size :]:
            ind.alive = False
        return population

    start = []
    for g in range(6):
        ind = a001.Individual()
        ind.genotype = [g, g]
        start.append(ind)
    ops = [a004.EAStep("breed", breed), a004.EAStep("eval", evaluate), a004.EAStep("s", survive)]
    ea = a004.EA(evaluate(start), operations=ops, num_of_generations=3, quiet=True)
    ea.run()
    assert (tmp_path / "database.db").is_file() and ea.num_of_generations == 3
    assert ea.population_size == 6
    ea.fetch_population()  # old signature: best first
    fitness = [i.fitness for i in ea.population]
    assert fitness == sorted(fitness, reverse=True)
    ea.fetch_population("last", already_evaluated=True)
    assert [i.fitness for i in ea.population] == sorted(fitness)
    assert ea.get_solution().fitness == max(fitness)
    with pytest.raises(ValueError, match="best_comes must be"):
        ea.fetch_population("middle")  # type: ignore[arg-type]
