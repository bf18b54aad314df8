"""An upstream-style script: morphology-only evolution of CPPN bodies (as upstream's
examples/c_genotypes/5_body_evolution_cppn.py, tiny), run end to end headless."""

from __future__ import annotations

import random

import numpy as np

from ariel.body_phenotypes.robogen_lite.config import NUM_OF_ROTATIONS, NUM_OF_TYPES_OF_MODULES
from ariel.body_phenotypes.robogen_lite.constructor import construct_mjspec_from_graph
from ariel.body_phenotypes.robogen_lite.cppn_neat.genome import Genome
from ariel.body_phenotypes.robogen_lite.cppn_neat.id_manager import IdManager
from ariel.body_phenotypes.robogen_lite.decoders.cppn_best_first import (
    MorphologyDecoderBestFirst,
)
from ariel.simulation.environments import SimpleFlatWorld
from ariel.utils.morphological_descriptor import MorphologicalMeasures

NUM_CPPN_INPUTS = 6
NUM_CPPN_OUTPUTS = 1 + NUM_OF_TYPES_OF_MODULES + NUM_OF_ROTATIONS + 1  # upstream's spare output
NUM_MODULES = 10


def score(genome: Genome) -> float:
    graph = MorphologyDecoderBestFirst(cppn_genome=genome, max_modules=NUM_MODULES).decode()
    m = MorphologicalMeasures(graph)
    return 0.2 * (m.symmetry + m.joints + m.branching + m.length_of_limbs + m.module_diversity)


def evolve(seed: int, pop_size: int = 8, generations: int = 4) -> tuple[list[float], Genome]:
    random.seed(seed)  # upstream scripts seed Python's random; the genome draws from it
    ids = IdManager(
        node_start=NUM_CPPN_INPUTS + NUM_CPPN_OUTPUTS - 1,
        innov_start=NUM_CPPN_INPUTS * NUM_CPPN_OUTPUTS - 1,
    )
    population = []
    for _ in range(pop_size):
        g = Genome.random(NUM_CPPN_INPUTS, NUM_CPPN_OUTPUTS, NUM_CPPN_INPUTS + NUM_CPPN_OUTPUTS, 0)
        for _ in range(3):
            g.mutate(0.6, 0.6, ids.get_next_innov_id, ids.get_next_node_id)
        g.fitness = score(g)
        population.append(g)
    best_per_generation = []
    for _ in range(generations):
        population.sort(key=lambda g: g.fitness, reverse=True)
        parents = population[: pop_size // 2]
        children = []
        while len(parents) + len(children) < pop_size:
            a, b = random.sample(parents, 2)
            child = a.crossover(b)
            child.mutate(0.2, 0.3, ids.get_next_innov_id, ids.get_next_node_id)
            child.fitness = score(child)
            children.append(child)
        population = parents + children
        best_per_generation.append(max(g.fitness for g in population))
    return best_per_generation, max(population, key=lambda g: g.fitness)


def test_cppn_body_evolution_runs_and_keeps_its_best() -> None:
    curve, best = evolve(seed=42)
    assert len(curve) == 4 and all(0.0 <= v <= 1.0 for v in curve)
    assert curve == sorted(curve)  # elitist: the best never gets worse
    assert evolve(seed=42)[0] == curve  # random.seed(42) repeats the run
    graph = MorphologyDecoderBestFirst(best, max_modules=NUM_MODULES).decode()
    world = SimpleFlatWorld()
    world.spawn(construct_mjspec_from_graph(graph).spec, position=(-0.8, 0, 0.1))
    model = world.spec.compile()
    assert model.nbody > len(graph) and np.isfinite(model.body_mass).all()
