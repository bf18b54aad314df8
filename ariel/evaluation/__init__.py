"""Evaluation: evaluation tasks, the rollout engine, the executors that run them, and the
plugin checkers (they run the engine).

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.evaluation._check_registered import (
        check_engine_plugins as check_engine_plugins,
    )
    from ariel.evaluation._checks import (
        check_body_encoder as check_body_encoder,
        check_controller as check_controller,
        check_fitness as check_fitness,
        check_world as check_world,
    )
    from ariel.evaluation._engine import (
        BodyBuildError as BodyBuildError,
        TrajectoryRecord as TrajectoryRecord,
        build as build,
        evaluate as evaluate,
        evaluate_batch as evaluate_batch,
    )
    from ariel.evaluation._task import (
        BodySpec as BodySpec,
        EvaluationResult as EvaluationResult,
        EvaluationTask as EvaluationTask,
    )
    from ariel.evaluation._warp import (
        WarpEvaluator as WarpEvaluator,
    )
    from ariel.evaluation.executors import (
        EXECUTOR_KINDS as EXECUTOR_KINDS,
        DaskExecutor as DaskExecutor,
        SerialExecutor as SerialExecutor,
        evaluation_threads as evaluation_threads,
        make_executor as make_executor,
        map_ordered as map_ordered,
    )

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.evaluation._check_registered import (
        check_rows as check_rows,
    )
    from ariel.evaluation._checks import (
        CHECK_SEED as CHECK_SEED,
        Checker as Checker,
        call_text as call_text,
    )
    from ariel.evaluation._engine import (
        SPAWN_PREFIX as SPAWN_PREFIX,
        frame_steps as frame_steps,
        make_plugin as make_plugin,
        robot_module as robot_module,
        worst_fitness as worst_fitness,
    )
    from ariel.evaluation._pool import (
        WORKER_CANNOT_START as WORKER_CANNOT_START,
        WorkerCannotStartError as WorkerCannotStartError,
    )
    from ariel.evaluation._task import (
        FAILED_STATUSES as FAILED_STATUSES,
        fitness_options_error as fitness_options_error,
    )
    from ariel.evaluation._threads import (
        default_workers as default_workers,
    )
    from ariel.evaluation._warp import (
        WarpUnavailableError as WarpUnavailableError,
    )
    from ariel.evaluation.executors import (
        known_kinds as known_kinds,
    )

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "BodyBuildError": "ariel.evaluation._engine",
    "BodySpec": "ariel.evaluation._task",
    "EvaluationResult": "ariel.evaluation._task",
    "EvaluationTask": "ariel.evaluation._task",
    "TrajectoryRecord": "ariel.evaluation._engine",
    "build": "ariel.evaluation._engine",
    "evaluate": "ariel.evaluation._engine",
    "evaluate_batch": "ariel.evaluation._engine",
    # Plugin checkers (Gymnasium's check_env): they run the engine, so they live here
    # (`ariel.evolution.check_all`, which adds the optimizers, a layer up).
    "check_body_encoder": "ariel.evaluation._checks",
    "check_controller": "ariel.evaluation._checks",
    "check_engine_plugins": "ariel.evaluation._check_registered",
    "check_fitness": "ariel.evaluation._checks",
    "check_world": "ariel.evaluation._checks",
    "EXECUTOR_KINDS": "ariel.evaluation.executors",
    "DaskExecutor": "ariel.evaluation.executors",
    "SerialExecutor": "ariel.evaluation.executors",
    "evaluation_threads": "ariel.evaluation.executors",
    "make_executor": "ariel.evaluation.executors",
    "map_ordered": "ariel.evaluation.executors",
    # MuJoCo Warp (``pip install 'ariel[gpu]'``); importing the name imports no Warp yet.
    "WarpEvaluator": "ariel.evaluation._warp",
}

__all__ = sorted(_LAZY)


# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "CHECK_SEED": "ariel.evaluation._checks",
    "FAILED_STATUSES": "ariel.evaluation._task",
    "Checker": "ariel.evaluation._checks",
    "SPAWN_PREFIX": "ariel.evaluation._engine",
    "WORKER_CANNOT_START": "ariel.evaluation._pool",
    "WarpUnavailableError": "ariel.evaluation._warp",
    "WorkerCannotStartError": "ariel.evaluation._pool",
    "call_text": "ariel.evaluation._checks",
    "check_rows": "ariel.evaluation._check_registered",
    "default_workers": "ariel.evaluation._threads",
    "fitness_options_error": "ariel.evaluation._task",
    "frame_steps": "ariel.evaluation._engine",
    "known_kinds": "ariel.evaluation.executors",
    "make_plugin": "ariel.evaluation._engine",
    "robot_module": "ariel.evaluation._engine",
    "worst_fitness": "ariel.evaluation._engine",
}

__getattr__, __dir__ = lazy_face(__name__, _LAZY, _INTERNAL)
