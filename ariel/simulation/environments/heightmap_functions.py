"""Heightmap helpers under upstream's module name; they live in
`ariel.simulation.environments.heightmaps`."""

from ariel.simulation.environments.heightmaps import (
    amphitheater_heightmap,
    amphitheatre_heightmap,
    crater_heightmap,
    flat_heightmap,
    rugged_heightmap,
    smooth_edges_heightmap,
)

__all__ = [
    "amphitheater_heightmap",
    "amphitheatre_heightmap",
    "crater_heightmap",
    "flat_heightmap",
    "rugged_heightmap",
    "smooth_edges_heightmap",
]
