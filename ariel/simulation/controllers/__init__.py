"""Controllers: ``Controller`` (MuJoCo callback wrapper), ``NaCPG`` and ``SimpleCPG`` (torch,
tutorial API), the numpy NA-CPG kernel (``cpg_kernel``) that both the tutorial path and the
evaluation engine use, and ``hinge_observation``, what closed-loop controllers see by default.

Names load on first use, so importing ``cpg_kernel`` or ``controller`` never imports torch.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ariel.simulation.controllers.controller import (
        Controller,
        actuator_bounds,
        blend_and_clip,
    )
    from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
    from ariel.simulation.controllers.observations import hinge_observation
    from ariel.simulation.controllers.simple_cpg import SimpleCPG

__all__ = [
    "Controller",
    "NaCPG",
    "SimpleCPG",
    "actuator_bounds",
    "blend_and_clip",
    "create_fully_connected_adjacency",
    "hinge_observation",
]

_MODULES = {
    "Controller": "controller",
    "actuator_bounds": "controller",
    "blend_and_clip": "controller",
    "NaCPG": "na_cpg",
    "create_fully_connected_adjacency": "na_cpg",
    "hinge_observation": "observations",
    "SimpleCPG": "simple_cpg",
}


def __getattr__(name: str) -> Any:
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value  # cache: later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
