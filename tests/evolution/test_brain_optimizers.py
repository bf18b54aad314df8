"""Brain optimizers as plugins: both built-in learners pass their check and store plain state
that continues bit for bit (a checkpoint from before the seam too), a Nevergrad run killed after
a generation resumes to the uninterrupted records, a third-party learner from an entry point
runs an experiment, and a bad ``brain.optimizer`` or option is one config error."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _helpers import table_digests

from ariel.errors import PluginCheckError
from ariel.evolution import BrainRun, ConfigError, load_config
from ariel.evolution._config import config_hash
from ariel.evolution._progress import Progress
from ariel.evolution._state import from_json_safe, to_json_safe
from ariel.plugins import brain_optimizers, check_brain_optimizer
from ariel.recording import load_run
from ariel.runs import resume_experiment, run_experiment

GECKO = Path(__file__).resolve().parents[2] / "experiments" / "gecko_gait.toml"
SMALL = [
    "generations=3",
    "brain.popsize=4",
    "brain.iterations=2",
    "task.duration=0.4",
    "record.rerun=false",
    "executor.kind=serial",
]
NEVERGRAD = [*SMALL, "brain.optimizer=nevergrad"]


@pytest.mark.parametrize(
    ("name", "options"),
    [("cmaes", {}), ("nevergrad", {}), ("nevergrad", {"method": "NGOpt", "budget": 24})],
)
def test_the_built_in_learners_pass_their_check(name: str, options: dict) -> None:
    assert {"cmaes", "nevergrad"} <= set(brain_optimizers.names())
    check_brain_optimizer(name, **options)


def _run(optimizer: str, told: int, **options) -> BrainRun:
    run = BrainRun(5, 6, True, np.zeros(5), 0.5, 7, optimizer=optimizer, options=options)
    for k in range(told):
        x = run.ask()
        fitness = -np.sum((x - 1.0) ** 2, axis=1)
        if k == 1:
            fitness[2] = np.nan  # a failed candidate
        run.tell(x, fitness)
    return run


@pytest.mark.parametrize("optimizer", ["cmaes", "nevergrad"])
def test_a_stored_run_continues_bit_for_bit(optimizer: str) -> None:
    run = _run(optimizer, 4)
    text = json.dumps(to_json_safe(run.to_plain()), allow_nan=False)
    again = BrainRun.from_plain(from_json_safe(json.loads(text)))
    assert (again.iteration, again.best_fitness) == (run.iteration, run.best_fitness)
    np.testing.assert_array_equal(again.best_params, run.best_params)
    assert again.ask().tobytes() == run.ask().tobytes()


def test_a_checkpoint_from_before_brain_optimizers_is_a_cma_es_run_told_again() -> None:
    run = _run("cmaes", 3)
    plain = run.to_plain()
    old = {k: plain[k] for k in ("n_params", "popsize", "maximise", "x0", "sigma0", "seed")}
    old["told"] = run.learner.state()["told"]  # as BrainRun.to_plain stored it then
    again = BrainRun.from_plain(old)
    assert again.optimizer == "cmaes" and again.iteration == 3
    assert again.best_fitness == run.best_fitness
    assert again.ask().tobytes() == run.ask().tobytes()


def test_a_nevergrad_run_resumes_to_the_uninterrupted_records(tmp_path: Path, monkeypatch) -> None:
    whole = run_experiment(GECKO, out=tmp_path / "whole" / "run", overrides=NEVERGRAD)
    info = load_run(whole.run_dir).info
    assert info["config"]["brain"]["optimizer"] == "nevergrad"
    assert info["plugins"]["brain_optimizer"]["object"] == "ariel.evolution._nevergrad:Nevergrad"
    original = Progress.end_generation

    def stop_after_generation_one(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        if generation == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "end_generation", stop_after_generation_one)
    out = tmp_path / "killed" / "run"
    with pytest.raises(KeyboardInterrupt):
        run_experiment(GECKO, out=out, overrides=NEVERGRAD)
    monkeypatch.setattr(Progress, "end_generation", original)
    assert load_run(out).generations_done == 2
    assert resume_experiment(out).status == "finished"
    assert table_digests(out) == table_digests(Path(whole.run_dir))
    cma = load_run(run_experiment(GECKO, out=tmp_path / "cma", overrides=SMALL).run_dir)
    assert not cma.evaluations["fitness"].equals(load_run(out).evaluations["fitness"])


def test_the_config_hash_leaves_out_the_default_learner() -> None:
    base = load_config({})
    assert config_hash(base) == config_hash(load_config({}, ["brain.optimizer=cmaes"]))
    assert config_hash(base) != config_hash(load_config({}, ["brain.optimizer=nevergrad"]))
    options = ["brain.optimizer=nevergrad", "brain.optimizer_options={method='PSO'}"]
    assert config_hash(load_config({}, options)) != config_hash(
        load_config({}, ["brain.optimizer=nevergrad"])
    )


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (
            ["brain.optimizer=cmaess"],
            r"^brain\.optimizer: unknown brain optimizer 'cmaess'; known: cmaes, nevergrad; "
            r"did you mean 'cmaes'\?$",
        ),
        (
            ["brain.optimizer_options={colour='red'}"],
            r"^brain\.optimizer_options: 'cmaes': unknown option 'colour'; it takes no options$",
        ),
        (
            ["brain.optimizer_options={popsize=3}"],
            r"^brain\.optimizer_options: 'popsize' is not an option: the run gives every",
        ),
        (
            ["brain.optimizer=nevergrad", "brain.optimizer_options={method='TwoPointDE'}"],
            r"^brain\.optimizer_options: 'nevergrad': unknown nevergrad method 'TwoPointDE'; "
            r"did you mean 'TwoPointsDE'\?",
        ),
        (
            ["brain.optimizer=nevergrad", "brain.optimizer_options={budget=0}"],
            r"^brain\.optimizer_options: 'nevergrad': budget must be a whole number",
        ),
    ],
)
def test_a_bad_learner_is_one_config_error_and_writes_nothing(
    overrides: list[str], message: str, tmp_path: Path
) -> None:
    with pytest.raises(ConfigError, match=message) as caught:
        run_experiment(GECKO, out=tmp_path / "run", overrides=[*SMALL, *overrides])
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "run").exists()


# A third-party learner: a hill climber around the best candidate of the last iteration.
HILL_CLIMBER = """
import numpy as np

from ariel.evolution import derive_rng, penalised_cost


class HillClimber:
    def __init__(self, *, x0, popsize, sigma0, seed, maximise, scale=1.0):
        self.mean, self.popsize = np.asarray(x0, dtype=float), popsize
        self.sigma, self.seed, self.maximise = sigma0 * scale, seed, maximise
        self.iteration = 0

    def ask(self):
        rng = derive_rng(self.seed, "hill", self.iteration)
        return self.mean + self.sigma * rng.standard_normal((self.popsize, self.mean.size))

    def tell(self, params, fitness):
        self.mean = np.array(params[int(np.argmin(penalised_cost(fitness, self.maximise)))])
        self.iteration += 1

    def state(self):
        return {"mean": self.mean.tolist(), "iteration": self.iteration}

    def restore(self, state):
        self.mean, self.iteration = np.asarray(state["mean"]), state["iteration"]


class Unseeded(HillClimber):
    def ask(self):
        return self.mean + np.random.standard_normal((self.popsize, self.mean.size))
"""
PKG = "ariel_test_hill_climber"


@pytest.fixture
def hill_climber(fake_distribution) -> str:
    fake_distribution(
        PKG,
        source=HILL_CLIMBER,
        entry_points={
            "ariel.brain_optimizers": {"hill": f"{PKG}:HillClimber", "unseeded": f"{PKG}:Unseeded"}
        },
    )
    return "hill"


def test_a_third_party_learner_runs_an_experiment(hill_climber: str, tmp_path: Path) -> None:
    check_brain_optimizer(hill_climber, scale=0.5)
    config = {
        "name": "hill",
        "seed": 3,
        "generations": 2,
        "body": {"options": {"number_of_modules": 6}, "population": 2, "offspring": 2},
        "brain": {"optimizer": hill_climber, "optimizer_options": {"scale": 0.5}},
        "task": {"duration": 0.3},
        "record": {"rerun": False},
        "executor": {"kind": "serial"},
    }
    config["brain"].update(popsize=3, iterations=2)
    run_experiment(config, out=tmp_path / "run")
    run = load_run(tmp_path / "run")
    assert len(run.evaluations) == (2 + 2) * 3 * 2
    ok = run.bodies[run.bodies["status"] == "ok"]
    best = run.evaluations.groupby("body_id")["fitness"].max()
    assert (ok["fitness"].to_numpy() == best[ok["body_id"]].to_numpy()).all()
    provenance = run.info["plugins"]["brain_optimizer"]
    assert provenance["object"] == f"{PKG}:HillClimber"
    assert provenance["distribution"].startswith(PKG)


def test_a_learner_that_draws_from_numpy_s_global_generator_fails_its_check(
    hill_climber: str,
) -> None:
    message = "brain optimizer 'unseeded': asks for different candidates with the same seed"
    with pytest.raises(PluginCheckError, match=message):
        check_brain_optimizer("unseeded")
    np.random.seed(None)
