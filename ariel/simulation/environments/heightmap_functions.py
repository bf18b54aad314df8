"""Upstream's heightmap module: its five functions under its names and keywords
(``amphitheater_heightmap(dims, ring_inner_radius, ring_outer_radius, cone_height)``). They
live in `ariel.simulation.environments.heightmaps`, which also has our spelling
``amphitheatre_heightmap``; only upstream's names are here, as scripts list this module's
functions (``inspect.getmembers``) and call each by its ``__name__``."""

from ariel.simulation.environments.heightmaps import (
    amphitheater_heightmap,
    crater_heightmap,
    flat_heightmap,
    rugged_heightmap,
    smooth_edges_heightmap,
)

__all__ = [
    "amphitheater_heightmap",
    "crater_heightmap",
    "flat_heightmap",
    "rugged_heightmap",
    "smooth_edges_heightmap",
]
