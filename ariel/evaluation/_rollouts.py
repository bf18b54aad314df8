"""Open loop: every candidate of one body in one threaded rollout.

Open-loop controllers (the CPGs) are functions of time: the control sequence of every candidate
is computed in numpy first (`open_loop_targets`, then `held_controls`: the tutorial
`Controller`'s smoothing and clipping), and all candidates step in C with `mujoco.rollout`
across threads (GIL released). A lone candidate whose controller computes its targets in pieces
steps while a second thread computes the next piece (`_pipelined_single`). Re-exported by
`ariel.evaluation._engine`.
"""

from __future__ import annotations

import math
import queue
import sys
import threading
import time as _time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from mujoco import rollout as _rollout

from ariel.evaluation._build import BuiltBody
from ariel.evaluation._results import _blame, _finish, frame_steps, num_steps
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.evaluation._threads import evaluation_threads
from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.controllers.controller import blend_and_clip
from ariel.utils import SharedSetting

if TYPE_CHECKING:
    from ariel.plugins import FitnessFunction, OpenLoopController

__all__ = ["control_sequence", "held_controls", "open_loop_targets"]


def held_controls(
    targets: np.ndarray,
    smoothing: float,
    low: np.ndarray,
    high: np.ndarray,
    ctrl: np.ndarray | None = None,
) -> np.ndarray:
    """The control held after each controller call, ``(B, C, nu)``, from targets ``(B, C, nu)``.

    Call ``c`` sets ``ctrl = blend_and_clip(ctrl, target_c, smoothing, low, high)`` (the
    tutorial `Controller`'s formula); ``ctrl`` starts at zero (a reset) unless given.
    """
    batch, calls, nu = targets.shape
    held = np.empty_like(targets)
    ctrl = np.zeros((batch, nu)) if ctrl is None else ctrl
    for c in range(calls):
        ctrl = blend_and_clip(ctrl, targets[:, c], smoothing, low, high)
        held[:, c] = ctrl
    return held


def control_sequence(
    targets: np.ndarray,
    nstep: int,
    period: int,
    smoothing: float,
    low: np.ndarray,
    high: np.ndarray,
) -> np.ndarray:
    """Per-step controls ``(B, nstep, nu)``: each call's control holds for ``period`` steps."""
    held = held_controls(targets, smoothing, low, high)
    # min(): a period longer than the run (one call) must not allocate period columns.
    return np.repeat(held, min(period, nstep), axis=1)[:, :nstep]


class _Pools(threading.local):
    """Each thread's rollout pools, by their thread count: one `Rollout` used by two threads
    at once crashed the process (two runs or evaluate_batch calls in threads of one process)."""

    def __init__(self) -> None:
        self.by_threads: dict[int, _rollout.Rollout] = {}


_ROLLOUTS = _Pools()
#: The GIL switch interval, short while any thread pipelines a lone candidate.
_SHORT_SWITCH = SharedSetting(sys.getswitchinterval, sys.setswitchinterval, 1e-4)


def _rollout_pool(nthread: int) -> _rollout.Rollout:
    pools = _ROLLOUTS.by_threads
    pool = pools.get(nthread)
    if pool is None:
        pool = pools[nthread] = _rollout.Rollout(nthread=nthread)
    return pool


def open_loop_targets(
    controller: OpenLoopController,
    params: np.ndarray,
    seeds: Sequence[int],
    sample_times: np.ndarray,
    model: mujoco.MjModel,
    *,
    name: str = "",
) -> np.ndarray:
    """Targets ``(B, T, nu)`` of an open-loop controller for rows ``params`` with their seeds.

    ``controller.targets`` is called once per distinct seed on that seed's rows (vectorised
    within the group) and always gets one Python ``int``, as the protocol promises; results
    come back in input order. Shapes and values are checked (a plugin's bug raises here).
    """
    label = f"controller {name or type(controller).__name__!r}"
    rows_by_seed: dict[int, list[int]] = {}
    for row, seed in enumerate(seeds):
        rows_by_seed.setdefault(int(seed), []).append(row)
    out = np.empty((len(seeds), sample_times.size, model.nu))
    for seed, rows in rows_by_seed.items():
        try:
            part = np.asarray(controller.targets(params[rows], sample_times, model, seed=seed))
        except Exception as exc:
            raise _blame(exc, label) from None
        if part.shape != (len(rows), sample_times.size, model.nu):
            raise ValueError(
                f"{label}: targets() returned shape {part.shape}; expected "
                f"{(len(rows), sample_times.size, model.nu)} (candidates, calls, actuators)"
            )
        if not np.all(np.isfinite(part)):
            raise ValueError(f"{label}: targets() returned NaN or inf")
        out[rows] = part
    return out


def _open_loop(
    tasks: Sequence[EvaluationTask],
    built: BuiltBody,
    controller: Any,  # an OpenLoopController, maybe with iter_targets (not in the protocol)
    fitness_fn: FitnessFunction,
    nthread: int,
) -> list[EvaluationResult]:
    head = tasks[0]
    model = built.model
    nstep = num_steps(head, model)
    period = head.control_period
    smoothing = head.smoothing
    dt = model.opt.timestep
    call_times = np.arange(0, nstep, period) * dt
    params = np.array([t.params for t in tasks], dtype=np.float64)

    start = _time.perf_counter()
    # The pipelined path keeps a second thread busy: only where this process has CPUs to spare.
    if len(tasks) == 1 and hasattr(controller, "iter_targets") and evaluation_threads() > 1:
        states, controls = _pipelined_single(
            head, built, controller, params, call_times, nstep, period, smoothing
        )
    else:
        seeds = [t.seed for t in tasks]
        targets = open_loop_targets(
            controller, params, seeds, call_times, model, name=head.controller
        )
        controls = control_sequence(targets, nstep, period, smoothing, built.low, built.high)
        nthread = max(1, min(nthread, len(tasks)))
        datas = [mujoco.MjData(model) for _ in range(nthread)]
        with control_callback_unset():
            states, _ = _rollout_pool(nthread).rollout(
                model, datas, built.initial_state[None, :], controls, nstep=nstep
            )
    wall = (_time.perf_counter() - start) / len(tasks)

    qpos_slice = slice(1, 1 + model.nq)  # FULLPHYSICS state: time, qpos, qvel, ...
    steps = frame_steps(nstep, head.record_every)
    results = []
    for b, task in enumerate(tasks):
        final_time = states[b, -1, 0]
        stable = math.isclose(final_time, nstep * dt, rel_tol=0, abs_tol=dt / 2) and bool(
            np.all(np.isfinite(states[b, -1]))
        )
        qpos = np.where(
            (steps == 0)[:, None],
            built.initial_state[qpos_slice],
            states[b, np.maximum(steps - 1, 0), qpos_slice],
        )
        joint_target = controls[b, np.minimum(steps, nstep - 1)]
        results.append(
            _finish(task, built, fitness_fn, steps * dt, qpos, joint_target, stable, wall)
        )
    return results


def _pipelined_single(
    task: EvaluationTask,
    built: BuiltBody,
    controller: Any,  # an OpenLoopController with iter_targets (not in the protocol)
    params: np.ndarray,
    call_times: np.ndarray,
    nstep: int,
    period: int,
    smoothing: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One candidate: compute the CPG (Python) on a second thread while physics (C) steps.

    Physics runs as consecutive rollouts carrying the solver warm start, which is bit for bit
    one continuous rollout. The GIL switch interval is shortened meanwhile so the stepping
    thread gets the GIL back promptly between chunks.
    """
    pieces: queue.SimpleQueue[np.ndarray | BaseException] = queue.SimpleQueue()
    # Stepping starts almost at once, and the CPG thread then stays ahead of the physics.
    chunks = _call_chunks(call_times.size)
    producer = threading.Thread(
        target=_produce_targets,
        args=(pieces, controller, params, call_times, built.model, int(task.seed), chunks),
        name="ariel-cpg",
        daemon=True,
    )
    with _SHORT_SWITCH.held():
        try:
            producer.start()
            with control_callback_unset():
                return _step_pieces(pieces, chunks, built, nstep, period, smoothing)
        finally:
            producer.join()


def _step_pieces(
    pieces: queue.SimpleQueue[np.ndarray | BaseException],
    chunks: list[int],
    built: BuiltBody,
    nstep: int,
    period: int,
    smoothing: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Step one candidate through its target pieces as they arrive in ``pieces`` (one per
    chunk): each piece's held controls, then a rollout of its steps from where the last ended.

    Returns the states ``(1, nstep, nstate)`` and controls ``(1, nstep, nu)``; a run that
    becomes unstable is frozen from there on, as `mujoco.rollout` itself does. An exception
    that the producer put in ``pieces`` is raised here.
    """
    model = built.model
    nstate = built.initial_state.size
    states = np.empty((1, nstep, nstate))
    controls = np.empty((1, nstep, model.nu))
    data = mujoco.MjData(model)
    state = built.initial_state[None, :].copy()
    warmstart = np.zeros((1, model.nv))
    ctrl = np.zeros((1, model.nu))
    done_calls = 0
    for _ in chunks:
        piece = pieces.get()
        if isinstance(piece, BaseException):
            raise piece
        if piece.shape[1] == 0:
            continue
        held = held_controls(piece, smoothing, built.low, built.high, ctrl)
        ctrl = held[:, -1]
        k0 = done_calls * period
        done_calls += piece.shape[1]
        k1 = min(done_calls * period, nstep)
        repeat = min(period, k1 - k0)  # one call when the period outlasts the rest
        controls[:, k0:k1] = np.repeat(held, repeat, axis=1)[:, : k1 - k0]
        out, _ = _rollout_pool(1).rollout(
            model,
            data,
            state,
            controls[:, k0:k1],
            nstep=k1 - k0,
            initial_warmstart=warmstart,
        )
        states[:, k0:k1] = out
        if not math.isclose(out[0, -1, 0], k1 * model.opt.timestep, abs_tol=1e-9):
            states[:, k1:] = out[:, -1:]  # unstable: freeze, as rollout itself does
            controls[:, k1:] = ctrl[:, None]
            break
        state = out[:, -1]
        warmstart = data.qacc_warmstart[None, :].copy()
    return states, controls


def _call_chunks(ncalls: int) -> list[int]:
    """Pieces of 1, 2, 4, 8, then 16 controller calls (the last one what is left): ``ncalls``
    in all."""
    chunks: list[int] = []
    while sum(chunks) < ncalls:
        chunks.append(min(2 ** len(chunks), 16, ncalls - sum(chunks)))
    return chunks


def _produce_targets(
    pieces: queue.SimpleQueue[np.ndarray | BaseException],
    controller: Any,  # an OpenLoopController with iter_targets (not in the protocol)
    params: np.ndarray,
    call_times: np.ndarray,
    model: mujoco.MjModel,
    seed: int,
    chunks: list[int],
) -> None:
    """Put the controller's target pieces (`iter_targets`) into ``pieces`` (a thread's work);
    an exception raised meanwhile goes there too, handed to the stepping thread, which raises
    it."""
    try:
        for piece in controller.iter_targets(params, call_times, model, seed=seed, chunks=chunks):
            pieces.put(piece)
    except BaseException as exc:
        pieces.put(exc)
