"""Experiment configs: TOML -> typed config, one-line errors naming the dotted key."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from ariel.evolution import ConfigError, ExperimentConfig, load_config
from ariel.evolution._config import config_hash
from ariel.runs._experiment import resolve_plugins as _resolve

EXPERIMENTS = sorted((Path(__file__).resolve().parents[2] / "experiments").glob("*.toml"))


@pytest.mark.parametrize("path", EXPERIMENTS, ids=lambda p: p.stem)
def test_every_shipped_experiment_validates_and_resolves_its_plugins(path: Path) -> None:
    text = path.read_text()
    assert text.startswith("#"), "each experiment opens with a comment on what it studies"
    config = load_config(path)
    assert config.name == path.stem
    _resolve(config)  # plugin names and options are valid


def test_the_shipped_experiments_include_the_four_the_project_promises() -> None:
    names = {p.stem for p in EXPERIMENTS}
    assert {"coevolve_flat", "coevolve_rugged", "gecko_gait", "olympic_target"} <= names


def test_default_config_is_the_flat_coevolution() -> None:
    config = load_config(None)
    assert config.name == "coevolve_flat"
    assert config.body.encoder == "nde" and config.world.name == "flat"


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"generation": 3}, r"unknown key 'generation'; allowed: .*did you mean 'generations'"),
        ({"brain": {"popsiz": 3}}, r"unknown key 'brain.popsiz'.*did you mean 'brain.popsize'"),
        ({"brain": {"popsize": 0}}, r"^brain.popsize: must be greater than or equal to 2"),
        ({"body": {"population": -1}}, r"^body.population: must be greater than or equal to 1"),
        ({"generations": 0}, r"^generations: must be greater than or equal to 1 \(got 0\)"),
        ({"generations": 10**20}, r"^generations: must be less than or equal to 1000000 \(got"),
        ({"task": {"duration": -1.0}}, r"^task.duration: must be greater than 0"),
        ({"record": {"rate_hz": 0}}, r"^record.rate_hz: must be greater than 0"),
        ({"brain": {"control_period": 0}}, r"^brain.control_period: must be greater than"),
        ({"seed": "one"}, r"^seed: must be a valid integer"),
        (
            {"executor": {"kind": "gpuu"}},
            r"^executor.kind: must be an executor kind: serial, local, dask, gpu \(got 'gpuu'\)$",
        ),
        ({"executor": {"device": "tpu"}}, r"^executor.device: must be 'cuda' or 'cpu'"),
        ({"body": {"survivors": "best"}}, r"^body.survivors: must be 'plus' or 'generational'"),
        ({"executor": {"timeout": 0}}, r"^executor.timeout: must be greater than 0"),
        # Strict types: a string is no number, even one a float() would read.
        ({"executor": {"timeout": "inf"}}, r"^executor.timeout: must be a valid number .*string"),
        ({"executor": {"timeout": float("inf")}}, r"^executor.timeout: must be a finite number"),
        ({"executor": {"max_retries": -1}}, r"^executor.max_retries: must be greater than or"),
    ],
)
def test_bad_values_and_keys_give_one_line_naming_the_key(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        load_config(data)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"body": {"encoder": "ndee"}}, r"^body.encoder: unknown body encoder 'ndee'.*'nde'"),
        ({"brain": {"controller": "cpg"}}, r"^brain.controller: unknown controller 'cpg'"),
        ({"world": {"name": "moon"}}, r"^world.name: unknown world 'moon'"),
        ({"task": {"fitness": "speed"}}, r"^task.fitness: unknown fitness function 'speed'"),
        ({"brain": {"options": {"alfa": 1}}}, r"^brain.options: controller 'na_cpg'"),
        ({"body": {"options": {"number_of_modules": 1}}}, r"^body.options: body encoder 'nde'"),
        ({"world": {"options": {"floor": 1}}}, r"^world.options: world 'flat'"),
        ({"task": {"options": {"goal": 1}}}, r"^task.options: fitness function"),
    ],
)
def test_unknown_plugins_and_bad_plugin_options_are_config_errors(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        _resolve(load_config(data))
    assert "\n" not in str(info.value)


def test_set_overrides_parse_toml_values_and_reject_missing_keys() -> None:
    config = load_config(
        {},
        [
            "brain.popsize=12",
            "world.name=rugged",
            "task.spawn_position=[0, 1, 0]",
            "body.options.number_of_modules=9",
            "brain.inherit=true",
        ],
    )
    assert config.brain.popsize == 12 and config.world.name == "rugged"
    assert config.task.spawn_position == (0.0, 1.0, 0.0)
    assert config.body.options == {"number_of_modules": 9}
    assert config.brain.inherit is True
    with pytest.raises(ConfigError, match=r"--set brain.popsiz: no such key; keys under brain"):
        load_config({}, ["brain.popsiz=3"])
    with pytest.raises(ConfigError) as caught:
        load_config({}, ["brain.popsiz=3"])
    assert str(caught.value).endswith("; did you mean 'brain.popsize'?")
    assert "\n" not in str(caught.value)
    with pytest.raises(ConfigError, match=r"did you mean 'body.population'\?$"):
        load_config({}, ["bodyy.population=3"])  # the whole key, when the rest of it exists
    with pytest.raises(ConfigError) as caught:
        load_config({}, ["brain.zzzzzz=3"])  # nothing close: no suggestion
    assert "did you mean" not in str(caught.value)
    with pytest.raises(ConfigError, match=r"expected key=value"):
        load_config({}, ["brain.popsize"])


def test_malformed_toml_and_missing_files_are_config_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("generations = [1,\n")
    with pytest.raises(ConfigError, match=r"malformed TOML"):
        load_config(bad)
    with pytest.raises(ConfigError, match=r"not found"):
        load_config(tmp_path / "missing.toml")


def test_config_hash_ignores_the_executor_but_not_what_decides_results() -> None:
    base = load_config({})
    assert config_hash(base) == config_hash(load_config({}, ["executor.kind=serial"]))
    assert config_hash(base) != config_hash(load_config({}, ["seed=99"]))
    assert ExperimentConfig.from_plain(base.to_plain()) == base


def test_executor_scheduler_is_the_old_name_of_executor_address(tmp_path: Path) -> None:
    old = tmp_path / "old.toml"
    old.write_text('[executor]\nkind = "dask"\nscheduler = "tcp://h:1"\n')
    config = load_config(old)
    assert config.executor.address == "tcp://h:1"
    assert config.to_plain()["executor"]["address"] == "tcp://h:1"  # written: the new name
    assert "scheduler" not in config.to_plain()["executor"]
    assert config_hash(config) == config_hash(load_config({}, ["executor.kind=dask"]))
    assert load_config({}, ["executor.scheduler='tcp://h:2'"]).executor.address == "tcp://h:2"
    # --set either name replaces the value the file gave under the other one
    assert load_config(old, ["executor.address='tcp://h:3'"]).executor.address == "tcp://h:3"
    with pytest.raises(ConfigError, match=r"^executor: give address or its old name sched"):
        load_config({"executor": {"address": "tcp://h:1", "scheduler": "tcp://h:1"}})


def test_a_stored_config_from_before_settle_reads_as_settle_zero_with_its_old_hash() -> None:
    old = load_config({}, ["task.settle=0.0"]).to_plain()
    del old["task"]["settle"]  # as run.json held it before the key existed
    config = ExperimentConfig.from_plain(old)
    assert config.task.settle == 0.0
    assert load_config({}).task.settle == 1.0  # a new experiment settles by default
    # The key at its neutral value is left out of the hash: an old run's hash is unchanged,
    # i.e. the hash of what the old run stored (without the executor and the keys added at
    # their neutral values, as before).
    stored = {k: v for k, v in old.items() if k != "executor"}
    for section in ("body", "brain"):
        stored[section] = {
            k: v for k, v in stored[section].items() if k not in ("optimizer", "optimizer_options")
        }
    text = json.dumps(stored, sort_keys=True, separators=(",", ":"))
    assert config_hash(config) == hashlib.sha256(text.encode()).hexdigest()
    assert config_hash(config) != config_hash(load_config({}))


def test_a_cross_field_rule_is_the_config_s_own_generational_needs_enough_children() -> None:
    # No plugin is made: the config itself refuses it, so an ExperimentConfig is valid or none.
    with pytest.raises(ConfigError) as caught:
        load_config(overrides=['body.survivors="generational"', "body.offspring=2"])
    assert str(caught.value) == (
        "body: generational survival needs offspring >= population (8), got offspring = 2"
    )
    assert load_config(overrides=['body.survivors="generational"', "body.offspring=8"])
