"""Simulation worlds: ``BaseWorld`` and ready-made floors and terrains.

Every world builds a ``mujoco.MjSpec`` (``world.spec``), sets its timestep explicitly (default
0.002 s, implicitfast) and spawns robots with ``world.spawn(robot.spec, position=...)`` so that
their lowest point is 1 cm above the ground under them. ``world.ground_height(x, y)`` gives the
ground's height anywhere. Classes load on first use (this package imports only on demand),
and so do upstream's submodule attributes (``environments.heightmap_functions``).

The package's classes are exactly its worlds (no helper class such as ``typing.Any`` is in its
namespace): upstream's scripts instantiate every class that ``inspect.getmembers`` finds here.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ariel.simulation.environments._amphitheatre import AmphitheatreTerrainWorld
    from ariel.simulation.environments._base import BaseWorld
    from ariel.simulation.environments._compound import CompoundWorld
    from ariel.simulation.environments._crater import CraterTerrainWorld
    from ariel.simulation.environments._olympic_arena import OlympicArena
    from ariel.simulation.environments._rugged import RuggedTerrainWorld
    from ariel.simulation.environments._rugged_tilted import RuggedTiltedWorld
    from ariel.simulation.environments._simple_flat import SimpleFlatWorld
    from ariel.simulation.environments._simple_flat_with_target import SimpleFlatWorldWithTarget
    from ariel.simulation.environments._simple_tilted import SimpleTiltedWorld

__all__ = [
    "AmphitheatreTerrainWorld",
    "BaseWorld",
    "CompoundWorld",
    "CraterTerrainWorld",
    "OlympicArena",
    "RuggedTerrainWorld",
    "RuggedTiltedWorld",
    "SimpleFlatWorld",
    "SimpleFlatWorldWithTarget",
    "SimpleTiltedWorld",
]

_MODULES = {
    "AmphitheatreTerrainWorld": "_amphitheatre",
    "BaseWorld": "_base",
    "CompoundWorld": "_compound",
    "CraterTerrainWorld": "_crater",
    "OlympicArena": "_olympic_arena",
    "RuggedTerrainWorld": "_rugged",
    "RuggedTiltedWorld": "_rugged_tilted",
    "SimpleFlatWorld": "_simple_flat",
    "SimpleFlatWorldWithTarget": "_simple_flat_with_target",
    "SimpleTiltedWorld": "_simple_tilted",
}


# Public submodules reachable as attributes, as after upstream's eager imports.
_SUBMODULES = ("heightmap_functions", "heightmaps")


def __getattr__(name: str) -> object:
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")  # the import binds the attribute
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value  # cache: later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))
