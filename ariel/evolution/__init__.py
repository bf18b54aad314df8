"""Evolution: the co-evolution loop (body optimizers x brain optimizers), its configs, the
scheduler and the run driver.

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

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
    )
    from ariel.evolution._ga import (
        GeneticAlgorithm as GeneticAlgorithm,
    )
    from ariel.evolution._load_config import (
        load_config as load_config,
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
    from ariel.evolution._optimizer_checks import (
        check_all as check_all,
        check_body_optimizer as check_body_optimizer,
        check_brain_optimizer as check_brain_optimizer,
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
    from ariel.runs import (
        RunResult as RunResult,
        resume_experiment as resume_experiment,
        run_experiment as run_experiment,
    )

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.evolution._bodies import (
        BodyFactory as BodyFactory,
    )
    from ariel.evolution._brain import (
        fitness_rank as fitness_rank,
    )
    from ariel.evolution._checks import (
        ERROR_LOG as ERROR_LOG,
        check_plugins as check_plugins,
        check_resources as check_resources,
        machine_memory as machine_memory,
        no_main_guard_line as no_main_guard_line,
        plugin_named as plugin_named,
        refuse_in_spawned_child as refuse_in_spawned_child,
    )
    from ariel.evolution._config import (
        TOML_KIND as TOML_KIND,
        TYPE_ERRORS as TYPE_ERRORS,
        Int as Int,
        config_hash as config_hash,
    )
    from ariel.evolution._driver import (
        Plugins as Plugins,
        RunDriver as RunDriver,
        budget as budget,
        fixed_genotype as fixed_genotype,
        is_brain_only as is_brain_only,
    )
    from ariel.evolution._events import (
        BatchEvaluated as BatchEvaluated,
        BodyFailed as BodyFailed,
        CheckpointDue as CheckpointDue,
        FlushDue as FlushDue,
        GenerationEnded as GenerationEnded,
        GenerationStarted as GenerationStarted,
        RunEnded as RunEnded,
        RunEvent as RunEvent,
        RunObserver as RunObserver,
        RunStarted as RunStarted,
    )
    from ariel.evolution._genotype import (
        check_genotype as check_genotype,
        describe as describe,
        is_genotype_file as is_genotype_file,
        read_genotype_file as read_genotype_file,
    )
    from ariel.evolution._load_config import (
        not_a_file as not_a_file,
    )
    from ariel.evolution._overrides import (
        apply_overrides as apply_overrides,
        check_key as check_key,
        set_value as set_value,
    )
    from ariel.evolution._progress import (
        Progress as Progress,
        eta_text as eta_text,
        fmt_value as fmt_value,
        live_bars as live_bars,
        shows_progress as shows_progress,
    )
    from ariel.evolution._qd import (
        DEFAULT_MEASURES as DEFAULT_MEASURES,
        DEFAULT_RANGES as DEFAULT_RANGES,
        archive_quality as archive_quality,
    )
    from ariel.evolution._results_version import (
        RESULTS_VERSION as RESULTS_VERSION,
        results_version as results_version,
    )
    from ariel.evolution._scheduler import (
        run_groups as run_groups,
    )
    from ariel.evolution._state import (
        LoopState as LoopState,
        state_from_plain as state_from_plain,
    )
    from ariel.evolution._tasks import (
        body_spec as body_spec,
        evaluation_task as evaluation_task,
        record_steps as record_steps,
        shipped_body as shipped_body,
    )
    from ariel.evolution._toml import (
        read_toml_file as read_toml_file,
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
    "load_config": "ariel.evolution._load_config",
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
    # Every plugin checked, optimizers included (`ariel plugins --check`, ariel.plugins.check_all)
    "check_all": "ariel.evolution._optimizer_checks",
    "check_body_optimizer": "ariel.evolution._optimizer_checks",
    "check_brain_optimizer": "ariel.evolution._optimizer_checks",
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


# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "not_a_file": "ariel.evolution._load_config",
    "RESULTS_VERSION": "ariel.evolution._results_version",
    "results_version": "ariel.evolution._results_version",
    "BatchEvaluated": "ariel.evolution._events",
    "BodyFailed": "ariel.evolution._events",
    "CheckpointDue": "ariel.evolution._events",
    "FlushDue": "ariel.evolution._events",
    "GenerationEnded": "ariel.evolution._events",
    "GenerationStarted": "ariel.evolution._events",
    "RunEnded": "ariel.evolution._events",
    "RunEvent": "ariel.evolution._events",
    "RunObserver": "ariel.evolution._events",
    "RunStarted": "ariel.evolution._events",
    "BodyFactory": "ariel.evolution._bodies",
    "DEFAULT_MEASURES": "ariel.evolution._qd",
    "DEFAULT_RANGES": "ariel.evolution._qd",
    "ERROR_LOG": "ariel.evolution._checks",
    "Int": "ariel.evolution._config",
    "LoopState": "ariel.evolution._state",
    "Plugins": "ariel.evolution._driver",
    "Progress": "ariel.evolution._progress",
    "RunDriver": "ariel.evolution._driver",
    "TOML_KIND": "ariel.evolution._config",
    "TYPE_ERRORS": "ariel.evolution._config",
    "apply_overrides": "ariel.evolution._overrides",
    "archive_quality": "ariel.evolution._qd",
    "body_spec": "ariel.evolution._tasks",
    "budget": "ariel.evolution._driver",
    "check_genotype": "ariel.evolution._genotype",
    "check_key": "ariel.evolution._overrides",
    "check_plugins": "ariel.evolution._checks",
    "check_resources": "ariel.evolution._checks",
    "config_hash": "ariel.evolution._config",
    "describe": "ariel.evolution._genotype",
    "eta_text": "ariel.evolution._progress",
    "evaluation_task": "ariel.evolution._tasks",
    "fitness_rank": "ariel.evolution._brain",
    "fixed_genotype": "ariel.evolution._driver",
    "fmt_value": "ariel.evolution._progress",
    "is_brain_only": "ariel.evolution._driver",
    "is_genotype_file": "ariel.evolution._genotype",
    "live_bars": "ariel.evolution._progress",
    "machine_memory": "ariel.evolution._checks",
    "no_main_guard_line": "ariel.evolution._checks",
    "plugin_named": "ariel.evolution._checks",
    "read_genotype_file": "ariel.evolution._genotype",
    "read_toml_file": "ariel.evolution._toml",
    "record_steps": "ariel.evolution._tasks",
    "refuse_in_spawned_child": "ariel.evolution._checks",
    "run_groups": "ariel.evolution._scheduler",
    "set_value": "ariel.evolution._overrides",
    "shipped_body": "ariel.evolution._tasks",
    "shows_progress": "ariel.evolution._progress",
    "state_from_plain": "ariel.evolution._state",
}

__getattr__, __dir__ = lazy_face(__name__, _LAZY, _INTERNAL)
