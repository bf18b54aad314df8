"""The plugin checkers catch broken plugins, each with a one-line message naming the plugin."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.prebuilt_robots.encoder import PrebuiltEncoder
from ariel.ec.genotypes.nde.encoder import NDEEncoder
from ariel.plugins import (
    BUILTIN_PLUGINS,
    PluginCheckError,
    Registry,
    body_encoders,
    check_all,
    check_body_encoder,
    check_controller,
    check_fitness,
    check_world,
    controllers,
    fitness_function,
    fitness_functions,
    worlds,
)


@pytest.fixture
def register() -> Iterator[Callable[[Registry[Any], str, Any], None]]:
    """``register(registry, name, obj)`` for this test only."""
    added: list[tuple[Registry[Any], str]] = []

    def add(registry: Registry[Any], name: str, obj: Any) -> None:
        registry.register(name, obj)
        added.append((registry, name))

    yield add
    for registry, name in added:
        registry.unregister(name)


def assert_fails(check: Callable[..., None], name: str, pattern: str, **options: Any) -> None:
    with pytest.raises(PluginCheckError) as info:
        check(name, **options)
    message = str(info.value)
    assert isinstance(info.value, AssertionError)
    assert "\n" not in message
    assert f"'{name}'" in message, message
    assert re.search(pattern, message), message


# --- controllers ----------------------------------------------------------------------------


class Sine:
    """A well-behaved open-loop controller; the broken ones below change one thing each."""

    open_loop = True

    def num_parameters(self, model: Any) -> int:
        return model.nu

    def random_parameters(self, model: Any, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.uniform(0.1, 1.0, (n, model.nu))

    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        phase = np.random.default_rng(seed).uniform(0, 2 * np.pi, model.nu)
        wave = np.sin(2 * np.pi * sample_times[None, :, None] + phase)
        return params[:, None, :] * wave


class GlobalRandomSine(Sine):
    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        return super().targets(params, sample_times, model, seed=np.random.randint(1000))


class WrongShapeSine(Sine):
    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        return super().targets(params, sample_times, model, seed=seed)[:, :, :-1]


class WrongSizeParameters(Sine):
    def random_parameters(self, model: Any, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.uniform(0.1, 1.0, (n, model.nu + 1))


class RowsShareNoise(Sine):
    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        noise = np.random.default_rng(seed).normal(0, 0.1, (len(params), sample_times.size, 1))
        return super().targets(params, sample_times, model, seed=seed) + noise


class NanSine(Sine):
    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        out = super().targets(params, sample_times, model, seed=seed)
        out[:, -1] = np.nan
        return out


class OpenLoopAsString(Sine):
    open_loop = "yes"  # type: ignore[assignment]


class BadPolicy:
    open_loop = False

    def num_parameters(self, model: Any) -> int:
        return 1

    def random_parameters(self, model: Any, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.normal(size=(n, 1))

    def make_policy(self, params: Any, model: Any) -> Callable[[np.ndarray], np.ndarray]:
        return lambda observation: np.zeros(model.nu + 2)


def test_a_good_controller_passes(register) -> None:
    register(controllers, "test_sine", Sine)
    check_controller("test_sine")


@pytest.mark.parametrize(
    ("plugin", "pattern"),
    [
        (GlobalRandomSine, "targets.. is not deterministic"),
        (WrongShapeSine, r"targets.. has shape \(3, 5, 7\); expected \(3, 5, 8\)"),
        (WrongSizeParameters, r"random_parameters.*shape \(3, 9\); expected \(3, 8\)"),
        (RowsShareNoise, "differ when other candidates share the batch"),
        (NanSine, "NaN or inf"),
        (OpenLoopAsString, "needs a bool attribute 'open_loop'"),
        (BadPolicy, r"policy output has shape \(10,\); expected \(8,\)"),
    ],
)
def test_broken_controllers_are_caught(register, plugin: type, pattern: str) -> None:
    register(controllers, "test_broken_ctrl", plugin)
    assert_fails(check_controller, "test_broken_ctrl", pattern)


def test_a_controller_rejecting_its_options_is_caught() -> None:
    assert_fails(check_controller, "na_cpg", r"make\(.*raised TypeError", smoothing=0.5)


# --- fitness functions ----------------------------------------------------------------------


def test_a_fitness_function_without_maximise_is_caught(register) -> None:
    @fitness_function(maximise=True)
    def height(record: Any) -> float:
        return float(record.core_pos[-1, 2])

    register(fitness_functions, "test_no_direction", height)
    del height.maximise  # the registry checks at registration; the object changed since
    assert_fails(check_fitness, "test_no_direction", "needs a bool attribute 'maximise'")


def test_a_fitness_entry_point_without_maximise_is_reported(fake_distribution) -> None:
    fake_distribution(
        "ariel_check_plugin_pkg",
        "0.3",
        source="def height(record):\n    return float(record.core_pos[-1, 2])\n",
        entry_points={"ariel.fitness": {"test_ep_height": "ariel_check_plugin_pkg:height"}},
    )
    assert_fails(check_fitness, "test_ep_height", "PluginLoadError.*maximise")
    rows = {(kind, name): error for kind, name, error in check_all()}
    assert "maximise" in rows[("fitness", "test_ep_height")]
    assert rows[("fitness", "xy_displacement")] is None  # the others still pass


def _register_fitness(register, name: str, fn: Callable[..., Any]) -> None:
    register(fitness_functions, name, fitness_function(maximise=True)(fn))


@pytest.mark.parametrize(
    ("score", "pattern"),
    [
        (lambda record: float("nan"), "returned nan"),
        (lambda record: "far", "returned str, not a float"),
        (lambda record: np.random.random(), "different values for the same record"),
        (lambda record: record.core_pos.fill(0.0), "read-only"),
        (lambda record: 10**400, r"returned 100000000000\.\.\. \(401 digits\)"),
    ],
    ids=["nan", "str", "random", "writes-the-record", "an-int-no-float-holds"],
)
def test_broken_fitness_functions_are_caught(register, score: Callable, pattern: str) -> None:
    def broken(record: Any) -> Any:
        return score(record)

    _register_fitness(register, "test_broken_fitness", broken)
    assert_fails(check_fitness, "test_broken_fitness", pattern)


# --- body encoders --------------------------------------------------------------------------


class InPlaceNDE(NDEEncoder):
    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> Any:
        genotype += rng.normal(0.0, 0.1, np.shape(genotype)).astype(np.float32)
        return genotype


class IdleNDE(NDEEncoder):
    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> Any:
        return np.array(genotype, dtype=np.float32)


class GlobalRandomNDE(NDEEncoder):
    def random_genotype(self, rng: np.random.Generator) -> np.ndarray:
        return np.random.random((3, self.genotype_size)).astype(np.float32)


class ObjectGenotypeNDE(NDEEncoder):
    def random_genotype(self, rng: np.random.Generator) -> Any:
        return {"genes": super().random_genotype(rng), "born": object()}


class MisdeclaredShapeNDE(NDEEncoder):
    genotype_shape = (3, 99)


class SilentPrebuilt(PrebuiltEncoder):
    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> Any:
        return genotype


class VagueEvolvable(PrebuiltEncoder):
    evolvable = None  # type: ignore[assignment]


@pytest.mark.parametrize(
    ("plugin", "pattern"),
    [
        (InPlaceNDE, "mutate changed its input genotype in place"),
        (IdleNDE, "mutate returned a genotype equal to its input"),
        (GlobalRandomNDE, "random_genotype is not deterministic"),
        (ObjectGenotypeNDE, r"plain data \(JSON\) raised TypeError"),
        (MisdeclaredShapeNDE, r"genotype_shape is \(3, 99\) but random_genotype gives shape"),
        (SilentPrebuilt, "mutate returned a genotype although evolvable is False"),
        (VagueEvolvable, "needs a bool attribute 'evolvable'"),
    ],
)
def test_broken_body_encoders_are_caught(register, plugin: type, pattern: str) -> None:
    register(body_encoders, "test_broken_encoder", plugin)
    assert_fails(check_body_encoder, "test_broken_encoder", pattern)


def test_bad_encoder_options_are_caught() -> None:
    assert_fails(check_body_encoder, "nde", r"make\(.*raised ValueError", number_of_modules=1)


# --- worlds ---------------------------------------------------------------------------------


def wobbly_world(**options: Any) -> Any:
    from ariel.simulation.environments import SimpleFlatWorld

    return SimpleFlatWorld(floor_size=(np.random.uniform(5, 10), 10.0, 1.0), **options)


def specless_world(**options: Any) -> Any:
    return object()


@pytest.mark.parametrize(
    ("factory", "pattern"),
    [
        (wobbly_world, "compile to different models"),
        (specless_world, "needs an attribute 'spec'"),
    ],
)
def test_broken_worlds_are_caught(register, factory: Callable, pattern: str) -> None:
    register(worlds, "test_broken_world", factory)
    assert_fails(check_world, "test_broken_world", pattern)


def test_one_check_all_and_one_helper_for_its_rows() -> None:
    import ariel.evaluation
    import ariel.evolution
    from ariel.evaluation import check_rows

    # check_all is ariel.evolution's (optimizers included); the engine's own has its own name
    assert check_all is ariel.evolution.check_all
    assert not hasattr(ariel.evaluation, "check_all")
    assert callable(ariel.evaluation.check_engine_plugins)

    def checker(name: str) -> None:
        if name == "bad":
            raise PluginCheckError("thing 'bad': broken")
        if name == "odd":
            raise RuntimeError("first line\nsecond line")

    names = staticmethod(lambda: ["bad", "ok", "odd"])
    registry = type("Registry", (), {"label": "thing", "names": names})
    assert check_rows([("thing", registry, checker)]) == [
        ("thing", "bad", "thing 'bad': broken"),
        ("thing", "ok", None),
        ("thing", "odd", "thing 'odd': RuntimeError: first line"),
    ]


def test_check_all_reports_broken_plugins_without_raising(register) -> None:
    register(controllers, "test_broken_ctrl", WrongShapeSine)
    rows = {(kind, name): error for kind, name, error in check_all()}
    assert "targets() has shape" in rows[("controller", "test_broken_ctrl")]
    assert rows[("controller", "na_cpg")] is None


# --- checks of one plugin do not depend on another ------------------------------------------


class RaisesEverywhere(Sine):
    """What a user might register over "na_cpg": every call fails."""

    def random_parameters(self, model: Any, rng: np.random.Generator, n: int) -> np.ndarray:
        raise RuntimeError("broken on purpose")

    def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> np.ndarray:
        raise RuntimeError("broken on purpose")


@fitness_function(maximise=True)
def raises_when_scoring(record: Any) -> float:
    raise RuntimeError("broken on purpose")


@pytest.fixture
def replace_builtin() -> Iterator[Callable[[Registry[Any], str, Any], None]]:
    """``replace_builtin(registry, name, obj or None)``: a built-in replaced (None: removed)
    for this test only; restored from its "module:attr" afterwards."""
    replaced: list[tuple[Registry[Any], str]] = []

    def replace(registry: Registry[Any], name: str, obj: Any) -> None:
        if name in registry:
            registry.unregister(name)
        if obj is not None:
            registry.register(name, obj)
        replaced.append((registry, name))

    yield replace
    for registry, name in replaced:
        if name in registry:
            registry.unregister(name)
        registry.register(name, BUILTIN_PLUGINS[registry.kind][name])


def test_world_encoder_and_fitness_checks_survive_a_replaced_na_cpg(replace_builtin) -> None:
    replace_builtin(controllers, "na_cpg", RaisesEverywhere)
    replace_builtin(fitness_functions, "xy_displacement", raises_when_scoring)
    # The replacements are in effect: their own checks fail ...
    assert_fails(check_controller, "na_cpg", "random_parameters.*broken on purpose")
    assert_fails(check_fitness, "xy_displacement", "broken on purpose")
    # ... and the other plugins' checks, which drive the gecko with a CPG, still pass.
    check_world("flat")
    check_body_encoder("nde")
    check_fitness("x_speed")


def test_checks_need_no_registered_na_cpg_at_all(replace_builtin) -> None:
    replace_builtin(controllers, "na_cpg", None)
    assert "na_cpg" not in controllers
    check_world("tilted")
    check_fitness("distance_to_target")


def _clashing(monkeypatch: pytest.MonkeyPatch, registry: Registry[Any], name: str) -> None:
    """``registry.get(name)`` raises as for two entry points of that name."""
    from ariel.errors import DuplicatePluginError

    original = registry.get

    def get(asked: str) -> Any:
        if asked == name:
            raise DuplicatePluginError(f"{name!r} is provided twice (by a and by b)")
        return original(asked)

    monkeypatch.setattr(registry, "get", get)


def test_a_clashing_plugin_fails_only_the_experiments_that_use_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every controller's check failed for a second "xy_displacement", naming 'na_cpg'; a
    second "ga" refused brain-only runs, which ask no body optimizer."""
    from ariel.evolution import load_config
    from ariel.plugins import body_optimizers
    from ariel.runs._prepare import prepare_run

    _clashing(monkeypatch, fitness_functions, "xy_displacement")
    _clashing(monkeypatch, body_optimizers, "ga")
    check_controller("na_cpg")
    config = load_config(
        {"body": {"encoder": "prebuilt", "genotype": "gecko"}, "task": {"fitness": "x_speed"}}
    )
    prepared = prepare_run(config)
    assert prepared.config.body.optimizer == "ga"
    from ariel.runs._session import run_info

    assert "body_optimizer" not in run_info(prepared, "r")["plugins"]  # not looked up either
