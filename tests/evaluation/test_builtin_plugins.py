"""Registry-driven tests: every registered body encoder, world, controller and fitness function
goes through its `ariel.plugins` checker the day it is registered (the parametrisation reads
the registries), plus the built-ins' own promises."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate
from ariel.plugins import (
    body_encoders,
    body_optimizers,
    brain_optimizers,
    check_all,
    check_body_encoder,
    check_controller,
    check_fitness,
    check_world,
    controllers,
    fitness_functions,
    worlds,
)

GECKO = BodySpec("prebuilt", "gecko")


def random_params(controller: str, world: str = "flat", seed: int = 0) -> np.ndarray:
    model = build(EvaluationTask(body=GECKO, world=world)).model
    plugin = controllers.make(controller)
    return plugin.random_parameters(model, np.random.default_rng(seed), 1)[0]


@pytest.mark.parametrize("name", body_encoders.names())
def test_every_body_encoder_keeps_its_contract(name: str) -> None:
    check_body_encoder(name)


@pytest.mark.parametrize("name", worlds.names())
def test_every_world_keeps_its_contract(name: str) -> None:
    check_world(name)


@pytest.mark.parametrize("name", controllers.names())
def test_every_controller_keeps_its_contract(name: str) -> None:
    check_controller(name)


@pytest.mark.parametrize("name", fitness_functions.names())
def test_every_fitness_function_keeps_its_contract(name: str) -> None:
    check_fitness(name)


def test_checkers_take_plugin_options() -> None:
    check_body_encoder("nde", number_of_modules=8, genotype_size=16)
    check_world("rugged", seed=3)
    check_controller("na_cpg", coupling="none")
    check_controller("mlp", hidden=4)
    check_fitness("distance_to_target", target=[1.0, 1.0])


def test_check_all_reports_every_registered_name() -> None:
    report = check_all()
    expected = [
        (kind, name)
        for kind, registry in (
            ("body_encoder", body_encoders),
            ("world", worlds),
            ("controller", controllers),
            ("fitness", fitness_functions),
            ("body_optimizer", body_optimizers),
            ("brain_optimizer", brain_optimizers),
        )
        for name in registry.names()
    ]
    assert [(kind, name) for kind, name, _ in report] == expected
    assert [row for row in report if row[2] is not None] == []


def test_only_nde_bodies_can_evolve() -> None:
    assert body_encoders.make("nde").evolvable is True
    rng = np.random.default_rng(0)
    for name in ("prebuilt", "graph"):
        encoder = body_encoders.make(name)
        assert encoder.evolvable is False
        genotype = encoder.random_genotype(rng)
        message = f"body encoder '{name}' cannot vary its genotypes"
        with pytest.raises(NotImplementedError, match=message):
            encoder.mutate(genotype, rng)
        with pytest.raises(NotImplementedError, match=message):
            encoder.crossover(genotype, genotype, rng)


def test_graph_bodies_evaluate_like_the_prebuilt_ones() -> None:
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_GRAPHS

    spider = nx.node_link_data(PREBUILT_GRAPHS["spider"](), edges="edges")
    params = random_params("na_cpg")
    from_graph = evaluate(EvaluationTask(body=BodySpec("graph", spider), params=params))
    prebuilt = evaluate(EvaluationTask(body=BodySpec("prebuilt", "spider"), params=params))
    assert from_graph.status == "ok"
    assert from_graph.descriptors == prebuilt.descriptors


def test_nde_encoder_is_seeded_and_mutation_changes_genes() -> None:
    nde = body_encoders.make("nde", number_of_modules=12)
    a = nde.random_genotype(np.random.default_rng(4))
    assert a.shape == (3, 64) and a.dtype == np.float32
    mutated = nde.mutate(a, np.random.default_rng(5), mutation_rate=0.25)
    changed = (mutated != a).mean()
    assert 0.1 < changed < 0.4  # about a quarter of the genes moved
    assert nde.decode(a).number_of_nodes() <= 12
    with pytest.raises(ValueError, match="3 chromosomes of 64 genes"):
        nde.mutate(a[:2], np.random.default_rng(5))


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
