"""The ``random`` body optimizer: new random genotypes every generation, the best kept."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _helpers import table_digests

from ariel.evolution import BodyConfig, RandomSearch
from ariel.evolution._ga import random_proposals
from ariel.evolution._optimizer_checks import _VectorEncoder
from ariel.evolution._progress import Progress
from ariel.evolution._state import Body
from ariel.plugins import body_optimizers
from ariel.recording import load_run, make_report
from ariel.runs import resume_experiment, run_experiment

SETTINGS = BodyConfig(population=3, offspring=4)


def _told(proposals, first: int, generation: int) -> list[Body]:
    """Bodies of ``proposals``; fitness -|genotype|^2 (the first one's failed)."""
    bodies = []
    for k, proposal in enumerate(proposals):
        body = Body(first + k, proposal.genotype, list(proposal.parent_ids), generation)
        body.fitness = -float(np.sum(np.square(proposal.genotype)))
        bodies.append(body)
    bodies[0].fitness, bodies[0].status = -math.inf, "error"
    return bodies


def test_every_generation_is_new_random_bodies_and_the_best_are_kept() -> None:
    assert body_optimizers.get("random") is RandomSearch
    encoder = _VectorEncoder()
    search = RandomSearch(encoder=encoder, seed=5, maximise=True, settings=SETTINGS)
    first = search.ask(3)
    # generation 0 is every optimizer's generation 0 (the same draws as the GA's)
    assert [p.genotype for p in first] == [p.genotype for p in random_proposals(encoder, 5, 3)]
    seen, told = set(), []
    asks = [first] + [None] * 4
    for generation in range(5):
        proposals = asks[generation] or search.ask(4)
        assert search.ask(len(proposals)) == proposals  # asking changes nothing
        genotypes = {json.dumps(p.genotype) for p in proposals}
        assert len(genotypes) == len(proposals) and not genotypes & seen  # never drawn before
        seen |= genotypes
        assert all(p.parent_ids == [] for p in proposals)  # never bred
        bodies = _told(proposals, len(told), generation)
        told += bodies
        search.tell(bodies)
        best = sorted(told, key=lambda b: (-b.fitness, b.number))[:3]
        assert search.population == best  # the best 3 seen, failed ones never among them
    state = json.loads(json.dumps(search.state()))
    again = RandomSearch(encoder=encoder, seed=5, maximise=True, settings=SETTINGS)
    again.restore(state, search.population)
    assert again.ask(4) == search.ask(4)


def test_it_takes_no_options() -> None:
    with pytest.raises(TypeError, match=r"random takes no body\.optimizer_options"):
        RandomSearch(encoder=None, seed=0, maximise=True, settings=SETTINGS, bins=[2])


RANDOM = {
    "name": "random",
    "seed": 2,
    "generations": 3,
    "body": {
        "optimizer": "random",
        "options": {"number_of_modules": 6},
        "population": 2,
        "offspring": 3,
    },
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.3},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


def test_a_random_search_run_keeps_its_best_reports_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference = tmp_path / "reference"
    run_experiment(RANDOM, out=reference)
    run = load_run(reference)
    bodies = run.bodies
    assert (bodies["parent_ids"].map(len) == 0).all()
    assert bodies["body_genotype"].nunique() == 2 + 2 * 3  # every body a new genotype
    for generation, group in bodies.groupby("generation"):
        kept = group[group["selected"]]
        assert len(kept) == 2
        left = group[~group["selected"]]
        assert generation == 0 or kept["fitness"].min() >= left["fitness"].max()
        seen = bodies[bodies["generation"] <= generation].drop_duplicates("body_id")
        assert kept["fitness"].max() == seen["fitness"].max()  # the best so far is kept
    assert np.all(np.diff(run.generations["best_fitness"]) >= 0)
    assert make_report(reference, render=False).written

    original = Progress.end_generation

    def stop_after_generation_one(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        if generation == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "end_generation", stop_after_generation_one)
    out = tmp_path / "again" / "reference"  # the folder name is the run id, in every row
    with pytest.raises(KeyboardInterrupt):
        run_experiment(RANDOM, out=out)
    monkeypatch.setattr(Progress, "end_generation", original)
    assert resume_experiment(out).status == "finished"
    assert table_digests(out) == table_digests(reference)
