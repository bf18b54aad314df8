"""Plugin registries: body encoders, worlds, controllers, fitness functions, and the body
and brain optimizers of the loop.

Configs, Parquet rows and worker payloads name their plugins by string; a `Registry` turns a
name back into the object, in the parent process and in every spawned worker alike.

Three ways in:

- Built in: a ``"module:attr"`` string per name in `BUILTIN_PLUGINS` (``ariel._builtin_names``),
  as Gymnasium's ``register(id, entry_point="pkg.mod:Cls")``. Nothing is imported until a
  name is first looked up, so importing this module imports no engine, MuJoCo or numpy.
- A script or test: ``@controllers.register("sine")`` on a class or function, or
  ``controllers.register("sine", SineController)`` (a ``"module:attr"`` string works too).
- A third-party package: an entry point in its ``pyproject.toml``::

      [project.entry-points."ariel.controllers"]
      my_ctrl = "my_pkg.module:MyController"

  Entry points are listed by `Registry.names` without importing anything and imported on
  first `Registry.get`.

Rules:

- A name has exactly one provider. Registering a taken name raises `DuplicatePluginError`
  (unless ``replace=True``, or the same ``module:attr`` is registered again, as happens when a
  module is reloaded).
- An entry point that reuses a registered name, or two installed distributions declaring the
  same name in one group, is an error too. It is raised when that name is looked up (`get`,
  `make`, `provenance`), not when the names are listed, so one broken third-party package
  cannot break unrelated names. ``register(name, obj, replace=True)`` overrides an entry point
  on purpose.
- Unknown names raise `UnknownPluginError` (a `KeyError` and a `ValueError`) listing the known
  names.

The plugin checkers (``check_body_encoder``, ``check_world``, ``check_controller``,
``check_fitness``) run the engine, so they live a layer up, in `ariel.evaluation`;
``ariel.plugins.check_*`` still gives them, imported on first use (and, from
`ariel.evolution`, ``check_body_optimizer`` / ``check_brain_optimizer`` and ``check_all``,
which checks every registered plugin of every kind).

This module holds the registries and gives every name above; the protocols of the kinds and
`fitness_function` are defined in ``ariel._plugin_kinds``, `Registry` in
``ariel._plugin_registry``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

from ariel._builtin_names import BUILTIN_PLUGINS
from ariel._plugin_kinds import (
    BodyEncoder as BodyEncoder,
    ClosedLoopController as ClosedLoopController,
    ControllerPlugin as ControllerPlugin,
    FitnessFunction as FitnessFunction,
    OpenLoopController as OpenLoopController,
    Policy as Policy,
    World as World,
    WorldFactory as WorldFactory,
    fitness_function as fitness_function,
)
from ariel._plugin_registry import (
    Registry as Registry,
    _resolve as _resolve,  # tests resolve the built-in names with it
)
from ariel.errors import (
    DuplicatePluginError,
    PluginCheckError,
    PluginLoadError,
    UnknownPluginError,
    cannot_vary,
)

__all__ = [
    "BUILTIN_PLUGINS",
    "ENTRY_POINT_GROUPS",
    "REGISTRIES",
    "BodyEncoder",
    "ClosedLoopController",
    "ControllerPlugin",
    "DuplicatePluginError",
    "FitnessFunction",
    "OpenLoopController",
    "PluginCheckError",
    "PluginLoadError",
    "Policy",
    "Registry",
    "UnknownPluginError",
    "World",
    "WorldFactory",
    "body_encoders",
    "body_optimizers",
    "brain_optimizers",
    "cannot_vary",
    "controllers",
    "fitness_function",
    "fitness_functions",
    "plugin_provenance",
    "refresh_all",
    "script_plugins",
    "worlds",
]


#: Entry-point group of each registry kind (the keys of `REGISTRIES`).
ENTRY_POINT_GROUPS: dict[str, str] = {
    "body_encoder": "ariel.body_encoders",
    "world": "ariel.worlds",
    "controller": "ariel.controllers",
    "fitness": "ariel.fitness",
    "body_optimizer": "ariel.body_optimizers",
    "brain_optimizer": "ariel.brain_optimizers",
}


# --------------------------------------------------------------------------------------------
# The registries
# --------------------------------------------------------------------------------------------


def _check_callable(obj: object) -> str | None:
    return None if callable(obj) else "must be callable (a class or factory function)"


def _check_fitness(obj: object) -> str | None:
    if not callable(obj):
        return "must be callable as fn(trajectory) -> float"
    if not isinstance(getattr(obj, "maximise", None), bool):
        return "needs a bool attribute 'maximise' (see ariel.plugins.fitness_function)"
    return None


body_encoders: Registry[Callable[..., BodyEncoder]] = Registry(
    "body_encoder",
    group=ENTRY_POINT_GROUPS["body_encoder"],
    builtins=BUILTIN_PLUGINS["body_encoder"],
    check=_check_callable,
)
worlds: Registry[WorldFactory] = Registry(
    "world",
    group=ENTRY_POINT_GROUPS["world"],
    builtins=BUILTIN_PLUGINS["world"],
    check=_check_callable,
)
controllers: Registry[Callable[..., ControllerPlugin]] = Registry(
    "controller",
    group=ENTRY_POINT_GROUPS["controller"],
    builtins=BUILTIN_PLUGINS["controller"],
    check=_check_callable,
)
fitness_functions: Registry[FitnessFunction] = Registry(
    "fitness",
    group=ENTRY_POINT_GROUPS["fitness"],
    builtins=BUILTIN_PLUGINS["fitness"],
    label="fitness function",
    check=_check_fitness,
)

#: Body optimizers (``body.optimizer``): classes made with ``encoder=``, ``seed=``,
#: ``maximise=``, ``settings=`` and the config's ``body.optimizer_options``; their interface is
#: `ariel.evolution.BodyOptimizer` (docs/evolution.md, "Body optimizers").
body_optimizers: Registry[Callable[..., Any]] = Registry(
    "body_optimizer",
    group=ENTRY_POINT_GROUPS["body_optimizer"],
    builtins=BUILTIN_PLUGINS["body_optimizer"],
    label="body optimizer",
    check=_check_callable,
)

#: Brain optimizers (``brain.optimizer``): each body's learner over its controller's parameters,
#: made with ``x0=``, ``popsize=``, ``sigma0=``, ``seed=``, ``maximise=`` and the config's
#: ``brain.optimizer_options``; their interface is `ariel.evolution.BrainOptimizer`
#: (docs/evolution.md, "Brain optimizers").
brain_optimizers: Registry[Callable[..., Any]] = Registry(
    "brain_optimizer",
    group=ENTRY_POINT_GROUPS["brain_optimizer"],
    builtins=BUILTIN_PLUGINS["brain_optimizer"],
    label="brain optimizer",
    check=_check_callable,
)

#: The registries by kind (the keys of `ENTRY_POINT_GROUPS`).
REGISTRIES: dict[str, Registry[Any]] = {
    "body_encoder": body_encoders,
    "world": worlds,
    "controller": controllers,
    "fitness": fitness_functions,
    "body_optimizer": body_optimizers,
    "brain_optimizer": brain_optimizers,
}


def refresh_all() -> None:
    """`Registry.refresh` on every registry (for tests)."""
    for registry in REGISTRIES.values():
        registry.refresh()


def plugin_provenance(names: Mapping[str, str]) -> dict[str, dict[str, str | None]]:
    """Provenance of one plugin per kind, e.g. ``{"controller": "na_cpg", ...}``, for run.json.

    Entry points are not imported for this.

    Args:
        names: Plugin name by kind; the kinds are keys of `REGISTRIES`.

    Returns:
        For each kind, `Registry.provenance` of its name: ``{"kind", "name", "source",
        "object", "distribution"}``.

    Raises:
        ValueError: A kind that is not a key of `REGISTRIES`.
        UnknownPluginError: A name no plugin of its kind has.
        DuplicatePluginError: A name that two providers serve.
    """
    result = {}
    for kind, name in names.items():
        if kind not in REGISTRIES:
            raise ValueError(f"unknown plugin kind '{kind}'; known: {', '.join(REGISTRIES)}")
        result[kind] = REGISTRIES[kind].provenance(name)
    return result


def script_plugins(provenance: object) -> list[tuple[str, str]]:
    """The plugins of a run that a new process (``ariel resume``) does not know: registered
    by a script, a notebook or a module of its own, rather than ariel's own or an installed
    entry point, as run.json's ``plugins`` (`plugin_provenance`) recorded them.

    Args:
        provenance: run.json's ``plugins``: for each kind, ``{"kind", "name", "source",
            "object", ...}``; anything else (an older or crafted run.json) counts as none.

    Returns:
        Each such plugin's kind (a key of `REGISTRIES`) and name, in the kinds' order.
    """
    found = []
    entries = provenance.values() if isinstance(provenance, Mapping) else ()
    for entry in entries:
        if not isinstance(entry, Mapping) or entry.get("source") != "registered":
            continue
        kind, name = entry.get("kind"), entry.get("name")
        module = str(entry.get("object", "")).partition(":")[0]
        if kind in REGISTRIES and isinstance(name, str) and module.partition(".")[0] != "ariel":
            found.append((kind, name))
    return found


# The checkers' home is `ariel.evaluation` (they run the engine, a layer above this one); the
# names here keep ``from ariel.plugins import check_all`` working, imported on first use from
# those packages' faces. Body and brain optimizers are checked in ariel.evolution (a layer
# above the engine), and so is the whole set, `check_all`, which includes them.
_CHECKS = dict.fromkeys(
    ("check_body_encoder", "check_controller", "check_fitness", "check_world"),
    "ariel.evaluation",
) | dict.fromkeys(
    ("check_body_optimizer", "check_brain_optimizer", "check_all"),
    "ariel.evolution",
)


def __getattr__(name: str) -> Any:
    if name in _CHECKS:
        value = getattr(importlib.import_module(_CHECKS[name]), name)
        globals()[name] = value  # cache: __getattr__ runs once per name
        return value
    raise AttributeError(f"module 'ariel.plugins' has no attribute {name!r}")
