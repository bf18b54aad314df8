"""Before a run starts: `prepare_run` turns a config into a `PreparedRun`. Its plugins are
made from the config and checked with their options (the only call of the plugin checkers), a
genotype file read, a fixed body built, the executor settings checked and the memory one
generation needs estimated; every problem a `ConfigError` naming the key, before anything is
written.
"""

from __future__ import annotations

import numbers
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ariel import evolution
from ariel.evaluation import default_workers, fitness_options_error
from ariel.evaluation.executors import (
    ExecutorSettingsError,
    check_settings,
    executor_kind,
    executor_kinds,
    planned_workers,
)
from ariel.evolution import (
    BodyFactory,
    ConfigError,
    ExecutorConfig,
    ExperimentConfig,
    Plugins,
    budget,
    check_genotype,
    check_resources,
    describe,
    fixed_genotype,
    is_brain_only,
    is_genotype_file,
    read_genotype_file,
    record_steps,
)
from ariel.plugins import (
    BodyEncoder,
    FitnessFunction,
    Registry,
    body_encoders,
    body_optimizers,
    brain_optimizers,
    controllers,
    fitness_functions,
    worlds,
)
from ariel.recording.store import short_ascii
from ariel.simulation.tasks.gait_learning import window_count_error
from ariel.utils import ariel_line, unknown_option

__all__ = [
    "PreparedRun",
    "executor_settings",
    "prepare_run",
    "resolve_plugins",
    "resume_settings",
]


# --------------------------------------------------------------------------------------------
# Plugins resolved once, with config errors naming the key
# --------------------------------------------------------------------------------------------


def _make(key: str, registry: Registry[Any], name: str, options: dict[str, Any]) -> Any:
    try:
        registry.get(name)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"{key}: {exc}") from None
    try:
        return registry.make(name, **options)
    except (TypeError, ValueError) as exc:
        options_key = key.rsplit(".", 1)[0] + ".options"
        raise ConfigError(f"{options_key}: {registry.label} '{name}': {exc}") from None


def _check_fitness_options(
    config: ExperimentConfig, fitness: FitnessFunction, world: object
) -> None:
    exc = fitness_options_error(fitness, config.task.options)
    if exc is not None:  # the function's own signature, or the options the config gives it
        key = "task.fitness" if "no argument for the record" in str(exc) else "task.options"
        raise ConfigError(f"{key}: fitness function '{config.task.fitness}': {exc}")
    _check_windows(config, getattr(world, "timestep", None))


def _check_windows(config: ExperimentConfig, timestep: object) -> None:
    """``sustained_displacement``'s ``window`` against this run's recorded path (its span and
    frames, from ``task.duration``, ``record.rate_hz`` and the world's ``timestep``): the
    function refuses a window that cuts it into too many pieces (`window_count_error`), which
    would otherwise stop the run at its first evaluation, or take all memory."""
    window = config.task.options.get("window", 1.0)
    if (
        config.task.fitness != "sustained_displacement"
        or not isinstance(timestep, float)
        or not isinstance(window, int | float)
        or isinstance(window, bool)
        or not window > 0  # the function's own message says what a window must be
    ):
        return
    steps = max(1, round(config.task.duration / timestep))  # as the engine's `num_steps`
    samples = steps // record_steps(config, timestep) + 1
    error = window_count_error(steps * timestep * (1 + 1e-9), samples, float(window))
    if error is not None:
        raise ConfigError(
            f"task.options: fitness function 'sustained_displacement': {error} (task.duration "
            f"{config.task.duration:g} s, {samples} recorded frames)"
        )


def _optimizer_factory(
    config: ExperimentConfig, encoder: BodyEncoder, maximise: bool
) -> Callable[..., Any]:
    """``(**keywords) -> BodyOptimizer`` for ``body.optimizer``, made once here to check it."""
    body = config.body
    try:
        cls = body_optimizers.get(body.optimizer)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"body.optimizer: {exc}") from None

    def make(**keywords: Any) -> Any:
        return cls(**keywords, **body.optimizer_options)

    try:
        make(encoder=encoder, seed=config.seed, maximise=maximise, settings=body)
    except (TypeError, ValueError) as exc:
        first = (str(exc).splitlines() or [""])[0]
        raise ConfigError(f"body.optimizer_options: {body.optimizer!r}: {first}") from None
    return make


def _check_brain_optimizer(config: ExperimentConfig, maximise: bool) -> None:
    """``brain.optimizer`` is a registered brain optimizer that takes ``optimizer_options``:
    one is made here for a two-parameter body (each body makes its own during the run), with
    at most 64 candidates (a popsize too big for this machine is the memory check's to refuse:
    pycma allocates per candidate), and asked, told and asked again, as ``ariel plugins
    --check`` does (a Nevergrad method that needs a budget fails its first ask without one)."""
    brain = config.brain
    try:
        factory = brain_optimizers.get(brain.optimizer)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"brain.optimizer: {exc}") from None
    keywords = {"popsize": min(brain.popsize, 64), "sigma0": brain.sigma0, "maximise": maximise}
    taken = sorted(set(brain.optimizer_options) & {*keywords, "x0", "seed"})
    if taken:
        raise ConfigError(
            f"brain.optimizer_options: {taken[0]!r} is not an option: the run gives every "
            "learner x0, popsize, sigma0, seed and maximise (brain.popsize, brain.sigma0)"
        )
    unknown = unknown_option(factory, brain.optimizer_options, given={*keywords, "x0", "seed"})
    if unknown is not None:
        raise ConfigError(f"brain.optimizer_options: {brain.optimizer!r}: {unknown}")
    try:
        learner = factory(x0=np.zeros(2), seed=1, **keywords, **brain.optimizer_options)
    except (TypeError, ValueError) as exc:
        first = (str(exc).splitlines() or [""])[0]
        raise ConfigError(f"brain.optimizer_options: {brain.optimizer!r}: {first}") from None
    key = f"brain.optimizer_options: {brain.optimizer!r}: the plugin check failed"
    step = "ask()"
    try:
        params = np.asarray(learner.ask(), dtype=np.float64)
        if params.shape != (keywords["popsize"], 2):
            raise ConfigError(
                f"{key}: ask() gave shape {params.shape}, not (popsize, parameters) = "
                f"({keywords['popsize']}, 2)"
            )
        step = "tell(...)"
        learner.tell(params, -np.sum(params**2, axis=1))
        step = "ask() after tell(...)"
        learner.ask()
    except ConfigError:
        raise
    except Exception as exc:  # any: the learner's own code
        first = (f"{type(exc).__name__}: {exc}".splitlines() or [""])[0]
        raise ConfigError(f"{key}: {step} raised {first}") from None


def resolve_plugins(config: ExperimentConfig) -> Plugins:
    """Make every plugin the config names; a bad name or option is a `ConfigError`."""
    encoder = _make("body.encoder", body_encoders, config.body.encoder, config.body.options)
    controller = _make(
        "brain.controller", controllers, config.brain.controller, config.brain.options
    )
    world = _make("world.name", worlds, config.world.name, config.world.options)
    try:
        fitness = fitness_functions.get(config.task.fitness)
    except (KeyError, ValueError, ImportError) as exc:
        raise ConfigError(f"task.fitness: {exc}") from None
    _check_fitness_options(config, fitness, world)
    if config.body.genotype is not None and not is_genotype_file(config.body.genotype):
        check_genotype(config.body.genotype, encoder)  # a file is checked as it is read
    maximise = bool(fitness.maximise)
    # A brain-only run asks no body optimizer: its name (an entry point's) is not looked up.
    brain_only = is_brain_only(config, encoder)
    optimizer = None if brain_only else _optimizer_factory(config, encoder, maximise)
    _check_brain_optimizer(config, maximise)
    return Plugins(encoder, controller, fitness, optimizer)


def _check_plugins_reach_workers(config: ExperimentConfig, settings: ExecutorConfig) -> None:
    """Worker processes know a plugin by importing the module that registers it: one defined
    in a notebook or an interactive session (module ``__main__``, no file) is unknown to
    them, and so is one defined in a script to the workers of a Dask scheduler (they never
    import the script). Refused before anything is written, rather than failing the run's
    first evaluation."""
    kind = executor_kind(settings.kind)
    if kind.one_worker is not None:  # the calls run in this process
        return
    main = sys.modules.get("__main__")
    remote = kind.takes_address and settings.address is not None
    script = getattr(main, "__file__", None)
    if not remote and script and not os.path.isfile(script):  # `python - < file`: <stdin>
        raise ConfigError(
            f"executor.kind: this script was read from {script}, which the {settings.kind} "
            "executor's worker processes cannot import again: save it to a file and run that, "
            'or run on executor "serial"'
        )
    if not remote and script:  # a script: workers import it
        return
    named = [
        ("body.encoder", body_encoders, config.body.encoder),
        ("brain.controller", controllers, config.brain.controller),
        ("world.name", worlds, config.world.name),
        ("task.fitness", fitness_functions, config.task.fitness),
    ]
    for key, registry, name in named:
        if getattr(registry.get(name), "__module__", None) != "__main__":
            continue
        where = "in this script" if remote else "in this notebook (or interactive session)"
        raise ConfigError(
            f"{key}: {registry.label} {name!r} is defined {where}, which the {settings.kind} "
            "executor's worker processes cannot import: define it in a module and import "
            'that (docs/plugins.md), or run on executor "serial"'
        )


def _read_genotype_file(config: ExperimentConfig, encoder: BodyEncoder) -> ExperimentConfig:
    """The config holding the genotype itself when ``body.genotype`` names a file (checked)."""
    if not is_genotype_file(config.body.genotype):
        return config
    path = config.body.genotype
    genotype = read_genotype_file(path)
    check_genotype(genotype, encoder, f"body.genotype: file {path!r}")
    body = config.body.model_copy(update={"genotype": genotype})
    return config.model_copy(update={"body": body})


def _check_fixed_body(config: ExperimentConfig, plugins: Plugins, genotype: object) -> None:
    """A brain-only run's body (``genotype``) must build: a bad ``body.genotype`` is a config
    error."""
    factory = BodyFactory(config, plugins.encoder, plugins.controller, plugins.maximise)
    body = factory.new_body(0, genotype, [], 0)
    if body.status == "error":
        shown = describe(config.body.genotype)
        raise ConfigError(f"body.genotype: {shown} gives no body: {body.error}")


def executor_settings(config: ExperimentConfig, **given: object) -> ExecutorConfig:
    """The config's ``[executor]`` with the caller's overrides, checked: `ConfigError`."""
    changes = {key: value for key, value in given.items() if value is not None}
    return _checked(config.executor, changes)


def _checked(section: ExecutorConfig, changes: dict[str, object]) -> ExecutorConfig:
    """``section`` with ``changes`` (the caller's, not validated by pydantic), checked."""
    workers = changes.get("workers")
    if isinstance(workers, numbers.Integral) and not isinstance(workers, bool):
        changes["workers"] = int(workers)  # a NumPy integer (a loop over np.arange) is a count
    settings = section.model_copy(update=changes)
    try:
        check_settings(settings)
    except ExecutorSettingsError as exc:
        raise ConfigError(str(exc)) from None
    return settings


def _stored_workers(value: object) -> int | None:
    """A worker count a folder recorded, if it is one this machine can honour (at most the
    CPUs this process may use); None (the default) otherwise."""
    if type(value) is int and 1 <= value <= default_workers():
        return value
    return None


def resume_settings(
    config: ExperimentConfig,
    stored: object,
    *,
    kind: str | None,
    workers: int | None,
    address: str | None,
    command: Sequence[object],
) -> ExecutorConfig:
    """The executor of a resume: the caller's ``kind`` / ``workers`` / ``address``, else what
    the folder recorded (``stored``: run.json's or campaign.json's ``executor``, and the stored
    config's section) for the kind and the worker count, but never a scheduler address: a
    folder is data, and a Dask scheduler it names could be anyone's (Dask moves results as
    pickles). A stored address not used is said in one line on stderr, with how to pass one
    (``command``: the words of the resume command, e.g. ``("resume", run_dir)``)."""
    stored = stored if isinstance(stored, dict) else {}
    stored_kind = stored.get("kind")
    if not isinstance(stored_kind, str) or stored_kind not in executor_kinds:
        stored_kind = config.executor.kind  # absent, or not a kind: the stored config's
    # ``scheduler``: the old name of ``address``, in folders written before the rename.
    named = stored.get("address") or stored.get("scheduler") or config.executor.address
    if kind is None:
        kind = "dask" if address is not None else stored_kind
    # The same kind of worker pool: its stored worker count carries over.
    same_pool = (
        kind == stored_kind and kind in executor_kinds and executor_kind(kind).one_worker is None
    )
    if workers is None and address is None and same_pool:
        workers = _stored_workers(stored.get("workers", config.executor.workers))
    changes = {"kind": kind, "workers": workers, "address": address}
    settings = _checked(config.executor, changes)
    if named and address is None and kind == "dask":
        print(
            f"note: not connecting to the Dask scheduler {short_ascii(named)} that the folder "
            "names (an address is never taken from a folder); resuming on a local Dask "
            f"cluster. To use a scheduler you trust: {ariel_line(*command)} --address "
            "ADDRESS",
            file=sys.stderr,
            flush=True,
        )
    return settings


@dataclass(frozen=True)
class PreparedRun:
    """A config made ready to run, every part of it checked (`prepare_run`).

    Attributes:
        config: The config, with a genotype file named by ``body.genotype`` read into it.
        plugins: Its plugins, made once.
        settings: The executor it runs on, checked.
        brain_only: Whether its body is fixed (`is_brain_only`).
        genotype: A brain-only run's body (it builds); None when bodies evolve.
        budget: The evaluations the run makes.
        memory: Bytes one generation needs, estimated from a sample body (None: no body to
            measure).
    """

    config: ExperimentConfig
    plugins: Plugins
    settings: ExecutorConfig
    brain_only: bool
    genotype: object | None
    budget: int
    memory: int | None


def prepare_run(config: ExperimentConfig, settings: ExecutorConfig | None = None) -> PreparedRun:
    """``config`` made ready to run on ``settings`` (None: the config's ``[executor]``), all of
    it checked: `ConfigError` naming the key."""
    settings = executor_settings(config) if settings is None else settings
    plugins = resolve_plugins(config)
    _check_plugins_reach_workers(config, settings)
    config = _read_genotype_file(config, plugins.encoder)
    brain_only = is_brain_only(config, plugins.encoder)
    genotype = None
    if brain_only:
        genotype = fixed_genotype(config, plugins.encoder)
        _check_fixed_body(config, plugins, genotype)
    # The plugins --check checks, for these plugins with these options; from the face when
    # called: tests replace it there (tests/e2e/test_unstable.py).
    evolution.check_plugins(config, brain_only=brain_only)
    capacity, local_workers = planned_workers(settings)
    memory = check_resources(
        config,
        plugins.encoder,
        brain_only=brain_only,
        capacity=capacity,
        local_workers=local_workers,
    )
    return PreparedRun(
        config, plugins, settings, brain_only, genotype, budget(config, brain_only), memory
    )
