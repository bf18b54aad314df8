"""Package faces that load their names on first use.

A package of ARIEL names what it offers in its ``__init__`` (its face), and the other packages
import only from there. Loading every module a face names would make ``import ariel`` pull in
pandas, pyarrow, MuJoCo and Rerun, so a face maps each name to the module that defines it and
`lazy_face` loads that module when the name is first used, leaving Python's global `random`
state as it was (`keeping_random_state`).
"""

from __future__ import annotations

import contextlib
import importlib
import random
import sys
from collections.abc import Callable, Iterator, Mapping
from typing import Any

__all__ = ["keeping_random_state", "lazy_face"]


@contextlib.contextmanager
def keeping_random_state() -> Iterator[None]:
    """Python's global `random` state, and NumPy's where NumPy is loaded, as they were before,
    after the block: libraries draw from them as they load (rich: ``getrandbits``; nevergrad
    advances both), so a script's ``random.seed(0)`` or ``np.random.seed(0)`` before using
    ariel no longer gave the same draws after.

    Returns:
        A context manager (a ``with`` block) that restores the states when it ends.
    """
    state = random.getstate()
    numpy = sys.modules.get("numpy")  # not loaded: nobody has seeded it, nothing to keep
    numpy_state = numpy.random.get_state() if numpy is not None else None
    try:
        yield
    finally:
        random.setstate(state)
        if numpy is not None:
            numpy.random.set_state(numpy_state)


def lazy_face(
    package: str, *tables: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of a package face.

    Args:
        package: The package's dotted name (its ``__name__``).
        *tables: Maps of name -> dotted name of the module that defines it: the package's public
            names (those in its ``__all__``) and the ones only ARIEL's other packages use.

    Returns:
        ``(__getattr__, __dir__)``: the first loads a name's module on first use and caches
        the value in the package (AttributeError for a name no table holds); the second lists
        the package's loaded names and every name of the tables.
    """
    names: dict[str, str] = {}
    for table in tables:
        names.update(table)

    def get(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        with keeping_random_state():  # loading it must not draw from the caller's random
            value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # cache: __getattr__ runs once per name
        return value

    def listing() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return get, listing
