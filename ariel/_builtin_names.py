"""The built-in plugins by name, as ``"module:attribute"`` strings (Gymnasium's entry_point).

`ariel.plugins` registers these strings and imports a plugin on its first lookup only, so
importing the registries imports no engine, no MuJoCo and no plugin module: the registry sits
below the code it names (see the layers in pyproject.toml), and naming it by string is what
lets it do so without an import cycle.

Each string names where the object is defined (``module:qualname``), so a run's provenance is
the same whether the object was registered by string or by itself
(``tests/test_plugins_registry.py`` checks that every string resolves to such an object).
To add a built-in, add one line to its kind's table. Third-party plugins do not go here: they
declare entry points in their own package (docs/plugins.md).
"""

from __future__ import annotations

__all__ = ["BUILTIN_PLUGINS"]

_ADAPTERS = "ariel.evaluation.builtin_plugins"
_WORLDS = "ariel.simulation.environments"

#: kind (a key of ``ariel.plugins.REGISTRIES``) -> name -> ``"module:attribute"``.
BUILTIN_PLUGINS: dict[str, dict[str, str]] = {
    "body_encoder": {
        # Each encoder lives beside the encoding it varies.
        "nde": "ariel.ec.genotypes.nde.encoder:NDEEncoder",
        "prebuilt": "ariel.body_phenotypes.robogen_lite.prebuilt_robots.encoder:PrebuiltEncoder",
        "graph": "ariel.body_phenotypes.robogen_lite.graph_encoder:GraphEncoder",
        "tree": "ariel.ec.genotypes.tree.encoder:TreeEncoder",
        "cppn": "ariel.body_phenotypes.robogen_lite.cppn_encoder:CPPNEncoder",
    },
    "world": {
        # The world classes are their own factories: ``SimpleFlatWorld(**options)``.
        "flat": f"{_WORLDS}._simple_flat:SimpleFlatWorld",
        "tilted": f"{_WORLDS}._simple_tilted:SimpleTiltedWorld",
        "rugged": f"{_WORLDS}._rugged:RuggedTerrainWorld",
        "rugged_tilted": f"{_WORLDS}._rugged_tilted:RuggedTiltedWorld",
        "crater": f"{_WORLDS}._crater:CraterTerrainWorld",
        "amphitheatre": f"{_WORLDS}._amphitheatre:AmphitheatreTerrainWorld",
        "olympic_arena": f"{_WORLDS}._olympic_arena:OlympicArena",
    },
    "controller": {
        "na_cpg": f"{_ADAPTERS}:NaCPGController",
        "mlp": f"{_ADAPTERS}:MLPController",
    },
    "body_optimizer": {
        # Above the registry's layer (ariel.evolution), hence named by string.
        "ga": "ariel.evolution._ga:GeneticAlgorithm",
        "map_elites": "ariel.evolution._map_elites:MapElites",
        "novelty": "ariel.evolution._novelty:NoveltySearch",
        "random": "ariel.evolution._random_search:RandomSearch",
    },
    "brain_optimizer": {
        # Above the registry's layer (ariel.evolution), hence named by string.
        "cmaes": "ariel.evolution._cmaes:CMAES",
        "nevergrad": "ariel.evolution._nevergrad:Nevergrad",
    },
    "fitness": {
        "xy_displacement": f"{_ADAPTERS}:xy_displacement",
        "sustained_displacement": f"{_ADAPTERS}:sustained_displacement",
        "x_speed": f"{_ADAPTERS}:x_speed",
        "distance_to_target": f"{_ADAPTERS}:distance_to_target",
        "turning_in_place": f"{_ADAPTERS}:turning_in_place",
    },
}
