"""Registry-driven tests: every registered world, controller, fitness function and body encoder
is exercised here the day it is registered (the parametrisation reads the registries)."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate, evaluate_batch
from ariel.plugins import body_encoders, controllers, fitness_functions, worlds

GECKO = BodySpec("prebuilt", "gecko")


def random_params(controller: str, world: str = "flat", seed: int = 0) -> np.ndarray:
    model = build(EvaluationTask(body=GECKO, world=world)).model
    plugin = controllers.make(controller)
    return plugin.random_parameters(model, np.random.default_rng(seed), 1)[0]


@pytest.mark.parametrize("world", worlds.names())
def test_every_world_runs_the_gecko(world: str) -> None:
    result = evaluate(
        EvaluationTask(body=GECKO, world=world, params=random_params("na_cpg"), duration=1.0)
    )
    assert result.status == "ok", result.error
    assert math.isfinite(result.fitness)
    assert np.all(np.isfinite(result.core_pos))


@pytest.mark.parametrize("controller", controllers.names())
def test_every_controller_drives_the_gecko_deterministically(controller: str) -> None:
    plugin = controllers.make(controller)
    model = build(EvaluationTask(body=GECKO)).model
    assert isinstance(plugin.open_loop, bool)
    params = plugin.random_parameters(model, np.random.default_rng(1), 3)
    assert params.shape == (3, plugin.num_parameters(model))
    tasks = [
        EvaluationTask(body=GECKO, controller=controller, params=p, duration=1.0) for p in params
    ]
    first, again = evaluate_batch(tasks, nthread=2), evaluate_batch(tasks, nthread=1)
    for a, b in zip(first, again):
        assert a.status == "ok", a.error
        assert a.fitness == b.fitness
        np.testing.assert_array_equal(a.joint_angle, b.joint_angle)
    assert np.ptp(first[0].joint_angle, axis=0).max() > 1e-3  # the joints moved


@pytest.mark.parametrize("fitness", fitness_functions.names())
def test_every_fitness_function_scores_a_run(fitness: str) -> None:
    fn = fitness_functions.get(fitness)
    assert isinstance(fn.maximise, bool)
    result = evaluate(
        EvaluationTask(body=GECKO, fitness=fitness, params=random_params("na_cpg"), duration=1.0)
    )
    assert result.status == "ok", result.error
    assert isinstance(result.fitness, float) and math.isfinite(result.fitness)


@pytest.mark.parametrize("encoder", body_encoders.names())
def test_every_body_encoder_round_trips_plain_data(encoder: str) -> None:
    plugin = body_encoders.make(encoder)
    rng = np.random.default_rng(0)
    if encoder == "graph":
        from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS

        genotype = nx.node_link_data(PREBUILT_GRAPHS["spider"](), edges="edges")
    else:
        genotype = plugin.random_genotype(rng)
    graph = plugin.decode(genotype)
    assert nx.is_arborescence(graph) and 0 in graph
    child = plugin.mutate(plugin.crossover(genotype, genotype, rng), rng)
    assert nx.is_arborescence(plugin.decode(child))
    result = evaluate(EvaluationTask(body=BodySpec(encoder, genotype), duration=0.5))
    assert result.status in ("ok", "error")  # params () only fit a body without hinges
    if result.status == "error":
        assert "parameters" in result.error


def test_nde_encoder_is_seeded_and_mutation_changes_genes() -> None:
    nde = body_encoders.make("nde", number_of_modules=12)
    a = nde.random_genotype(np.random.default_rng(4))
    assert a.shape == (3, 64) and a.dtype == np.float32
    np.testing.assert_array_equal(a, nde.random_genotype(np.random.default_rng(4)))
    mutated = nde.mutate(a, np.random.default_rng(5))
    assert mutated.shape == a.shape and not np.array_equal(mutated, a)
    assert nx.utils.graphs_equal(nde.decode(a), nde.decode(a.tolist()))
    assert nde.decode(a).number_of_nodes() <= 12


def test_prebuilt_encoder_rejects_unknown_bodies() -> None:
    with pytest.raises(ValueError, match=r"unknown prebuilt body .dragon.; known: .*gecko"):
        body_encoders.make("prebuilt").build("dragon")


def test_a_third_party_fitness_plugin_from_an_entry_point_is_used_in_an_evaluation(
    fake_distribution,
) -> None:
    fake_distribution(
        "ariel_height_plugin",
        "1.2",
        source="""
            def mean_core_height(record):
                return float(record.core_pos[:, 2].mean())

            mean_core_height.maximise = True
        """,
        entry_points={
            "ariel.fitness": {"mean_core_height": "ariel_height_plugin:mean_core_height"}
        },
    )
    assert "mean_core_height" in fitness_functions.names()
    result = evaluate(
        EvaluationTask(
            body=GECKO,
            fitness="mean_core_height",
            params=random_params("na_cpg"),
            duration=1.0,
        )
    )
    assert result.status == "ok"
    assert result.fitness == pytest.approx(result.core_pos[:, 2].mean())
    provenance = fitness_functions.provenance("mean_core_height")
    assert provenance["distribution"] == "ariel_height_plugin==1.2"
