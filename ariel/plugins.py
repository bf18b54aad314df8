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
"""

from __future__ import annotations

import difflib
import importlib
import re
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import (
    TYPE_CHECKING,
    Any,
    Generic,
    Protocol,
    TypeVar,
    overload,
    runtime_checkable,
)

from ariel._builtin_names import BUILTIN_PLUGINS
from ariel.errors import (
    DuplicatePluginError,
    PluginCheckError,
    PluginLoadError,
    UnknownPluginError,
    cannot_vary,
)

if TYPE_CHECKING:
    import importlib.metadata

    import mujoco
    import networkx as nx
    import numpy as np


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
    "worlds",
]

T = TypeVar("T")
F = TypeVar("F", bound=Callable[..., Any])

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
# Protocols, one per kind. The evaluation engine may refine the controller protocol.
# --------------------------------------------------------------------------------------------


@runtime_checkable
class BodyEncoder(Protocol):
    """Genotype operations of one body encoding; made by ``body_encoders.make(name, **options)``.

    Genotypes are plain data (numpy arrays, lists, dicts of those) so they can be stored in
    Parquet and sent to workers. Every operation draws only from the ``rng`` it is given.
    ``evolvable`` says whether ``mutate``/``crossover`` work: an encoder of fixed bodies (e.g.
    ``prebuilt``) sets it False and raises `NotImplementedError` from both (see `cannot_vary`);
    the co-evolution loop then evolves brains only. An encoder may also define
    ``build(genotype) -> CoreModule`` for bodies a graph cannot express; the engine then
    builds with it and uses ``decode`` only for the morphology descriptors. An encoder of
    array genotypes may declare their ``genotype_shape`` (e.g. ``(3, 64)``): a fixed genotype
    (``body.genotype``, perhaps from a file) is then checked against it before a run starts.
    """

    name: str
    evolvable: bool

    def random_genotype(self, rng: np.random.Generator) -> Any:
        """A new random genotype."""
        ...

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> Any:
        """A mutated copy of ``genotype`` (the input is left unchanged)."""
        ...

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> Any:
        """One child genotype from parents ``a`` and ``b``."""
        ...

    def decode(self, genotype: Any) -> nx.DiGraph:
        """The robot graph (the tutorial's module graph: a tree rooted at the core, node 0)."""
        ...


@runtime_checkable
class World(Protocol):
    """A world: an ``MjSpec`` to compile and a ``spawn`` that places a robot in it."""

    spec: mujoco.MjSpec

    def spawn(self, robot_spec: mujoco.MjSpec, *args: Any, **kwargs: Any) -> Any:
        """Attach ``robot_spec`` to the world (position, rotation: see the world's docs)."""
        ...


class WorldFactory(Protocol):
    """What the ``worlds`` registry holds: ``worlds.make(name, **options)`` gives a `World`."""

    def __call__(self, **options: Any) -> World: ...


@runtime_checkable
class ControllerPlugin(Protocol):
    """A brain family; made by ``controllers.make(name, **options)``.

    Parameters are flat float vectors; a batch is a ``(B, P)`` array. ``model`` is the compiled
    ``mujoco.MjModel`` of the robot in its world (``model.nu`` actuators). Whether the plugin
    is `OpenLoopController` or `ClosedLoopController` is said by ``open_loop``.
    """

    open_loop: bool

    def num_parameters(self, model: mujoco.MjModel) -> int:
        """Length P of one parameter vector for this body."""
        ...

    def random_parameters(
        self, model: mujoco.MjModel, rng: np.random.Generator, n: int
    ) -> np.ndarray:
        """``(n, P)`` random parameter vectors (e.g. CMA-ES initial means)."""
        ...


@runtime_checkable
class OpenLoopController(ControllerPlugin, Protocol):
    """Controls as a function of time only: the engine precomputes them, vectorised."""

    def targets(
        self, params: np.ndarray, sample_times: np.ndarray, model: mujoco.MjModel, *, seed: int
    ) -> np.ndarray:
        """Actuator targets ``(B, T, nu)`` for params ``(B, P)`` at ``sample_times`` ``(T,)``.

        ``seed`` is exactly one Python ``int``, the evaluation's seed (for e.g. an oscillator's
        random initial state: ``np.random.default_rng(seed)``). The engine groups a batch's
        candidates by seed and calls this once per distinct seed, so each row must depend only
        on its own parameters and the seed. An optional ``iter_targets(params, sample_times,
        model, *, seed, chunks)`` yields the same array in pieces along time.
        """
        ...


class Policy(Protocol):
    """One closed-loop brain with fixed parameters."""

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """Actuator targets ``(nu,)`` for one observation vector (built by the engine)."""
        ...


@runtime_checkable
class ClosedLoopController(ControllerPlugin, Protocol):
    """Controls from observations; the engine calls the policy once per control period."""

    def make_policy(self, params: np.ndarray, model: mujoco.MjModel) -> Policy:
        """A policy for one parameter vector ``(P,)``."""
        ...


@runtime_checkable
class FitnessFunction(Protocol):
    """Scores one evaluation's trajectory record; ``maximise`` says which way is better. An
    optional ``unit`` (a string such as ``"m"``) labels the fitness axes of `ariel report`."""

    maximise: bool

    def __call__(self, trajectory: Any) -> float: ...


def fitness_function(*, maximise: bool, unit: str | None = None) -> Callable[[F], F]:
    """Decorator that marks a plain function as a fitness function.

    It sets the function's ``maximise`` and ``unit`` attributes and returns the function
    itself; register it under a name to use it (``fitness_functions.register``).

    Args:
        maximise: True if larger values are better, False if smaller ones are.
        unit: The fitness's unit, e.g. ``"m"`` (it labels the fitness axes of ``ariel
            report``); None (the default) where it has none.

    Returns:
        The decorator: it takes the function and returns it, marked.

    Raises:
        TypeError: ``maximise`` is not a bool, or ``unit`` is neither a string nor None.

    Example:
        ```python
        from ariel.plugins import fitness_function, fitness_functions


        @fitness_functions.register("final_height")
        @fitness_function(maximise=True, unit="m")
        def final_height(record) -> float:  # the core's height at the end of the run
            return float(record.core_pos[-1, 2])


        print(final_height.maximise, final_height.unit)  # True m
        ```
    """
    if not isinstance(maximise, bool):
        raise TypeError(f"maximise must be True or False, not {maximise!r}")
    if unit is not None and not isinstance(unit, str):
        raise TypeError(f"unit must be a string or None, not {unit!r}")

    def mark(fn: F) -> F:
        fn.maximise = maximise  # type: ignore[attr-defined]
        fn.unit = unit  # type: ignore[attr-defined]
        return fn

    return mark


# --------------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------------


def _object_path(obj: object) -> str:
    """``module:qualname`` of a registered object (of its type for plain instances)."""
    module = getattr(obj, "__module__", None)
    qualname = getattr(obj, "__qualname__", None)
    if isinstance(module, str) and isinstance(qualname, str):
        return f"{module}:{qualname}"
    kind = type(obj)
    return f"{kind.__module__}:{kind.__qualname__}()"


def _has_own_path(obj: object) -> bool:
    """True for functions and classes: their ``module:qualname`` names one definition."""
    return isinstance(getattr(obj, "__qualname__", None), str)


_OBJECT_PATH = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")


def _resolve(path: str) -> Any:
    """The object a ``module:attr`` string names, importing its module (as an entry point)."""
    module, _, attribute = path.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attribute.split("."):
        obj = getattr(obj, part)
    return obj


_packages_lock = threading.Lock()
_packages_cache: dict[str, list[str]] | None = None


def _distribution_of_module(module: str) -> str | None:
    """``name==version`` of the installed distribution providing ``module``, if any."""
    global _packages_cache
    import importlib.metadata  # here, not at the top: ~20 ms that workers need not pay

    top = module.partition(".")[0]
    if top == "ariel":
        try:
            return f"ariel=={importlib.metadata.version('ariel')}"
        except importlib.metadata.PackageNotFoundError:
            from ariel._version import __version__

            return f"ariel=={__version__}"
    with _packages_lock:
        if _packages_cache is None:
            # Scans every installed distribution's file list: done once, and only for
            # provenance of objects registered from outside ariel.
            _packages_cache = importlib.metadata.packages_distributions()
        dists = _packages_cache.get(top, [])
    for dist in dists:
        try:
            return f"{dist}=={importlib.metadata.version(dist)}"
        except importlib.metadata.PackageNotFoundError:
            continue
    return None


def _distribution_of_entry_point(ep: importlib.metadata.EntryPoint) -> str | None:
    dist = getattr(ep, "dist", None)
    if dist is None:
        return None
    return f"{dist.name}=={dist.version}"


@dataclass(frozen=True)
class _Registered:
    """One registered name: its object, or only its ``module:attr`` until first looked up."""

    path: str
    obj: Any = None
    loaded: bool = True


class Registry(Generic[T]):
    """Names -> plugins of one kind, from ``register`` calls and from entry points.

    Args:
        kind: short id of the kind, e.g. ``"controller"``.
        group: entry-point group to discover, e.g. ``"ariel.controllers"``; None for none.
        builtins: name -> ``"module:attr"`` of the built-in plugins, registered now and each
            imported on its first lookup (``_builtin_names.BUILTIN_PLUGINS``).
        label: the kind as written in messages (default: ``kind`` with spaces).
        check: called as ``check(obj)`` on every registered or loaded object; returns an error
            text for an unusable object, or None.
    """

    def __init__(
        self,
        kind: str,
        *,
        group: str | None = None,
        builtins: Mapping[str, str] | None = None,
        label: str | None = None,
        check: Callable[[Any], str | None] | None = None,
    ) -> None:
        self.kind = kind
        self.group = group
        self.label = label if label is not None else kind.replace("_", " ")
        self._check = check
        # RLock: an entry point's module, imported under the lock, may register() here.
        self._lock = threading.RLock()
        self._registered: dict[str, _Registered] = {}
        self._overrides: set[str] = set()  # names registered with replace=True
        self._entry_points: dict[str, importlib.metadata.EntryPoint] | None = None
        self._entry_point_clashes: dict[str, str] = {}  # name -> error text
        self._loaded: dict[str, Any] = {}  # objects loaded from entry points
        for name, path in (builtins or {}).items():
            self.register(name, path)

    def __repr__(self) -> str:
        return f"Registry(kind={self.kind!r}, group={self.group!r})"

    # -- registration -------------------------------------------------------------------------

    @overload
    def register(
        self, name: str, obj: None = None, *, replace: bool = False
    ) -> Callable[[T], T]: ...

    @overload
    def register(self, name: str, obj: str, *, replace: bool = False) -> str: ...

    @overload
    def register(self, name: str, obj: T, *, replace: bool = False) -> T: ...

    def register(self, name: str, obj: T | str | None = None, *, replace: bool = False) -> Any:
        """Register ``obj`` under ``name``; without ``obj``, return a decorator that does.

        ``obj`` may be a ``"module:attr"`` string (Gymnasium's ``entry_point``): nothing is
        imported now; the first `get` imports the module and checks the object.
        ``replace=True`` overrides an existing registration or an installed entry point.
        """
        self._validate_name(name)
        if obj is None:

            def decorator(target: T) -> T:
                self._add(name, target, replace=replace)
                return target

            return decorator
        self._add(name, obj, replace=replace)
        return obj

    def unregister(self, name: str) -> T:
        """Remove a registered (not entry-point) name and return its object; for tests.

        A name registered as a ``"module:attr"`` string is imported to return its object.
        """
        with self._lock:
            if name not in self._registered:
                raise self._unknown(name)
            self._overrides.discard(name)
            removed = self._registered.pop(name)
        return removed.obj if removed.loaded else self._load_declared(name, removed.path)

    def _validate_name(self, name: object) -> None:
        if not isinstance(name, str) or not name or name != name.strip() or " " in name:
            raise ValueError(
                f"{self.label} name must be a non-empty string without spaces, got {name!r}"
            )

    def _entry(self, name: str, obj: Any) -> _Registered:
        """What registering ``obj`` stores: the checked object, or a ``module:attr`` string."""
        if isinstance(obj, str):
            if not _OBJECT_PATH.fullmatch(obj):
                raise ValueError(
                    f"{self.label} '{name}': {obj!r} is not a 'module:attribute' string"
                )
            return _Registered(obj, loaded=False)  # checked when first loaded
        path = _object_path(obj)
        problem = self._check(obj) if self._check is not None else None
        if problem is not None:
            raise TypeError(f"{self.label} '{name}' ({path}) {problem}")
        return _Registered(path, obj)

    def _add(self, name: str, obj: Any, *, replace: bool) -> None:
        entry = self._entry(name, obj)
        path = entry.path
        with self._lock:
            current = self._registered.get(name)
            # The same definition registered again (a reloaded module, or a built-in's object
            # over its "module:attr") is no clash; instances have no definition of their own.
            same_definition = (
                current is not None
                and current.path == path
                and (not entry.loaded or _has_own_path(obj))
            )
            if same_definition and not entry.loaded and not replace:
                return  # keep what is there: perhaps the object, loaded already
            if current is not None and not replace and not same_definition:
                raise DuplicatePluginError(
                    f"{self.label} '{name}' is already registered (by {current.path})"
                )
            if not replace and self._entry_points is not None and name in self._entry_points:
                ep = self._entry_points[name]
                if ep.value != path:
                    raise DuplicatePluginError(
                        f"{self.label} '{name}' is already provided by entry point {ep.value} "
                        f"({_distribution_of_entry_point(ep)}) in group '{self.group}'"
                    )
            self._registered[name] = entry
            if replace:
                self._overrides.add(name)

    # -- discovery ----------------------------------------------------------------------------

    def _discover(self) -> dict[str, importlib.metadata.EntryPoint]:
        found = self._entry_points
        if found is not None:
            return found
        with self._lock:
            if self._entry_points is not None:
                return self._entry_points
            found, clashes = {}, {}
            if self.group is not None:
                import importlib.metadata

                # Lists distribution metadata only; nothing is imported here.
                for ep in importlib.metadata.entry_points(group=self.group):
                    other = found.get(ep.name)
                    if other is None:
                        found[ep.name] = ep
                    elif other.value != ep.value:
                        clashes[ep.name] = (
                            f"{self.label} '{ep.name}' is declared by two entry points in group "
                            f"'{self.group}': {other.value} ({_distribution_of_entry_point(other)})"
                            f" and {ep.value} ({_distribution_of_entry_point(ep)}); "
                            "uninstall or rename one"
                        )
            self._entry_point_clashes = clashes
            self._entry_points = found
            return found

    def refresh(self) -> None:
        """Forget discovered entry points and the objects loaded from them (for tests).

        The next lookup discovers again; ``register``-ed names stay.
        """
        global _packages_cache
        with self._lock:
            self._entry_points = None
            self._entry_point_clashes = {}
            self._loaded.clear()
        with _packages_lock:
            _packages_cache = None
        # Path finders cache directory listings; a distribution added since must be seen.
        importlib.invalidate_caches()

    def _clash(self, name: str) -> str | None:
        """Error text when ``name`` has two providers, else None."""
        entry_points = self._discover()
        if name in self._entry_point_clashes and name not in self._overrides:
            return self._entry_point_clashes[name]
        registered = self._registered.get(name)
        ep = entry_points.get(name)
        if registered is None or ep is None or name in self._overrides:
            return None
        if ep.value == registered.path:  # the entry point names the registered object
            return None
        return (
            f"{self.label} '{name}' is provided twice: registered {registered.path} "
            f"({_distribution_of_module(registered.path.partition(':')[0])}) and entry point "
            f"{ep.value} ({_distribution_of_entry_point(ep)}) in group '{self.group}'; "
            "rename or uninstall one, or register with replace=True to override on purpose"
        )

    # -- lookup -------------------------------------------------------------------------------

    def names(self) -> list[str]:
        """Every known name, sorted; entry points are listed without being imported."""
        entry_points = self._discover()
        with self._lock:
            return sorted(set(self._registered) | set(entry_points))

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self.names())

    def _unknown(self, name: str) -> UnknownPluginError:
        known = self.names()
        message = f"unknown {self.label} '{name}'; known: {', '.join(known) or '(none)'}"
        close = difflib.get_close_matches(name, known, n=1)
        if close:
            message += f"; did you mean '{close[0]}'?"
        return UnknownPluginError(message)

    def get(self, name: str) -> T:
        """The plugin registered as ``name``; a ``module:attr`` string or an entry point is
        imported on first use."""
        clash = self._clash(name)
        if clash is not None:
            raise DuplicatePluginError(clash)
        with self._lock:
            registered = self._registered.get(name)
            if registered is None:
                return self._entry_point_object(name)
            if registered.loaded:
                return registered.obj
        # Imported outside the lock: a module being imported in another thread may look a
        # plugin up, and would wait for this lock while this thread waits for its import.
        obj = self._load_declared(name, registered.path)
        with self._lock:
            if self._registered.get(name) is registered:  # not replaced meanwhile
                self._registered[name] = _Registered(registered.path, obj)
        return obj

    def _entry_point_object(self, name: str) -> Any:
        """The object of entry point ``name``, loaded once (call with the lock held)."""
        if name in self._loaded:
            return self._loaded[name]
        ep = self._discover().get(name)
        if ep is None:
            raise self._unknown(name)
        obj = self._load(
            name, ep.load, lambda: f"entry point {ep.value} ({_distribution_of_entry_point(ep)})"
        )
        self._loaded[name] = obj
        return obj

    def _load_declared(self, name: str, path: str) -> Any:
        """The object a registered ``module:attr`` string names, imported and checked."""
        return self._load(
            name,
            lambda: _resolve(path),
            lambda: f"{path} ({_distribution_of_module(path.partition(':')[0])})",
        )

    def _load(self, name: str, load: Callable[[], Any], where: Callable[[], str]) -> Any:
        """``load()``, checked; an error names the plugin and ``where()`` it came from (only
        then asked: finding a distribution's version reads package metadata)."""
        try:
            obj = load()
        except Exception as exc:
            raise PluginLoadError(
                f"could not load {self.label} '{name}' from {where()}: {type(exc).__name__}: {exc}"
            ) from exc
        problem = self._check(obj) if self._check is not None else None
        if problem is not None:
            raise PluginLoadError(f"{self.label} '{name}' from {where()} {problem}")
        return obj

    def make(self, name: str, **options: Any) -> Any:
        """``get(name)(**options)``: build a plugin instance from its factory (gymnasium style)."""
        factory = self.get(name)
        if not callable(factory):
            raise TypeError(f"{self.label} '{name}' is not callable; use get('{name}')")
        return factory(**options)

    def provenance(self, name: str) -> dict[str, str | None]:
        """Who serves ``name``: ``{"kind", "name", "source", "object", "distribution"}``.

        ``object`` is ``module:attr``; ``distribution`` is ``name==version`` (None for an object
        registered from a script or test that no installed distribution provides). Entry
        points are not imported for this.
        """
        clash = self._clash(name)
        if clash is not None:
            raise DuplicatePluginError(clash)
        with self._lock:
            registered = self._registered.get(name)
            if registered is not None:
                return {
                    "kind": self.kind,
                    "name": name,
                    "source": "registered",
                    "object": registered.path,
                    "distribution": _distribution_of_module(registered.path.partition(":")[0]),
                }
            ep = self._discover().get(name)
            if ep is None:
                raise self._unknown(name)
            return {
                "kind": self.kind,
                "name": name,
                "source": "entry point",
                "object": ep.value,
                "distribution": _distribution_of_entry_point(ep),
            }


# --------------------------------------------------------------------------------------------
# The registries
# --------------------------------------------------------------------------------------------


def _check_callable(obj: Any) -> str | None:
    return None if callable(obj) else "must be callable (a class or factory function)"


def _check_fitness(obj: Any) -> str | None:
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
