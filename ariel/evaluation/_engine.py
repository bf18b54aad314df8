"""The rollout engine: evaluation tasks -> results, with physics as nearly all of the cost.

* A body is compiled once per process (`build`, cached) and every brain candidate of that body
  runs on that model.
* Open-loop controllers (the CPGs) are functions of time: the whole control sequence of every
  candidate is computed in numpy first, then all candidates step in C with `mujoco.rollout`
  across threads (GIL released).
* Closed-loop controllers step in chunks: ``mj_step(model, data, nstep=control_period)``
  between policy calls, never a Python callback per physics step.
* Control semantics are the tutorial `Controller`'s (same formula, `blend_and_clip`): the
  controller runs at physics steps ``k % control_period == 0``, its output is blended with the
  previous control by the task's ``smoothing`` (the tutorial's ``alpha``, 0.5) and clipped to
  the actuator ranges. Hence the fast path and the tutorial path give identical trajectories.
* Failures: the caller's mistakes (unknown plugin names, options a plugin rejects, a wrong
  number of parameters) raise at once. A genotype whose body cannot be built gives status
  ``error`` (`BodyBuildError` inside), physics instability (MuJoCo warnings such as bad
  accelerations, NaN or inf state) status ``unstable``, a fitness function that returns NaN or
  an infinity status ``invalid`` (the value's text in ``error``); all with the worst fitness.

This module holds the entry points (`evaluate`, `evaluate_batch`) and the grouping of tasks into
batches; the paths are its private siblings: ``_build`` (bodies), ``_rollouts`` (open loop),
``_closed_loop`` and ``_results`` (frames -> results). Their names are re-exported here.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ariel.errors import BodyBuildError as BodyBuildError
from ariel.evaluation._build import (
    _BUILD_CACHE as _BUILD_CACHE,
    SPAWN_PREFIX as SPAWN_PREFIX,
    BuiltBody as BuiltBody,
    _build_key as _build_key,
    _one_line as _one_line,
    build as build,
    make_plugin as make_plugin,
    robot_module as robot_module,
)
from ariel.evaluation._closed_loop import _closed_loop
from ariel.evaluation._heap import steady_heap
from ariel.evaluation._mujoco_log import MUJOCO_LOG_OFF
from ariel.evaluation._results import (
    TrajectoryRecord as TrajectoryRecord,
    _check_fitness_options,
    _error_result,
    _finish as _finish,
    frame_steps as frame_steps,
    num_steps as num_steps,
    worst_fitness as worst_fitness,
)
from ariel.evaluation._rollouts import (
    _open_loop as _open_loop,
    control_sequence as control_sequence,
    held_controls as held_controls,
    open_loop_targets as open_loop_targets,
)
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.evaluation._threads import evaluation_threads
from ariel.plugins import FitnessFunction, controllers, fitness_functions

__all__ = [
    "BodyBuildError",
    "BuiltBody",
    "TrajectoryRecord",
    "build",
    "control_sequence",
    "evaluate",
    "evaluate_batch",
    "frame_steps",
    "open_loop_targets",
    "worst_fitness",
]


def _group_key(task: EvaluationTask) -> str:
    return json.dumps(
        [
            _build_key(task),
            task.controller,
            task.controller_options,
            task.fitness,
            task.fitness_options,
            task.duration,
            task.control_period,
            task.smoothing,
            task.record_every,
            task.record_bodies,
        ],
        sort_keys=True,
    )


def evaluate_batch(
    tasks: Sequence[EvaluationTask], *, nthread: int | None = None
) -> list[EvaluationResult]:
    """Evaluate many tasks, compiling each body once; results in input order.

    Tasks that share a body, world, controller and timing run as one batch: open-loop ones in a
    single threaded rollout. Every group is checked before any physics runs. A body that cannot
    be built gives ``error`` results, unstable physics ``unstable`` ones.

    Args:
        tasks: The evaluation tasks, in any mix of bodies, worlds and controllers.
        nthread: Threads of an open-loop batch's rollout (at most one per task of the batch);
            None (the default): `evaluation_threads`, this process's share of the CPUs.

    Returns:
        One `EvaluationResult` per task, in the order of ``tasks``.

    Raises:
        TypeError: An item of ``tasks`` is not an `EvaluationTask`, or a plugin rejected its
            options (an unknown keyword).
        UnknownPluginError: A plugin name that nothing provides.
        ValueError: A task's params do not number the controller's ``num_parameters`` for its
            body, or a plugin rejected an option's value.

    Example:
        ```python
        import numpy as np

        from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch
        from ariel.plugins import controllers

        body = BodySpec("prebuilt", "gecko")
        model = build(EvaluationTask(body=body)).model
        params = controllers.make("na_cpg").random_parameters(model, np.random.default_rng(1), 4)
        tasks = [
            EvaluationTask(body=body, params=p, duration=2.0, eval_id=f"c{i}")
            for i, p in enumerate(params)
        ]
        for result in evaluate_batch(tasks):
            print(result.eval_id, result.status, round(result.fitness, 3))
        ```
    """
    steady_heap()  # each batch's arrays of megabytes come and go: keep the heap from growing
    if nthread is None:
        nthread = evaluation_threads()
    threads: int = nthread
    return evaluate_groups(
        tasks, lambda g: _open_loop(g.tasks, g.built, g.controller, g.fitness_fn, threads)
    )


def evaluate_groups(
    tasks: Sequence[EvaluationTask],
    open_loop: Callable[[TaskGroup], list[EvaluationResult]],
) -> list[EvaluationResult]:
    """Checks and groups ``tasks`` (`prepare_groups`), then runs every group: an open-loop one
    by ``open_loop`` (all its tasks), a closed-loop one task by task here; input order.
    MuJoCo logs nothing meanwhile (`MUJOCO_LOG_OFF`: no ``MUJOCO_LOG.TXT`` in the folder a
    run started from; the results say which simulations went unstable)."""
    with MUJOCO_LOG_OFF.held():
        results, ready = prepare_groups(tasks)
        for group in ready:
            for i, out in zip(group.indices, evaluate_group(group, open_loop)):
                results[i] = out
    return results  # type: ignore[return-value]


def evaluate_group(
    group: TaskGroup, open_loop: Callable[[TaskGroup], list[EvaluationResult]]
) -> list[EvaluationResult]:
    """One group's results: an open-loop group by ``open_loop``, a closed-loop one (a policy
    per controller call) on the CPU here, task by task."""
    if group.controller.open_loop:
        return open_loop(group)
    return [_closed_loop(t, group.built, group.controller, group.fitness_fn) for t in group.tasks]


@dataclass
class TaskGroup:
    """Tasks that share a body, world, controller and timing: they run as one batch."""

    indices: list[int]  # positions in the caller's list
    tasks: list[EvaluationTask]
    built: BuiltBody
    # A ControllerPlugin: its open_loop flag says which kind (OpenLoopController or
    # ClosedLoopController), which typing cannot narrow; the paths take the kind they run.
    controller: Any
    fitness_fn: FitnessFunction


def prepare_groups(
    tasks: Sequence[EvaluationTask],
) -> tuple[list[EvaluationResult | None], list[TaskGroup]]:
    """Group ``tasks`` into batches and check each before any physics runs.

    Returns the results known already (``error`` ones for bodies that cannot be built; None
    elsewhere) and the groups to run. Unknown plugin names, options a plugin rejects and wrong
    parameter counts raise.
    """
    groups: dict[str, list[int]] = {}
    for i, task in enumerate(tasks):
        if not isinstance(task, EvaluationTask):
            raise TypeError(f"tasks must be EvaluationTask objects, got {type(task).__name__}")
        groups.setdefault(_group_key(task), []).append(i)

    results: list[EvaluationResult | None] = [None] * len(tasks)
    ready: list[TaskGroup] = []
    for indices in groups.values():
        group = [tasks[i] for i in indices]
        head = group[0]
        controller = make_plugin(controllers, head.controller, head.controller_options)
        fitness_fn = fitness_functions.get(head.fitness)
        _check_fitness_options(head.fitness, fitness_fn, head.fitness_options)
        try:
            built = build(head)
        except BodyBuildError as exc:  # a genotype that cannot be built is a result
            for i, task in zip(indices, group):
                results[i] = _error_result(task, fitness_fn, exc)
            continue
        expected = controller.num_parameters(built.model)
        for task in group:
            if len(task.params) != expected:
                raise ValueError(
                    f"controller {task.controller!r} needs {expected} parameters for this body "
                    f"({built.model.nu} actuators); task {task.eval_id!r} has {len(task.params)}"
                )
        ready.append(TaskGroup(indices, group, built, controller, fitness_fn))
    return results, ready


def evaluate(task: EvaluationTask) -> EvaluationResult:
    """Evaluate one task (a pure function of the task).

    The same as ``evaluate_batch([task], nthread=1)[0]``: see `evaluate_batch` for what is
    checked and raised.

    Args:
        task: The evaluation to run: body, world, controller with its params, fitness.

    Returns:
        The task's result: fitness, status and the recorded frames.

    Example:
        ```python
        import numpy as np

        from ariel.evaluation import BodySpec, EvaluationTask, evaluate

        # The gecko has 8 actuators; the default controller, "na_cpg", takes 5 numbers each.
        params = np.random.default_rng(0).uniform(-1.0, 1.0, 40)
        task = EvaluationTask(body=BodySpec("prebuilt", "gecko"), params=params, duration=2.0)
        result = evaluate(task)
        print(result.status, result.fitness, result.core_pos[-1])
        ```
    """
    return evaluate_batch([task], nthread=1)[0]
