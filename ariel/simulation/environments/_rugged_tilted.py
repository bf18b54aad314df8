"""RuggedTiltedWorld: rugged Perlin terrain on a tilted heightfield."""

from __future__ import annotations

from ariel.simulation.environments._rugged import RuggedTerrainWorld

__all__ = ["RuggedTiltedWorld"]


class RuggedTiltedWorld(RuggedTerrainWorld):
    """RuggedTerrainWorld's terrain tilted by `floor_tilt` (default 15 degrees about x)."""

    name = "rugged-tilted-world"
    default_floor_tilt = (15.0, 0.0, 0.0)
