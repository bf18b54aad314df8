"""Evaluation: evaluation tasks, the rollout engine, the executors that run them, and the
plugin checkers (they run the engine).

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.evaluation._checks import (
        check_all as check_all,
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
    # Plugin checkers (Gymnasium's check_env): they run the engine, so they live here.
    "check_all": "ariel.evaluation._checks",
    "check_body_encoder": "ariel.evaluation._checks",
    "check_controller": "ariel.evaluation._checks",
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


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'ariel.evaluation' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # cache: __getattr__ runs once per name
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
