"""Evolution: the co-evolution loop (body optimizers x brain optimizers), its configs, the
scheduler and the run driver.

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.evolution._brain import (
        BrainOptimizer as BrainOptimizer,
        BrainRun as BrainRun,
        ToldHistory as ToldHistory,
        penalised_cost as penalised_cost,
        replay_told as replay_told,
    )
    from ariel.evolution._cmaes import (
        CMAES as CMAES,
    )
    from ariel.evolution._config import (
        BodyConfig as BodyConfig,
        BrainConfig as BrainConfig,
        ConfigError as ConfigError,
        ExecutorConfig as ExecutorConfig,
        ExperimentConfig as ExperimentConfig,
        RecordConfig as RecordConfig,
        TaskConfig as TaskConfig,
        WorldConfig as WorldConfig,
        load_config as load_config,
    )
    from ariel.evolution._ga import (
        GeneticAlgorithm as GeneticAlgorithm,
    )
    from ariel.evolution._map_elites import (
        MapElites as MapElites,
    )
    from ariel.evolution._nevergrad import (
        Nevergrad as Nevergrad,
    )
    from ariel.evolution._novelty import (
        NoveltySearch as NoveltySearch,
    )
    from ariel.evolution._optimizer import (
        BodyOptimizer as BodyOptimizer,
        Proposal as Proposal,
    )
    from ariel.evolution._random_search import (
        RandomSearch as RandomSearch,
    )
    from ariel.evolution._seeds import (
        derive_rng as derive_rng,
        derive_seed as derive_seed,
    )
    from ariel.evolution._state import (
        Body as Body,
    )
    from ariel.runs._experiment import (
        RunResult as RunResult,
        resume_experiment as resume_experiment,
        run_experiment as run_experiment,
    )

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "BodyConfig": "ariel.evolution._config",
    "BrainConfig": "ariel.evolution._config",
    "ConfigError": "ariel.evolution._config",
    "ExecutorConfig": "ariel.evolution._config",
    "ExperimentConfig": "ariel.evolution._config",
    "RecordConfig": "ariel.evolution._config",
    "TaskConfig": "ariel.evolution._config",
    "WorldConfig": "ariel.evolution._config",
    "load_config": "ariel.evolution._config",
    "BrainRun": "ariel.evolution._brain",
    "BrainOptimizer": "ariel.evolution._brain",
    "ToldHistory": "ariel.evolution._brain",
    "penalised_cost": "ariel.evolution._brain",
    "replay_told": "ariel.evolution._brain",
    "CMAES": "ariel.evolution._cmaes",
    "Nevergrad": "ariel.evolution._nevergrad",
    "Body": "ariel.evolution._state",
    "BodyOptimizer": "ariel.evolution._optimizer",
    "Proposal": "ariel.evolution._optimizer",
    "GeneticAlgorithm": "ariel.evolution._ga",
    "MapElites": "ariel.evolution._map_elites",
    "NoveltySearch": "ariel.evolution._novelty",
    "RandomSearch": "ariel.evolution._random_search",
    # The entry points live a layer up (`ariel.runs`: they tie a run folder to the driver);
    # these names stay here for the scripts that import them from ariel.evolution.
    "RunResult": "ariel.runs._experiment",
    "resume_experiment": "ariel.runs._experiment",
    "run_experiment": "ariel.runs._experiment",
    "derive_rng": "ariel.evolution._seeds",
    "derive_seed": "ariel.evolution._seeds",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'ariel.evolution' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
