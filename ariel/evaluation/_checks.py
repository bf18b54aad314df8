"""Plugin checkers, in the spirit of Gymnasium's ``check_env``: does a plugin keep its contract?

Each checker makes the plugin from its registry name, checks the protocol (attributes, methods,
types), determinism for a seed, shapes, and plain-data round trips, then runs a short
evaluation of the gecko (``BodySpec("prebuilt", "gecko")``, flat world, 0.5 simulated
seconds). The first problem raises `PluginCheckError` with one line naming the plugin and what
failed. Exposed as ``ariel.evaluation.check_*`` (and, as before, ``ariel.plugins.check_*``),
both imported on first use: this module needs MuJoCo. Every registered name of these kinds:
`ariel.evaluation._check_registered.check_engine_plugins`.

Worlds and fitness functions are checked with the gecko driven by `NaCPGController` itself,
scored by `xy_displacement` itself, not by whatever the registries now hold under "na_cpg" and
"xy_displacement": a user may replace those names, and a check of one plugin must not fail
for the faults of another.

The machinery every check uses (`Checker`, the reference body and run):
`ariel.evaluation._check_tools`, its names re-exported here.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
from collections.abc import Callable
from typing import Any

import mujoco
import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.prebuilt_robots import PREBUILT_ROBOTS
from ariel.evaluation._build import _one_line, build
from ariel.evaluation._check_tools import (
    CHECK_BODY as CHECK_BODY,
    CHECK_CANDIDATES as CHECK_CANDIDATES,
    CHECK_DURATION as CHECK_DURATION,
    CHECK_SEED as CHECK_SEED,
    Checker as Checker,
    _decoded,
    _expect_bool,
    _expect_methods,
    _expect_same_results,
    _gecko_params,
    _plain_round_trip,
    _rng,
    _run_gecko,
    _same,
    call_text as call_text,
)
from ariel.evaluation._engine import TaskGroup, evaluate_group
from ariel.evaluation._mujoco_log import MUJOCO_LOG_OFF
from ariel.evaluation._results import TrajectoryRecord, num_steps, read_only
from ariel.evaluation._rollouts import _open_loop
from ariel.evaluation._task import BodySpec, EvaluationResult, EvaluationTask
from ariel.evaluation.builtin_plugins import xy_displacement
from ariel.plugins import (
    BodyEncoder,
    ClosedLoopController,
    body_encoders,
    controllers,
    fitness_functions,
    worlds,
)
from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.controllers.observations import hinge_observation

__all__ = ["check_body_encoder", "check_controller", "check_fitness", "check_world"]

# --------------------------------------------------------------------------------------------
# Body encoders
# --------------------------------------------------------------------------------------------


def check_body_encoder(name: str, /, **options: Any) -> None:
    """Check body encoder ``name`` made with ``options``; raise `PluginCheckError` if broken.

    Protocol (``name``, bool ``evolvable``, the four methods); ``random_genotype`` is
    deterministic for a seed and plain data (JSON) whose decoding equals the original's; the
    genotype decodes to a valid robot graph and builds, and has the ``genotype_shape`` the
    encoder declares (if it declares one). Evolvable encoders: ``mutate`` returns
    a new, different genotype, deterministically, and leaves its input unchanged; ``crossover``
    leaves its parents unchanged and gives a child that decodes. Encoders with ``evolvable =
    False``: ``mutate`` and ``crossover`` raise `NotImplementedError`.

    Args:
        name: The body encoder's registry name (an entry point's name works too).
        **options: Keyword arguments passed to the encoder's factory, as in a config's body
            options.

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the encoder itself, or an unknown ``name``, included).
    """
    check = Checker("body encoder", name)
    with check.step(call_text(options)):
        encoder = body_encoders.make(name, **options)
    check.expect(isinstance(getattr(encoder, "name", None), str), "needs a str attribute 'name'")
    _expect_bool(check, encoder, "evolvable")
    _expect_methods(check, encoder, ("random_genotype", "mutate", "crossover", "decode"))

    with check.step("random_genotype(rng)"):
        genotype = encoder.random_genotype(_rng())
        again = encoder.random_genotype(_rng())
    plain = _plain_round_trip(check, genotype, "random")
    check.expect(
        _same(genotype, again), "random_genotype is not deterministic: one rng seed, two genotypes"
    )
    graph = _decoded(check, encoder, genotype, "a random genotype")
    check.expect(
        nx.utils.graphs_equal(graph, _decoded(check, encoder, plain, "its plain-data form")),
        "a genotype and its plain-data (JSON) form decode to different graphs",
    )
    with check.step("building the body of a random genotype"):
        build(EvaluationTask(body=BodySpec(name, plain, options)))
    shape = getattr(encoder, "genotype_shape", None)
    if shape is not None:  # what a fixed body.genotype is checked against
        found = np.shape(plain)
        check.expect(
            found == tuple(shape),
            f"genotype_shape is {tuple(shape)} but random_genotype gives shape {found}",
        )

    if encoder.evolvable:
        _check_variation(check, encoder, genotype, plain)
    else:
        _check_refuses_variation(check, encoder, genotype)


def _check_variation(check: Checker, encoder: BodyEncoder, genotype: Any, plain: Any) -> None:
    before = copy.deepcopy(genotype)
    with check.step("mutate(genotype, rng)"):
        child = encoder.mutate(genotype, _rng())
        again = encoder.mutate(genotype, _rng())
        from_plain = encoder.mutate(plain, _rng())
    check.expect(_same(genotype, before), "mutate changed its input genotype in place")
    check.expect(not _same(child, genotype), "mutate returned a genotype equal to its input")
    check.expect(_same(child, again), "mutate is not deterministic: one rng seed, two children")
    check.expect(
        _same(child, from_plain), "mutate gives another child for the plain-data (JSON) genotype"
    )
    _plain_round_trip(check, child, "mutated")
    _decoded(check, encoder, child, "a mutated genotype")

    with check.step("random_genotype(rng)"):
        other = encoder.random_genotype(_rng(CHECK_SEED + 1))
    other_before = copy.deepcopy(other)
    with check.step("crossover(a, b, rng)"):
        child = encoder.crossover(genotype, other, _rng())
        again = encoder.crossover(genotype, other, _rng())
    check.expect(
        _same(genotype, before) and _same(other, other_before),
        "crossover changed a parent genotype in place",
    )
    check.expect(_same(child, again), "crossover is not deterministic: one rng seed, two children")
    _plain_round_trip(check, child, "crossover child's")
    _decoded(check, encoder, child, "a crossover child")


def _check_refuses_variation(check: Checker, encoder: BodyEncoder, genotype: Any) -> None:
    calls: dict[str, Callable[[], object]] = {
        "mutate": lambda: encoder.mutate(genotype, _rng()),
        "crossover": lambda: encoder.crossover(genotype, genotype, _rng()),
    }
    for operation, call in calls.items():
        try:
            call()
        except NotImplementedError:
            continue
        except Exception as exc:
            check.fail(
                f"{operation} raised {_one_line(exc)}; with evolvable = False it must raise "
                "NotImplementedError (see ariel.plugins.cannot_vary)"
            )
        check.fail(
            f"{operation} returned a genotype although evolvable is False; it must raise "
            "NotImplementedError (see ariel.plugins.cannot_vary)"
        )


# --------------------------------------------------------------------------------------------
# Worlds
# --------------------------------------------------------------------------------------------


def _model_bytes(model: mujoco.MjModel) -> bytes:
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def check_world(name: str, /, **options: Any) -> None:
    """Check world ``name`` made with ``options``; raise `PluginCheckError` if broken.

    Protocol (``spec`` is a ``mujoco.MjSpec``, ``spawn``); two worlds made with the same
    options and the gecko spawned in each compile to identical models (no hidden randomness);
    the gecko runs in it, stable, with a finite fitness.

    Args:
        name: The world's registry name (an entry point's name works too).
        **options: Keyword arguments passed to the world's factory (a task's
            ``world_options``).

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the world itself, or an unknown ``name``, included).
    """
    check = Checker("world", name)
    models = []
    for _ in range(2):
        with check.step(call_text(options)):
            world = worlds.make(name, **options)
        check.expect(
            isinstance(getattr(world, "spec", None), mujoco.MjSpec),
            "needs an attribute 'spec' holding a mujoco.MjSpec",
        )
        _expect_methods(check, world, ("spawn",))
        with check.step("spawning the gecko and compiling"):
            world.spawn(PREBUILT_ROBOTS["gecko"]().spec, position=(0, 0, 0), rotation=(0, 0, 0))
            with control_callback_unset():
                models.append(_model_bytes(world.spec.compile()))
    check.expect(
        models[0] == models[1],
        "two worlds made with the same options compile to different models (seed the world)",
    )
    tasks = [
        EvaluationTask(
            body=CHECK_BODY,
            world=name,
            world_options=options,
            params=p,
            duration=CHECK_DURATION,
            seed=CHECK_SEED,
        )
        for p in _gecko_params()
    ]
    with check.step("evaluating the gecko"):
        results = _run_gecko(tasks, xy_displacement)
    for result in results:
        check.expect(result.ok, f"the gecko's evaluation ended {result.status!r}: {result.error}")
        check.expect(
            math.isfinite(result.fitness) and np.all(np.isfinite(result.core_pos)),
            "the gecko's evaluation gave a non-finite fitness or trajectory",
        )


# --------------------------------------------------------------------------------------------
# Controllers
# --------------------------------------------------------------------------------------------


def check_controller(name: str, /, **options: Any) -> None:
    """Check controller ``name`` made with ``options`` on the gecko; raise `PluginCheckError`.

    Protocol (bool ``open_loop``, the methods of its kind); ``num_parameters`` is a whole
    number P; ``random_parameters(model, rng, n)`` is ``(n, P)``, finite and deterministic for
    a seed. Open loop: ``targets`` is ``(B, T, nu)``, finite, deterministic for a seed, each row
    independent of the others (batch = single), and ``iter_targets`` (if any) yields the same
    in pieces. Closed loop: a policy maps an observation to ``(nu,)`` finite targets,
    deterministically. Evaluations of the gecko run stable and repeat bit for bit.

    Args:
        name: The controller's registry name (an entry point's name works too).
        **options: Keyword arguments passed to the controller's factory (a task's
            ``controller_options``).

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the controller itself, or an unknown ``name``, included).
    """
    check = Checker("controller", name)
    with check.step(call_text(options)):
        controller = controllers.make(name, **options)
    _expect_bool(check, controller, "open_loop")
    open_loop = controller.open_loop
    kind_methods = ("targets",) if open_loop else ("make_policy",)
    _expect_methods(check, controller, ("num_parameters", "random_parameters", *kind_methods))

    model = build(EvaluationTask(body=CHECK_BODY)).model
    with check.step("num_parameters(model)"):
        size = controller.num_parameters(model)
    check.expect(
        isinstance(size, numbers.Integral) and not isinstance(size, bool) and size >= 0,
        f"num_parameters(model) returned {size!r}, not a whole number >= 0",
    )
    n = CHECK_CANDIDATES
    with check.step(f"random_parameters(model, rng, {n})"):
        params = np.asarray(controller.random_parameters(model, _rng(), n), dtype=np.float64)
        again = np.asarray(controller.random_parameters(model, _rng(), n), dtype=np.float64)
    check.expect(
        params.shape == (n, size),
        f"random_parameters(model, rng, {n}) has shape {params.shape}; expected {(n, size)} "
        "(n, num_parameters)",
    )
    check.expect(np.all(np.isfinite(params)), "random_parameters returned NaN or inf")
    check.expect(
        np.array_equal(params, again), "random_parameters is not deterministic for an rng seed"
    )
    if open_loop:
        _check_targets(check, controller, params, model)
    else:
        _check_policy(check, controller, params, model)

    tasks = [
        EvaluationTask(
            body=CHECK_BODY,
            controller=name,
            controller_options=options,
            params=p,
            duration=CHECK_DURATION,
            seed=CHECK_SEED,
        )
        for p in params
    ]
    with check.step("evaluating the gecko"):
        first, again_results = (_run_controller(tasks, controller, n) for n in (2, 1))
    _expect_same_results(check, first, again_results)


def _run_controller(
    tasks: list[EvaluationTask], controller: Any, nthread: int
) -> list[EvaluationResult]:
    """`evaluate_batch` of ``tasks`` (the gecko, one controller), given the controller and
    `xy_displacement` as objects: another "xy_displacement" (a clashing entry point) cannot
    fail a controller's check, as it cannot a world's (`_run_gecko`)."""
    group = TaskGroup(list(range(len(tasks))), tasks, build(tasks[0]), controller, xy_displacement)
    with MUJOCO_LOG_OFF.held():
        return evaluate_group(
            group, lambda g: _open_loop(g.tasks, g.built, g.controller, g.fitness_fn, nthread)
        )


def _check_targets(
    check: Checker,
    controller: Any,  # an OpenLoopController, maybe with iter_targets (not in the protocol)
    params: np.ndarray,
    model: mujoco.MjModel,
) -> None:
    task = EvaluationTask(body=CHECK_BODY, duration=CHECK_DURATION)
    times = np.arange(0, num_steps(task, model), task.control_period) * model.opt.timestep
    expected = (params.shape[0], times.size, model.nu)
    with check.step("targets(params, sample_times, model, seed=...)"):
        targets = np.asarray(controller.targets(params, times, model, seed=CHECK_SEED))
        again = np.asarray(controller.targets(params, times, model, seed=CHECK_SEED))
        single = np.asarray(controller.targets(params[1:2], times, model, seed=CHECK_SEED))
    check.expect(
        targets.shape == expected,
        f"targets() has shape {targets.shape}; expected {expected} (candidates, times, actuators)",
    )
    check.expect(np.all(np.isfinite(targets)), "targets() returned NaN or inf")
    check.expect(
        np.array_equal(targets, again), "targets() is not deterministic for one seed and params"
    )
    check.expect(
        single.shape == (1, *expected[1:]) and np.array_equal(single, targets[1:2]),
        "targets() of one candidate differ when other candidates share the batch",
    )
    if callable(getattr(controller, "iter_targets", None)):
        sizes = [1, times.size - 1]
        with check.step("iter_targets(..., chunks=[1, T - 1])"):
            pieces = list(
                controller.iter_targets(params, times, model, seed=CHECK_SEED, chunks=sizes)
            )
        joined = np.concatenate([np.asarray(p) for p in pieces], axis=1) if pieces else None
        check.expect(
            [np.shape(p)[1] for p in pieces] == sizes and np.array_equal(joined, targets),
            "iter_targets() pieces differ from targets() (or have the wrong sizes)",
        )


def _check_policy(
    check: Checker, controller: ClosedLoopController, params: np.ndarray, model: mujoco.MjModel
) -> None:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    observe = getattr(controller, "observation", hinge_observation)
    with check.step("make_policy(params, model) and policy(observation)"):
        observation = np.asarray(observe(model, data), dtype=np.float64)
        out = np.asarray(controller.make_policy(params[0], model)(observation.copy()))
        again = np.asarray(controller.make_policy(params[0], model)(observation.copy()))
    check.expect(
        out.shape == (model.nu,), f"policy output has shape {out.shape}; expected ({model.nu},)"
    )
    check.expect(np.all(np.isfinite(out)), "policy returned NaN or inf")
    check.expect(np.array_equal(out, again), "policy is not deterministic for one observation")


# --------------------------------------------------------------------------------------------
# Fitness functions
# --------------------------------------------------------------------------------------------


def check_fitness(name: str, /, **options: Any) -> None:
    """Check fitness function ``name`` (with fitness ``options``); raise `PluginCheckError`.

    Protocol (callable, bool ``maximise``); scoring a short gecko run (a read-only record)
    gives a finite float, the same value when scored again, and the value the engine reports.

    Args:
        name: The fitness function's registry name (an entry point's name works too).
        **options: Keyword arguments passed to the function after the record (a task's
            ``fitness_options``).

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the function itself, or an unknown ``name``, included).
    """
    check = Checker("fitness function", name)
    with check.step("get()"):
        fitness = fitness_functions.get(name)
    check.expect(callable(fitness), "is not callable as fn(record) -> float")
    _expect_bool(
        check, fitness, "maximise", " (mark it with @ariel.plugins.fitness_function(maximise=))"
    )
    # The run is scored by a built-in first, so this function is first called here, directly.
    run = EvaluationTask(
        body=CHECK_BODY, params=_gecko_params(1)[0], duration=CHECK_DURATION, seed=CHECK_SEED
    )
    (trajectory,) = _run_gecko([run], xy_displacement)
    record = TrajectoryRecord(
        time=read_only(trajectory.time),
        core_pos=read_only(trajectory.core_pos),
        joint_target=read_only(trajectory.joint_target),
        joint_angle=read_only(trajectory.joint_angle),
        target=build(run).target,
    )
    with check.step("fn(record)"):
        value = fitness(record, **options)
        again = fitness(record, **options)
    check.expect(
        isinstance(value, numbers.Real) and not isinstance(value, bool),
        f"fn(record) returned {type(value).__name__}, not a float",
    )
    try:
        finite = math.isfinite(value)
    except OverflowError:  # an int of more than 308 digits: no float holds it
        finite = False
    shown = (
        str(value) if len(str(value)) <= 24 else f"{str(value)[:12]}... ({len(str(value))} digits)"
    )
    check.expect(finite, f"fn(record) returned {shown} for a normal run")
    check.expect(value == again, "fn(record) gave different values for the same record")
    task = dataclasses.replace(run, fitness=name, fitness_options=options)
    with check.step("evaluating the gecko"):
        (result,) = _run_gecko([task], fitness)
    check.expect(
        float(value) == result.fitness,
        f"fn(record) gave {value}, the evaluation {result.fitness}, for the same run",
    )
