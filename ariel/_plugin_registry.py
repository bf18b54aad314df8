"""`Registry`: names -> plugins of one kind, from ``register`` calls, ``"module:attr"`` strings
imported on first lookup, and installed distributions' entry points (`ariel.plugins` has the
rules and the registries themselves).

Also who provides a plugin (`Registry.provenance`: the object's ``module:attr`` and the
installed distribution it comes from), for run.json. `ariel.plugins` gives `Registry`;
import it from there.
"""

from __future__ import annotations

import difflib
import importlib
import re
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar, overload

from ariel import utils  # its face: `gl_backend_error` is loaded on a failure only
from ariel._version import __version__
from ariel.errors import DuplicatePluginError, PluginLoadError, UnknownPluginError
from ariel.utils.lazy import keeping_random_state

if TYPE_CHECKING:
    import importlib.metadata

__all__ = ["Registry"]

T = TypeVar("T")


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


def _path_and_distribution(path: str) -> str:
    """``module:attr (name==version)``, or the path alone where no installed distribution
    provides the module (a script's, a missing one's)."""
    found = _distribution_of_module(path.partition(":")[0])
    return f"{path} ({found})" if found is not None else path


def _distribution_of_module(module: str) -> str | None:
    """``name==version`` of the installed distribution providing ``module``, if any."""
    global _packages_cache
    import importlib.metadata  # lazy: ~20 ms at import, which workers need not pay

    top = module.partition(".")[0]
    if top == "ariel":
        try:
            return f"ariel=={importlib.metadata.version('ariel')}"
        except importlib.metadata.PackageNotFoundError:
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
                import importlib.metadata  # lazy: ~20 ms at import, which workers need not pay

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
            lambda: _path_and_distribution(path),
        )

    def _load(self, name: str, load: Callable[[], Any], where: Callable[[], str]) -> Any:
        """``load()``, checked; an error names the plugin and ``where()`` it came from (only
        then asked: finding a distribution's version reads package metadata)."""
        try:
            with keeping_random_state():  # nevergrad's import draws from both global generators
                obj = load()
        except Exception as exc:
            # A signal taken mid-import may come out wrapped (ctypes: "ArgumentError: argument
            # 1: Interrupted: 15"): then the interrupt is what happened, not a broken plugin.
            utils.raise_pending()
            gl = utils.gl_backend_error(exc)  # MUJOCO_GL failed mujoco's import, not the plugin
            if gl is not None:
                raise gl from exc
            raise PluginLoadError(
                f"could not load {self.label} '{name}' from {where()}: {type(exc).__name__}: {exc}"
            ) from exc
        problem = self._check(obj) if self._check is not None else None
        if problem is not None:
            raise PluginLoadError(f"{self.label} '{name}' from {where()} {problem}")
        return obj

    def make(self, name: str, /, **options: Any) -> Any:
        """``get(name)(**options)``: build a plugin instance from its factory (gymnasium style)."""
        factory = self.get(name)
        if not callable(factory):
            raise TypeError(f"{self.label} '{name}' is not callable; use get('{name}')")
        unknown = utils.unknown_option(factory, options)
        if unknown is not None:
            raise TypeError(unknown)
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
