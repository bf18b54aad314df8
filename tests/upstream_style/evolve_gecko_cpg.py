"""Evolve gecko gaits (NaCPG parameters) with upstream ARIEL's EA engine, headless.

Written the way upstream's EA guides are: tagged individuals, ``@EAOperation`` steps, the
module-level ``config``, a SQLite database per run. The one workbench-specific line is the
evaluation: it hands the unevaluated genotypes to `ariel.evaluation.evaluate_batch` (one
compiled gecko, all candidates in a threaded rollout) instead of simulating them one by one.

    python evolve_gecko_cpg.py --generations 3 --pop 6 --duration 2 --out __data__/gecko
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ariel import console
from ariel.ec import (
    EA,
    Crossover,
    EAOperation,
    FloatMutator,
    Individual,
    Population,
    config,
    set_seed,
)
from ariel.evaluation import BodySpec, EvaluationTask, evaluate_batch
from ariel.simulation.controllers.cpg_kernel import random_parameters

GECKO = BodySpec("prebuilt", "gecko")
NUM_JOINTS = 8  # the gecko's hinges: 5 CPG parameters each
TOURNAMENT_SIZE = 3


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generations", type=int, default=10)
    parser.add_argument("--pop", type=int, default=10)
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds")
    parser.add_argument("--seed", type=int, default=42)
    parser.add_argument("--out", type=Path, default=Path("__data__") / "evolve_gecko_cpg")
    return parser.parse_args()


ARGS = parse_args()
set_seed(ARGS.seed)
RNG = np.random.default_rng(ARGS.seed)
config.is_maximisation = True  # fitness: planar distance walked
config.target_population_size = ARGS.pop


def create_individual() -> Individual:
    ind = Individual()
    ind.genotype = random_parameters(NUM_JOINTS, RNG).tolist()
    return ind


@EAOperation
def evaluate(population: Population) -> Population:
    """Distance walked in ``--duration`` seconds, through the workbench's batched engine."""
    todo = population.unevaluated
    tasks = [
        EvaluationTask(body=GECKO, params=ind.genotype, duration=ARGS.duration, seed=ARGS.seed)
        for ind in todo
    ]
    for ind, result in zip(todo, evaluate_batch(tasks), strict=True):
        ind.fitness = result.fitness
        ind.tags = {"status": result.status}
    return population


@EAOperation
def parent_selection(population: Population, tournament_size: int = TOURNAMENT_SIZE) -> Population:
    for ind in population:
        ind.tags["ps"] = False
    for _ in range(len(population) // 2 * 2):
        entrants = population.sample(tournament_size, seed=RNG)
        entrants.best(sort="max")[0].tags["ps"] = True
    return population


@EAOperation
def crossover(population: Population) -> Population:
    parents = population.where(lambda ind: ind.tags.get("ps", False))
    for i in range(0, len(parents) - 1, 2):
        for genes in Crossover.uniform(parents[i].genotype, parents[i + 1].genotype, seed=RNG):
            child = Individual()
            child.genotype = genes
            child.tags = {"mut": True, "parents": [parents[i].id, parents[i + 1].id]}
            population.append(child)
    return population


@EAOperation
def mutation(population: Population, std: float = 0.3, probability: float = 0.2) -> Population:
    for ind in population.where(lambda i: i.tags.get("mut", False)):
        ind.genotype = FloatMutator.gaussian(ind.genotype, std, probability, seed=RNG)
        ind.tags = {"mut": False}
    return population


@EAOperation
def survivor_selection(population: Population) -> Population:
    """Keep the ``target_population_size`` fittest (elitist truncation)."""
    for ind in population.alive.sort(sort="max")[config.target_population_size :]:
        ind.alive = False
    return population


def main() -> None:
    ARGS.out.mkdir(parents=True, exist_ok=True)
    population = evaluate(Population([create_individual() for _ in range(ARGS.pop)]))
    ops = [parent_selection, crossover, mutation(std=0.3), evaluate, survivor_selection]
    ea = EA(
        population,
        operations=ops,
        num_steps=ARGS.generations,
        db_file_path=ARGS.out / "database.db",
        quiet=True,
    )
    start = time.perf_counter()
    ea.run()
    seconds = time.perf_counter() - start
    best = ea.get_solution("best", only_alive=False)
    console.log(f"best distance {best.fitness:.3f} m (individual {best.id})")
    summary = {"best_id": best.id, "best_fitness": best.fitness, "seconds": seconds}
    (ARGS.out / "summary.json").write_text(json.dumps(summary))


if __name__ == "__main__":
    main()
