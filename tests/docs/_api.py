"""The public API as the docs site documents it: every name in a public module's ``__all__``.

A public module is `ariel` or one whose dotted path has no part starting with an underscore
(`ariel.cli` is documented by the CLI reference instead). Shared by the docstring tests and the
site's API-reference test, and by ``docs/hooks.py`` through the same rule.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

import ariel

EXCLUDED = ("ariel.cli",)


def public_modules() -> list[ModuleType]:
    """`ariel` and its public submodules that define ``__all__``, in dotted-name order."""
    names = ["ariel"]
    for info in pkgutil.walk_packages(ariel.__path__, "ariel."):
        parts = info.name.split(".")
        if any(part.startswith("_") for part in parts[1:]):
            continue
        if any(info.name == e or info.name.startswith(e + ".") for e in EXCLUDED):
            continue
        names.append(info.name)
    modules = [importlib.import_module(name) for name in sorted(names)]
    return [module for module in modules if hasattr(module, "__all__")]


def public_names() -> dict[str, list[str]]:
    """Module name -> the names in its ``__all__``."""
    return {module.__name__: list(module.__all__) for module in public_modules()}
