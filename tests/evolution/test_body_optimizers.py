"""Body optimizers as plugins: every registered one passes its check, broken ones fail it with
one line, and a third-party optimizer from an entry point runs a co-evolution experiment."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ariel.errors import PluginCheckError
from ariel.plugins import body_optimizers, check_body_optimizer
from ariel.recording import load_run
from ariel.runs import run_experiment


@pytest.mark.parametrize("name", body_optimizers.names())
def test_every_registered_body_optimizer_passes_its_check(name: str) -> None:
    check_body_optimizer(name)


def test_the_builtins_are_named_by_module_and_class() -> None:
    assert body_optimizers.provenance("ga")["object"] == "ariel.evolution._ga:GeneticAlgorithm"
    assert body_optimizers.provenance("map_elites")["object"] == (
        "ariel.evolution._map_elites:MapElites"
    )
    assert body_optimizers.provenance("random")["object"] == (
        "ariel.evolution._random_search:RandomSearch"
    )


# A third-party optimizer: random search, the best `population` bodies kept.
RANDOM_SEARCH = """
from ariel.evolution import Proposal, derive_rng


class RandomSearch:
    def __init__(self, *, encoder, seed, maximise, settings, keep=2):
        self.encoder, self.seed, self.maximise, self.keep = encoder, seed, maximise, keep
        self.generation = 0
        self._population = []

    @property
    def population(self):
        return list(self._population)

    def ask(self, n):
        draws = [derive_rng(self.seed, "rs", self.generation, j) for j in range(n)]
        return [Proposal(self.encoder.random_genotype(rng), []) for rng in draws]

    def tell(self, bodies):
        sign = -1.0 if self.maximise else 1.0
        pool = [b for b in self._population + list(bodies) if b.fitness == b.fitness]
        pool.sort(key=lambda b: (sign * b.fitness, b.number))
        self._population = pool[: self.keep]
        self.generation += 1

    def state(self):
        return {"generation": self.generation}

    def restore(self, state, population):
        self.generation = state["generation"]
        self._population = list(population)


class Forgetful(RandomSearch):
    def tell(self, bodies):
        self.generation += 1  # keeps nothing


class Unseeded(RandomSearch):
    def ask(self, n):
        import numpy as np

        return [Proposal(np.random.uniform(-1, 1, 4).tolist(), []) for _ in range(n)]
"""
PKG = "ariel_test_random_search"


@pytest.fixture
def random_search(fake_distribution) -> str:
    fake_distribution(
        PKG,
        source=RANDOM_SEARCH,
        entry_points={
            "ariel.body_optimizers": {
                "random_search": f"{PKG}:RandomSearch",
                "forgetful": f"{PKG}:Forgetful",
                "unseeded": f"{PKG}:Unseeded",
            }
        },
    )
    return "random_search"


def test_a_third_party_optimizer_runs_an_experiment(random_search: str, tmp_path: Path) -> None:
    assert random_search in body_optimizers.names()
    check_body_optimizer(random_search)
    config = {
        "name": "rs",
        "seed": 3,
        "generations": 3,
        "body": {
            "optimizer": random_search,
            "optimizer_options": {"keep": 2},
            "options": {"number_of_modules": 6},
            "population": 3,
            "offspring": 3,
        },
        "brain": {"popsize": 2, "iterations": 1},
        "task": {"duration": 0.3},
        "record": {"rerun": False},
        "executor": {"kind": "serial"},
    }
    run_experiment(config, out=tmp_path / "run")
    run = load_run(tmp_path / "run")
    bodies = run.bodies
    assert set(bodies[bodies["is_new"]]["parent_ids"].map(len)) == {0}  # random search
    for _, group in bodies.groupby("generation"):
        kept = group[group["selected"]]
        assert len(kept) == 2
        assert kept["fitness"].min() >= group[~group["selected"]]["fitness"].max()
    provenance = json.loads((tmp_path / "run" / "run.json").read_text())["plugins"]
    assert provenance["body_optimizer"]["object"] == f"{PKG}:RandomSearch"
    assert provenance["body_optimizer"]["distribution"].startswith(PKG)


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("forgetful", "keeps no body after generation 0"),
        ("unseeded", "asks for different genotypes with the same seed"),
    ],
)
def test_a_broken_optimizer_fails_its_check_in_one_line(
    random_search: str, name: str, message: str
) -> None:
    with pytest.raises(PluginCheckError, match=f"body optimizer '{name}': {message}") as caught:
        check_body_optimizer(name)
    assert "\n" not in str(caught.value)
    np.random.seed(None)


def test_the_plugins_check_command_lists_body_optimizers(random_search: str, capsys) -> None:
    from ariel.cli import main

    assert main(["plugins", "--check"]) in (0, 1)
    out = capsys.readouterr().out
    for name in ("ga", "map_elites", "random_search"):
        assert any(name in line and "body" in line for line in out.splitlines()), name
