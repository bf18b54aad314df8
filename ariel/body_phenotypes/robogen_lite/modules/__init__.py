"""Robogen-lite modules: core, brick and hinge (re-exported lazily to keep imports cheap)."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
    from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
    from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule
    from ariel.body_phenotypes.robogen_lite.modules.module import Module

__all__ = ["BrickModule", "CoreModule", "HingeModule", "Module"]

_WHERE = {
    "BrickModule": "brick",
    "CoreModule": "core",
    "HingeModule": "hinge",
    "Module": "module",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        module = importlib.import_module(f"{__name__}.{_WHERE[name]}")
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
