"""Experiment configuration: TOML files validated into typed, frozen config objects.

Every key has a type and a range; unknown keys are rejected. Errors are `ConfigError`, one
line naming the dotted key, what was given and what is allowed, e.g.
``brain.popsize: must be >= 2 (got 0)``.
"""

from __future__ import annotations

import difflib
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    AliasChoices,
    BaseModel,
    ConfigDict,
    Field,
    Strict,
    ValidationError,
    model_validator,
)
from pydantic_core import ErrorDetails

from ariel.errors import ConfigError
from ariel.evaluation.executors import executor_kinds, known_kinds
from ariel.evolution._toml import MAX_TOML_DEPTH

__all__ = [
    "MAX_GENERATIONS",
    "BodyConfig",
    "BrainConfig",
    "ConfigError",
    "ExecutorConfig",
    "ExperimentConfig",
    "RecordConfig",
    "TaskConfig",
    "WorldConfig",
    "config_hash",
    "plain_copy",
]


def _finite_seconds(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number of seconds")
    return value


#: Strict scalar types: ``generations = true`` or ``generations = "3"`` (TOML or ``--set``) is
#: a mistake to name, not a value to coerce; an integer is still a valid float.
Int = Annotated[int, Strict()]
Float = Annotated[float, Strict()]
Bool = Annotated[bool, Strict()]
Str = Annotated[str, Strict()]

#: The most generations a run has: a generation's files are named with six digits
#: (``gen-NNNNNN.parquet``), so generation 999,999 is the last one a folder can hold.
MAX_GENERATIONS = 1_000_000

#: A duration in seconds: positive and finite.
Seconds = Annotated[Float, Field(gt=0.0), AfterValidator(_finite_seconds)]
#: The longest ``executor.timeout``: 1,000,000 s (11.6 days).
MAX_TIMEOUT_S = 1_000_000.0


class _Section(BaseModel):
    # allow_inf_nan=False: every float of a config is finite (sigma0, spawn_position, ...).
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False, allow_inf_nan=False)


class BodyConfig(_Section):
    """The body optimizer (ignored, but for ``genotype``, in a brain-only run).

    ``population`` bodies are asked for in generation 0 and ``offspring`` in every later one.

    Attributes:
        encoder: The body encoder plugin (``ariel plugins`` lists them), ``"nde"`` by default.
        options: The encoder's options, e.g. ``{"number_of_modules": 12}``.
        optimizer: A registered body optimizer: ``"ga"`` (the default), ``"map_elites"``,
            ``"novelty"`` or ``"random"``.
        optimizer_options: The body optimizer's options (``map_elites``: ``measures``,
            ``bins``, ``ranges``, ``qd_offset``; ``novelty``: those and ``k``,
            ``novelty_threshold``, ``local_competition``, ``selection``).
        genotype: A fixed body, which makes the run brain-only: a prebuilt name ("gecko" for
            encoder "prebuilt"), a genotype, or a ``.json`` / ``.npy`` file holding one (a path
            in a TOML file is relative to that file). A run stores the genotype, not the path.
            None (the default): bodies evolve.
        population: Bodies of generation 0; the GA's mu (bodies kept each generation), >= 1.
        offspring: Children bred in each later generation (the GA's lambda), >= 1.
        survivors: ``"plus"`` (mu + lambda: parents and children compete) or
            ``"generational"`` (children only; needs ``offspring >= population``).
        tournament: The tournament size of parent selection, >= 1.
        crossover_rate: The probability (0 to 1) that a child has two parents (else one,
            mutated).
    """

    encoder: Str = "nde"
    options: dict[str, object] = Field(default_factory=dict)
    optimizer: str = "ga"
    optimizer_options: dict[str, object] = Field(default_factory=dict)
    genotype: object = None
    population: Int = Field(default=8, ge=1)
    offspring: Int = Field(default=8, ge=1)
    survivors: Literal["plus", "generational"] = "plus"
    tournament: Int = Field(default=2, ge=1)
    crossover_rate: Float = Field(default=0.5, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _generational_needs_enough_children(self) -> BodyConfig:
        if self.survivors == "generational" and self.offspring < self.population:
            raise ValueError(
                f"generational survival needs offspring >= population ({self.population}), "
                f"got offspring = {self.offspring}"
            )
        return self


class BrainConfig(_Section):
    """A learner (``optimizer``, a brain optimizer; CMA-ES by default) for each new body.

    Attributes:
        controller: The controller plugin, ``"na_cpg"`` by default.
        options: The controller's options (``na_cpg``: ``initial_amplitude``, ``coupling``,
            ``alpha``, ``dt``, ``hard_bounds``).
        optimizer: The brain optimizer plugin, each body's learner: ``"cmaes"`` (the default)
            or ``"nevergrad"``.
        optimizer_options: The brain optimizer's options (``nevergrad``: ``method``,
            ``budget``; ``cmaes``: none).
        popsize: Candidates per learner iteration (one batch of evaluations), >= 2.
        iterations: Learner iterations per new body, >= 1.
        sigma0: The learner's initial step size, > 0 (CMA-ES's sigma0; ``nevergrad``: the
            mutation scale of its parameters).
        inherit: Whether a child starts its learner from its first parent's best parameters
            when their count matches (else from random parameters).
        smoothing: Control smoothing in (0, 1] (the tutorial Controller's ``alpha``; 1 = none).
        control_period: Physics steps between controller calls, >= 1.
    """

    controller: Str = "na_cpg"
    options: dict[str, object] = Field(default_factory=dict)
    optimizer: Str = "cmaes"
    optimizer_options: dict[str, object] = Field(default_factory=dict)
    popsize: Int = Field(default=8, ge=2)
    iterations: Int = Field(default=6, ge=1)
    sigma0: Float = Field(default=1.0, gt=0.0)
    inherit: Bool = False
    smoothing: Float = Field(default=0.5, gt=0.0, le=1.0)
    control_period: Int = Field(default=50, ge=1)


class WorldConfig(_Section):
    """The world the robots are evaluated in.

    Attributes:
        name: The world plugin, ``"flat"`` by default.
        options: The world's options.
    """

    name: Str = "flat"
    options: dict[str, object] = Field(default_factory=dict)


class TaskConfig(_Section):
    """What an evaluation measures: ``fitness`` (a registered fitness function, with its
    ``options``) over ``duration`` seconds, after the robot was held ``settle`` seconds at
    zero controls to come to rest (docs/methodology.md); a run made before ``settle`` existed
    reads as ``settle = 0``.

    Attributes:
        fitness: The fitness plugin, ``"xy_displacement"`` by default (whether it is maximised
            is the plugin's).
        options: The fitness function's keyword arguments.
        duration: Simulated seconds per evaluation (measured after the settle), positive and
            finite.
        settle: Seconds each robot is first held at zero controls to come to rest, >= 0.
        spawn_position: Where robots are spawned, ``(x, y, z)`` in metres.
    """

    fitness: Str = "xy_displacement"
    options: dict[str, object] = Field(default_factory=dict)
    duration: Seconds = 10.0
    settle: Float = Field(default=1.0, ge=0.0)
    spawn_position: tuple[Float, Float, Float] = (0.0, 0.0, 0.0)


class RecordConfig(_Section):
    """What a run records besides its evaluations and bodies tables (docs/records.md).

    Attributes:
        rerun: Whether to write Rerun recordings: every generation's evaluations in one
            ``evaluations.rrd``, own recordings (``bodies``), ``run.rrd`` and the layouts.
        bodies: Which evaluations also get their own recording with the bodies' poses over
            time (a 3D replay): ``"elites"`` (the default: each new best of a body's brain run;
            any other evaluation's 3D replay is made on demand by `ariel view`, re-simulating
            it exactly), ``"all"`` or ``"none"``. It never changes a result (``all`` and
            ``elites`` build the same tasks), and a run's config (with this key) is stored
            resolved in run.json, so the default's change from ``all`` to ``elites`` leaves the
            config hash of every earlier run, and its resume, as it was.
        rate_hz: Frames recorded per simulated second, > 0. Fitness functions see these
            frames, so this is part of the experiment.
        trajectories: Whether to write the trajectories table.
    """

    rerun: Bool = True
    bodies: Literal["all", "elites", "none"] = "elites"
    rate_hz: Float = Field(default=10.0, gt=0.0)
    trajectories: Bool = True


def _known_executor_kind(kind: str) -> str:
    if kind not in executor_kinds:
        raise ValueError(f"must be an executor kind: {known_kinds()}")
    return kind


class ExecutorConfig(_Section):
    """Where evaluations run (docs/executors.md); none of it changes a finished evaluation.

    Attributes:
        kind: The executor: ``"serial"``, ``"local"`` (a process pool; the default),
            ``"dask"``, ``"gpu"`` (MuJoCo Warp) or another registered kind.
        workers: Worker processes, >= 1; None (the default): all CPUs.
        address: The address of a running Dask scheduler (``dask`` only), e.g.
            ``"tcp://host:8786"``; None: none. ``scheduler`` is its old name, still read.
        device: ``gpu`` only: MuJoCo Warp's device, ``"cuda"`` (the default) or ``"cpu"``
            (Warp's CPU device; slow, for tests). Unlike the other kinds, ``gpu`` does change
            results: float32 physics (docs/gpu.md).
        timeout: Seconds one evaluation may take before it is stopped and recorded as an
            ``error`` (a call of k evaluations gets k times as long); ``local`` kills the
            worker, Dask only stops waiting, ``serial`` has no timeout; at most
            `MAX_TIMEOUT_S`.
        max_retries: How often an evaluation whose worker process died is tried again
            (``local``, a Dask ``LocalCluster``), >= 0.
    """

    # A name in `ariel.evaluation.executors.executor_kinds` (built-in or registered).
    kind: Annotated[Str, AfterValidator(_known_executor_kind)] = "local"
    workers: Int | None = Field(default=None, ge=1)
    # Read under its old name ``scheduler`` too (a TOML file, ``--set``, an older run's config).
    address: Str | None = Field(default=None, validation_alias=AliasChoices("address", "scheduler"))
    # ``gpu`` only: MuJoCo Warp's device, "cuda", or "cpu" (Warp's CPU device; slow, for tests).
    # Unlike the other kinds, ``gpu`` does change results: float32 physics (docs/gpu.md).
    device: Literal["cuda", "cpu"] = "cuda"
    # At most ~11.6 days: longer waits overflowed the clocks of the pool and of Dask's threads
    # (a run that failed in its first generation, blaming its plugins).
    timeout: Seconds = Field(default=600.0, le=MAX_TIMEOUT_S)
    max_retries: Int = Field(default=2, ge=0)

    @model_validator(mode="before")
    @classmethod
    def _one_address(cls, data: object) -> object:
        if isinstance(data, Mapping) and "address" in data and "scheduler" in data:
            raise ValueError("give address or its old name scheduler, not both")
        return data


#: What an experiment's ``name`` may hold: it is part of its run ids and folder names.
NAME_PATTERN = r"^[A-Za-z0-9_.-]+$"


class ExperimentConfig(_Section):
    """One experiment: the whole validated config, as `load_config` makes it.

    Attributes:
        name: The experiment's name (letters, digits, ``_``, ``.``, ``-``); the run id starts
            with it.
        description: Free text.
        seed: The run seed, 0 <= seed < 2**63; every random decision of the run derives from
            it.
        generations: Generations, >= 1, counting the random first generation too; at most
            `MAX_GENERATIONS` (a generation's files are named with six digits).
        body: The body optimizer's section, ``[body]``.
        brain: The brain learners' section, ``[brain]``.
        world: The world's section, ``[world]``.
        task: The evaluation task's section, ``[task]``.
        record: What the run records besides its tables, ``[record]``.
        executor: Where evaluations run, ``[executor]`` (it never enters the config hash).
    """

    name: Str = Field(default="experiment", min_length=1, pattern=NAME_PATTERN)
    description: Str = ""
    seed: Int = Field(default=0, ge=0, lt=2**63)
    generations: Int = Field(default=10, ge=1, le=MAX_GENERATIONS)
    body: BodyConfig = Field(default_factory=BodyConfig)
    brain: BrainConfig = Field(default_factory=BrainConfig)
    world: WorldConfig = Field(default_factory=WorldConfig)
    task: TaskConfig = Field(default_factory=TaskConfig)
    record: RecordConfig = Field(default_factory=RecordConfig)
    executor: ExecutorConfig = Field(default_factory=ExecutorConfig)

    def to_plain(self) -> dict[str, Any]:
        """JSON-able dict (what run.json stores and `from_plain` reads back)."""
        return self.model_dump(mode="json")

    @classmethod
    def from_plain(cls, data: Mapping[str, object]) -> ExperimentConfig:
        """The config a run stored: keys added since read as they behaved before."""
        plain = plain_copy(dict(data), "config", 1)
        assert isinstance(plain, dict)  # a Mapping is copied to a dict
        for (section, key), neutral in _LATER_KEYS.items():
            if isinstance(plain.get(section), dict):
                plain[section].setdefault(key, neutral)
        return _validate(plain)


# Keys added after runs were made, with the value that behaves as before they existed: left out
# of the hash at that value, so the hash of an older run's config does not change.
_LATER_KEYS = {
    ("body", "optimizer"): "ga",
    ("body", "optimizer_options"): {},
    ("brain", "optimizer"): "cmaes",
    ("brain", "optimizer_options"): {},
    ("task", "settle"): 0.0,
}


def config_hash(config: ExperimentConfig) -> str:
    """SHA-256 of everything that decides results (the executor section does not)."""
    plain = config.to_plain()
    plain.pop("executor")
    for (section, key), neutral in _LATER_KEYS.items():
        if plain[section].get(key) == neutral:
            del plain[section][key]
    text = json.dumps(plain, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


# --------------------------------------------------------------------------------------------
# Errors: pydantic's first error -> one line
# --------------------------------------------------------------------------------------------


def _model_at(loc: Sequence[str]) -> type[BaseModel] | None:
    model: type[BaseModel] = ExperimentConfig
    for part in loc:
        field = model.model_fields.get(str(part))
        annotation = getattr(field, "annotation", None)
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            return None
        model = annotation
    return model


def _one_line(error: ValidationError) -> str:
    first = error.errors()[0]
    loc = [str(p) for p in first["loc"]]
    key = ".".join(loc) or "(top level)"
    if first["type"] == "extra_forbidden":
        parent = _model_at(loc[:-1])
        allowed = sorted(parent.model_fields) if parent is not None else []
        text = f"unknown key '{key}'; allowed: {', '.join(allowed)}"
        close = difflib.get_close_matches(loc[-1], allowed, n=1)
        return text + (f"; did you mean '{'.'.join([*loc[:-1], close[0]])}'?" if close else "")
    plain = _plain_words(first, loc)
    if plain is not None:
        return plain
    message = first["msg"]
    for prefix in ("Value error, ", "Input should be "):
        if message.startswith(prefix):
            message = ("must be " if prefix == "Input should be " else "") + message[len(prefix) :]
    given = first.get("input")
    shown = "" if isinstance(given, dict) else f" (got {given!r})"
    if first["type"] in TYPE_ERRORS and not isinstance(given, dict | list):
        # Strict types: say what the value was, e.g. a quoted "3" is a string in TOML.
        shown = f" (got {given!r}, {TOML_KIND.get(type(given), type(given).__name__)})"
    return f"{key}: {message}{shown}"


def _plain_words(first: ErrorDetails, loc: list[str]) -> str | None:
    """pydantic's words where they are its own rather than the config's ("Field required" for
    a list too short, a regular expression, "instance of BodyConfig"); else None."""
    given, kind = first.get("input"), first["type"]
    if kind == "missing" and loc and loc[-1].isdigit():  # a tuple's item: the list is short
        return f"{'.'.join(loc[:-1])}: too few values (got {given!r})"
    if kind == "too_long":
        most = first.get("ctx", {}).get("max_length")
        return f"{'.'.join(loc)}: too many values, at most {most} (got {given!r})"
    if kind == "string_pattern_mismatch" and first.get("ctx", {}).get("pattern") == NAME_PATTERN:
        return f"{'.'.join(loc)}: must be letters, digits, _ . - only (got {given!r})"
    if kind == "model_type":  # a section given as a value
        return f"{'.'.join(loc)}: must be a table ([{loc[-1]}] in TOML, a dict) (got {given!r})"
    return None


TYPE_ERRORS = {"int_type", "float_type", "bool_type", "string_type"}
TOML_KIND = {bool: "a boolean", str: "a string", float: "a float", int: "an integer"}


def _validate(data: Mapping[str, object]) -> ExperimentConfig:
    try:
        return ExperimentConfig.model_validate(dict(data))
    except ValidationError as exc:
        raise ConfigError(_one_line(exc)) from None


# --------------------------------------------------------------------------------------------
# Loading and --set overrides
# --------------------------------------------------------------------------------------------


def plain_copy(value: object, key: str, depth: int) -> object:
    """A deep copy of config data as a TOML file gives it: tables as dicts, arrays as lists,
    a NumPy scalar (``np.int64(5)`` from ``np.arange``) as its Python number; anything else is
    one `ConfigError` naming its key (json.dumps said "int64 is not JSON serializable").
    ``depth``: the tables and arrays ``value`` is in, itself counted if it is one; past
    `MAX_TOML_DEPTH` of them a `ConfigError`, as for a TOML file (walked no deeper)."""
    if depth > MAX_TOML_DEPTH and isinstance(value, Mapping | list | tuple):
        raise ConfigError(f"config: nested too deeply (at most {MAX_TOML_DEPTH} levels)")
    if isinstance(value, Mapping):
        copied = {}
        for name, item in value.items():
            if not isinstance(name, str):
                raise ConfigError(f"{key}: its keys must be strings, not {name!r}")
            copied[name] = plain_copy(item, name if key == "config" else f"{key}.{name}", depth + 1)
        return copied
    if isinstance(value, list | tuple):
        return [plain_copy(item, f"{key}[{i}]", depth + 1) for i, item in enumerate(value)]
    if value is None or isinstance(value, str | bool | int | float):
        return value
    if isinstance(value, np.generic):  # a NumPy scalar (not an array)
        return plain_copy(value.item(), key, depth)
    raise ConfigError(
        f"{key}: {type(value).__name__} is no config value type (numbers, strings, true and "
        "false, lists and tables are)"
    )
