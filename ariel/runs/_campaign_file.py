"""Campaign files: a base experiment, seeds, and conditions (named override sets and/or a
grid), validated into one experiment config per condition and seed.

```toml
name = "inheritance"
base = "../coevolve_flat.toml"      # a path relative to this file, or an inline [base] table
seeds = [1, 2, 3, 4, 5]             # or: seed_count = 5 (seeds 1..5)
seeding = "shared"                  # or "independent" (below)
set = { generations = 6 }           # overrides for every condition

[[condition]]
name = "inherit"
set = { "brain.inherit" = true }

[grid]                               # the cross product, named from its values
"brain.popsize" = [8, 16]
```

Conditions and a grid together give every condition crossed with every grid point. Every
problem is a `ConfigError`: one line naming the key, what was given and what is allowed.

Each run's folder is ``runs/condition=<name>/seed=<n>``, and a file system allows a name of at
most 255 bytes: a condition's name is at most `MAX_CONDITION_NAME` (245) characters, a
campaign's at most `MAX_CAMPAIGN_NAME` (239: its default folder is ``<name>-<date>-<time>``).
A longer name given in the file is refused; a longer name made from a grid's values (or a
condition crossed with a grid point) is cut to fit and ends in 8 hex digits of the SHA-256 of
the whole name, so names stay distinct.

A campaign has at most `MAX_RUNS` (10,000) runs (conditions x seeds), counted before any
condition or config is made: a grid of 1,000 x 1,000 values or ``seed_count = 1000000000`` is
refused in one line, not built (``max_runs`` of `campaign_spec` / `load_campaign_file` changes
the limit).

``seeding``: ``"shared"`` (the default): every condition runs the seeds as given (common random
numbers: generation 0 is the same in every condition, and `ariel compare` pairs the runs by
seed); ``"independent"``: condition i (0, 1, ... in the order of the campaign's conditions)
runs each seed + i x (max(seeds) - min(seeds) + 1), so no two conditions share a seed
(`condition_seeds`) and `ariel compare` treats the conditions as independent samples.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ariel.evolution import (
    TOML_KIND,
    TYPE_ERRORS,
    ConfigError,
    ExperimentConfig,
    Int,
    apply_overrides,
    check_key,
    load_config,
    not_a_file,
    read_toml_file,
    set_value,
)
from ariel.utils import ariel_line, path_argument

__all__ = [
    "MAX_CAMPAIGN_NAME",
    "MAX_CONDITION_NAME",
    "MAX_RUNS",
    "SEEDING",
    "CampaignSpec",
    "Condition",
    "condition_seeds",
    "load_campaign_file",
]

_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")
#: A file name's limit (bytes; a name here is ASCII), less ``condition=`` for a condition's
#: folder (as `ariel.recording.store._campaign` checks campaign.json) and less
#: ``-<date>-<time>`` for a campaign's default folder.
_NAME_MAX = 255
MAX_CONDITION_NAME = _NAME_MAX - len("condition=")
MAX_CAMPAIGN_NAME = _NAME_MAX - len("-20261124-101500")
#: The values of a campaign's ``seeding`` (the first is the default).
SEEDING = ("shared", "independent")
#: The most runs (conditions x seeds) a campaign may have unless the caller allows more: each
#: is a config in memory and a folder, and a campaign drives them all at once.
MAX_RUNS = 10_000


class _ConditionEntry(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(min_length=1, pattern=_NAME.pattern)
    description: str = ""
    set: dict[str, Any] = Field(default_factory=dict)


class _CampaignModel(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(default="campaign", min_length=1, pattern=_NAME.pattern)
    description: str = ""
    base: str | dict[str, Any]
    seeds: list[Int] | None = None  # strict, as the experiment's seed: not true, "3" or 2.0
    seed_count: Int | None = Field(default=None, ge=1)
    seeding: str = SEEDING[0]
    set: dict[str, Any] = Field(default_factory=dict)
    condition: list[_ConditionEntry] = Field(default_factory=list)
    grid: dict[str, list[Any]] = Field(default_factory=dict)

    @field_validator("seeding", mode="before")
    @classmethod
    def _known_seeding(cls, value: object) -> object:
        if value not in SEEDING:
            allowed = " or ".join(f'"{v}"' for v in SEEDING)
            raise ValueError(f"must be {allowed}")
        return value

    @model_validator(mode="after")
    def _one_seed_source(self) -> _CampaignModel:
        if (self.seeds is None) == (self.seed_count is None):
            raise ValueError("give either seeds = [..] or seed_count = N")
        return self


@dataclass(frozen=True)
class Condition:
    """One condition: its name and the overrides (dotted key -> value) it applies."""

    name: str
    set: dict[str, Any]
    description: str = ""


@dataclass(frozen=True)
class CampaignSpec:
    """A validated campaign: ``configs[(condition, seed)]`` is each run's experiment config
    (``seed``: the condition's own, see `condition_seeds`)."""

    name: str
    description: str
    base: dict[str, Any]  # the base experiment's raw data, campaign-wide ``set`` applied
    seeds: list[int]  # as the file gives them
    conditions: list[Condition]
    configs: dict[tuple[str, int], ExperimentConfig]
    seeding: str = SEEDING[0]
    base_name: str = "inline"  # the base experiment file as the campaign names it, or inline

    def seeds_of(self, condition: str) -> list[int]:
        """The seeds ``condition`` runs."""
        return [seed for name, seed in self.configs if name == condition]


def _one_line(error: ValidationError) -> str:
    first = error.errors()[0]
    key = ".".join(str(p) for p in first["loc"]) or "(top level)"
    if first["type"] == "extra_forbidden":
        fields = _ConditionEntry if first["loc"][0] == "condition" else _CampaignModel
        return f"unknown key '{key}'; allowed: {', '.join(sorted(fields.model_fields))}"
    message = first["msg"].removeprefix("Value error, ")
    message = message.replace("Input should be ", "must be ", 1)
    if first["type"] == "string_pattern_mismatch":  # the pattern is _NAME's: said in words
        message = "a name is ASCII letters, digits and . _ - (it names a folder)"
    given = first.get("input")
    shown = "" if isinstance(given, dict | list) else f" (got {given!r})"
    if first["type"] in TYPE_ERRORS and not isinstance(given, dict | list):
        # Strict types, as the experiment's: a quoted "3" is a string in TOML, 2.0 a float.
        shown = f" (got {given!r}, {TOML_KIND.get(type(given), type(given).__name__)})"
    return f"{key}: {message}{shown}"


def _base_data(base: str | dict[str, Any], beside: Path | None) -> dict[str, Any]:
    """The base experiment's raw data (a TOML file relative to the campaign file, a leading
    ``~`` the home folder as on the command line, or inline)."""
    if isinstance(base, dict):
        load_config(base)  # checked alone first: its errors name the base
        return json.loads(json.dumps(base))
    path = Path(base).expanduser()
    if not path.is_absolute() and beside is not None:
        path = beside / path
    if not path.is_file():
        raise ConfigError(f"base: experiment file {str(path)!r} not found")
    config = load_config(path)
    # The validated config as data (a genotype file named in it is read relative to it).
    return config.to_plain()


def _value_name(value: object) -> str:
    text = json.dumps(value) if not isinstance(value, str) else value
    text = {"true": "on", "false": "off"}.get(text, text)
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-") or "x"


def _grid_conditions(grid: Mapping[str, list[Any]]) -> list[Condition]:
    """The grid's cross product, each point named ``<last key part>-<value>`` joined by ``_``."""
    if not grid:
        return []
    keys = list(grid)
    short = [k.rsplit(".", 1)[-1] for k in keys]
    labels = short if len(set(short)) == len(short) else [k.replace(".", "-") for k in keys]
    for key, values in grid.items():
        check_key(key, f"grid: '{key}'")
        if not values:
            raise ConfigError(f"grid: '{key}' has no values; give a list of at least one")
    points = []
    for combination in itertools.product(*(grid[k] for k in keys)):
        name = "_".join(f"{label}-{_value_name(v)}" for label, v in zip(labels, combination))
        points.append(Condition(_fitted(name), dict(zip(keys, combination))))
    return points


def _fitted(name: str) -> str:
    """A name made from values, cut to `MAX_CONDITION_NAME` where longer: its start and 8 hex
    digits of the SHA-256 of the whole name (distinct names stay distinct)."""
    if len(name) <= MAX_CONDITION_NAME:
        return name
    digest = hashlib.sha256(name.encode()).hexdigest()[:8]
    return f"{name[: MAX_CONDITION_NAME - 9]}-{digest}"


def _check_name(name: str, key: str, limit: int, why: str) -> None:
    """A name given in the file: `ConfigError` when longer than ``limit``."""
    if len(name) > limit:
        raise ConfigError(
            f"{key}: name {name[:20]!r}... has {len(name)} characters; at most {limit} ({why}: "
            f"a file name, at most {_NAME_MAX} bytes)"
        )


def _conditions(model: _CampaignModel) -> list[Condition]:
    for index, entry in enumerate(model.condition):
        why = "its runs' folder is condition=<name>"
        _check_name(entry.name, f"condition.{index}", MAX_CONDITION_NAME, why)
    named = [Condition(c.name, dict(c.set), c.description) for c in model.condition]
    points = _grid_conditions(model.grid)
    if named and points:
        conditions = [
            Condition(_fitted(f"{c.name}_{p.name}"), {**c.set, **p.set}, c.description)
            for c in named
            for p in points
        ]
    else:
        conditions = named or points or [Condition("base", {})]
    seen: dict[str, str] = {}  # by casefold: the folders of 'Sigma' and 'sigma' are one on
    for condition in conditions:  # macOS and Windows (case-insensitive file systems)
        earlier = seen.get(condition.name.casefold())
        if earlier is not None and earlier != condition.name:
            raise ConfigError(
                f"condition: '{condition.name}' and '{earlier}' differ in case only; their "
                "folders would be one where case is not told apart (macOS, Windows): name "
                "them apart"
            )
        if earlier is not None:
            grid_clash = len({p.name for p in points}) < len(points)
            made = (
                " (made from grid values, which keep letters, digits, _ . - only: give those "
                "conditions names with [[condition]] entries)"
                if grid_clash
                else ""
            )
            raise ConfigError(
                f"condition: duplicate name '{condition.name}'{made}; every condition needs its own"
            )
        seen[condition.name.casefold()] = condition.name
    return conditions


def _valid(data: Mapping[str, object]) -> bool:
    """Whether ``data`` is a valid experiment config (the campaign's base, to tell whom a
    condition's error is due to)."""
    try:
        load_config(data)
    except ConfigError:
        return False
    return True


def _apply(
    data: dict[str, Any], changes: Mapping[str, Any], where: str, *, condition: bool = True
) -> dict[str, Any]:
    """``data`` with ``changes`` set; the executor (one for all runs) only campaign-wide."""
    result = json.loads(json.dumps(data))
    spelled: dict[str, str] = {}
    for key, value in changes.items():
        if key == "seed" or (condition and key.startswith("executor")):
            raise ConfigError(
                f"{where}: '{key}' cannot be set per condition (seeds come from seeds / "
                "seed_count; the executor is the campaign's: set it in the base or on the "
                "command line)"
            )
        set_value(result, key, value, f"{where}: '{key}'", spelled=spelled)
    return result


def _check_size(model: _CampaignModel, max_runs: int) -> None:
    """`ConfigError` when the campaign has more than ``max_runs`` runs, counted from the file's
    lists alone: nothing per run or per condition is made first."""
    seeds = len(model.seeds) if model.seeds is not None else int(model.seed_count or 0)
    points = math.prod(len(values) for values in model.grid.values()) if model.grid else 0
    named = len(model.condition)
    conditions = (named * points if named and points else named or points) or 1
    runs = conditions * seeds
    if runs > max_runs:
        raise ConfigError(
            f"campaign: {conditions} condition(s) x {seeds} seed(s) = {runs} runs; at most "
            f"{max_runs} runs a campaign: fewer grid values or seeds, or split it into "
            "smaller campaigns"
        )


def _seeds(model: _CampaignModel) -> list[int]:
    seeds = model.seeds if model.seed_count is None else list(range(1, model.seed_count + 1))
    if not seeds:
        raise ConfigError("seeds: the list is empty; give at least one seed (or seed_count = N)")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"seeds: duplicate seeds in {seeds}; give each seed once")
    return seeds


def condition_seeds(seeds: list[int], index: int, seeding: str) -> list[int]:
    """The seeds of the ``index``-th condition (from 0): ``seeds`` where they are shared, else
    each shifted by ``index`` x (max - min + 1), past every other condition's."""
    if seeding == "shared":
        return list(seeds)
    span = max(seeds) - min(seeds) + 1
    return [seed + index * span for seed in seeds]


def campaign_spec(
    data: Mapping[str, Any],
    *,
    beside: Path | None = None,
    overrides: tuple[str, ...] = (),
    max_runs: int = MAX_RUNS,
) -> CampaignSpec:
    """Validate a campaign's raw data (``beside``: the folder of its file, for ``base``);
    ``overrides``: ``key=value`` strings applied to the base (``--set``); ``max_runs``: the
    most runs (conditions x seeds) allowed, checked before any is made."""
    try:
        model = _CampaignModel.model_validate(dict(data))
    except ValidationError as exc:
        raise ConfigError(_one_line(exc)) from None
    _check_size(model, max_runs)
    why = "the campaign's default folder is <name>-<date>-<time>"
    _check_name(model.name, "name", MAX_CAMPAIGN_NAME, why)
    seeds = _seeds(model)
    base = _apply(_base_data(model.base, beside), model.set, "set", condition=False)
    base = apply_overrides(base, overrides)
    conditions = _conditions(model)
    configs: dict[tuple[str, int], ExperimentConfig] = {}
    for index, condition in enumerate(conditions):
        where = f"condition '{condition.name}'"
        raw = _apply(base, condition.set, where)
        for seed in condition_seeds(seeds, index, model.seeding):
            try:
                configs[(condition.name, seed)] = load_config({**raw, "seed": seed})
            except ConfigError as exc:  # the base's where it fails alone, else the condition's
                blame = where if _valid({**base, "seed": seed}) else "base (with set and --set)"
                raise ConfigError(f"{blame}: {exc}") from None
    base_name = model.base if isinstance(model.base, str) else "inline"
    return CampaignSpec(
        model.name,
        model.description,
        base,
        seeds,
        conditions,
        configs,
        seeding=model.seeding,
        base_name=base_name,
    )


def load_campaign_file(
    path: str | Path, overrides: tuple[str, ...] = (), *, max_runs: int = MAX_RUNS
) -> CampaignSpec:
    """Read and validate a campaign TOML file (see the module docstring); ``max_runs``: as
    `campaign_spec`'s."""
    path = path_argument("path", path, function="load_campaign_file")
    if not path.is_file():  # as `ariel run` says of an experiment file: never opened
        raise ConfigError(f"campaign file {str(path)!r} {not_a_file(path)}")
    data = read_toml_file(path)
    _refuse_experiment_file(data, path)
    return campaign_spec(data, beside=path.parent, overrides=overrides, max_runs=max_runs)


def _experiment_keys() -> list[str]:
    """Top-level keys of an experiment file that no campaign file has (it puts them in
    ``set``), in the experiment's order."""
    return [key for key in ExperimentConfig.model_fields if key not in _CampaignModel.model_fields]


def _refuse_experiment_file(data: Mapping[str, object], path: Path) -> None:
    """`ConfigError` saying which command takes ``path`` when it is an experiment file (an
    easy mix-up: both are TOML files under experiments/), rather than "base: Field required"."""
    found = [key for key in _experiment_keys() if key in data]
    if "base" not in data and found:
        raise ConfigError(
            f"{str(path)!r} is an experiment file (it has {', '.join(found)}), not a campaign: "
            f"run it with {ariel_line('run', path)}, or name it as a campaign file's base "
            "(docs/campaigns.md)"
        )
