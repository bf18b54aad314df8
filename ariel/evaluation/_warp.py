"""MuJoCo Warp: many brains stepped at once, as parallel worlds on a GPU.

`WarpEvaluator.evaluate_batch` takes the same tasks and gives the same `EvaluationResult`s as
`ariel.evaluation.evaluate_batch`, for open-loop controllers (the CPGs):

* A body is compiled by the CPU engine (`build`) and copied to the device once. The batches
  of several bodies in one call that can share a model are packed into one
  (`ariel.evaluation._warp_pack`, `_warp_packed`): world ``w`` holds brain ``w`` of each.
* Controls: the NA-CPG runs on the device (`ariel.evaluation._warp_cpg`): parameters and
  initial state uploaded once per batch, each controller call a kernel that advances the
  oscillators, blends and clips the targets and writes ``ctrl``. Other open-loop controllers'
  held controls are computed on the host (`held_controls`) and uploaded in pieces.
* Each event (a controller call, a recorded frame) and the steps to the next run as one
  captured graph: a CUDA graph on a GPU, Warp's CPU graph on the CPU. At each recorded frame
  the device computes the kinematics and copies qpos, each robot's core geom position and
  (``record_bodies``) the robots' body poses into frame buffers, which come back to the host
  once at the end.
* Fitness comes from the same registered fitness functions, on the same frames (`_finish`).

MuJoCo Warp computes in float32 and sums contact forces with atomics, so results agree with
the CPU engine closely but not bit for bit, and a GPU run is not bitwise repeatable; results
name their backend (``mujoco-warp:cuda`` or ``mujoco-warp:cpu``). A world whose state leaves
the finite range MuJoCo allows (|x| <= 1e10) is ``unstable``. A world whose contacts or
constraints overflow the device buffers is re-run with larger buffers.

Closed-loop controllers (a policy per call) are not batched here, nor worlds with a
heightfield (rugged, rugged_tilted, crater, amphitheatre, olympic_arena: MuJoCo Warp's
contacts with one differ from MuJoCo's, launching robots): their tasks run on the CPU engine
in this process (backend ``mujoco``), each reason said once on stderr. Import cost: `warp`
and `mujoco_warp` load on the first evaluator only.

The device side (device copies, frame buffers, captured graphs, stepping) is
`ariel.evaluation._warp_device`, the import of Warp and the device check
`ariel.evaluation._warp_runtime`; their public names are re-exported here.
"""

from __future__ import annotations

import json
import sys
import time as _time
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.errors import WarpUnavailableError as WarpUnavailableError
from ariel.evaluation._engine import (
    BuiltBody,
    TaskGroup,
    _build_key,
    _finish,
    _open_loop,
    evaluate_group,
    held_controls,
    open_loop_targets,
    prepare_groups,
)
from ariel.evaluation._rollouts import _call_chunks
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.evaluation._threads import evaluation_threads
from ariel.evaluation._warp_cpg import (
    CPGInputs,
    cpg_inputs,
    device_cpg_reason as device_cpg_reason,
    net_inputs,
)
from ariel.evaluation._warp_device import (
    _DeviceBody,
    _Frames,
    _Layout,
    _Run,
    _WarpDevice,
)
from ariel.evaluation._warp_pack import PackedModel, pack
from ariel.evaluation._warp_packed import RobotView, pack_plan, packed_inputs, robot_views
from ariel.evaluation._warp_runtime import (
    BACKEND as BACKEND,
    DEVICES as DEVICES,
    INSTALL_HINT as INSTALL_HINT,
    check_device as check_device,
    cuda_available as cuda_available,
    warp_modules as warp_modules,
)

if TYPE_CHECKING:
    from ariel.plugins import FitnessFunction

__all__ = [
    "BACKEND",
    "DEVICES",
    "INSTALL_HINT",
    "WarpEvaluator",
    "WarpUnavailableError",
    "check_device",
    "cuda_available",
]


# mujoco.mjtGeom.mjGEOM_HFIELD: a world with one runs on the CPU engine (`_on_the_cpu`).
_HFIELD = 1
# MuJoCo's limit on |qpos|, |qvel| (mjMAXVAL): beyond it the CPU engine warns and stops.
_MAX_VALUE = 1e10
# Buffer sizes grow this many times at most when contacts or constraints overflow them.
_MAX_GROWTH = 4


class WarpEvaluator(_WarpDevice):
    """Evaluates batches of tasks on MuJoCo Warp (see the module docs for the semantics).

    Args:
        device: ``"cuda"`` (default) or ``"cpu"``; checked now (`WarpUnavailableError`).
        max_worlds: most worlds stepped at once (a larger group runs in pieces); None: all of
            a group at once.
    """

    def __init__(self, device: str = "cuda", *, max_worlds: int | None = None) -> None:
        if max_worlds is not None and (
            not isinstance(max_worlds, int) or isinstance(max_worlds, bool) or max_worlds < 1
        ):  # True counted as 1
            raise ValueError(f"max_worlds must be an integer >= 1 or None, got {max_worlds!r}")
        self.device = check_device(device)
        self.max_worlds = max_worlds
        self._bodies: OrderedDict[str, _DeviceBody] = OrderedDict()
        self._noted: set[str] = set()  # reasons for not packing, said once

    @property
    def backend(self) -> str:
        """What results of this evaluator record as their backend, e.g. ``mujoco-warp:cuda``."""
        return f"{BACKEND}:{self.device}"

    def __repr__(self) -> str:
        return f"WarpEvaluator(device={self.device!r}, max_worlds={self.max_worlds!r})"

    # -- public ----------------------------------------------------------------------------------

    def evaluate_batch(self, tasks: Sequence[EvaluationTask]) -> list[EvaluationResult]:
        """Like `ariel.evaluation.evaluate_batch`: results in input order, checks first.

        Batches of different bodies that can share a model are packed into one
        (`ariel.evaluation._warp_packed`); the others run body by body.
        """
        results, ready = prepare_groups(tasks)
        here: list[TaskGroup] = []  # on the CPU engine (`_on_the_cpu`); the rest on the device
        there: list[TaskGroup] = []
        for group in ready:
            (here if self._on_the_cpu(group) else there).append(group)
        alone, packs, reasons = pack_plan(there)
        self._note_unpacked(reasons)
        done = [(g, outs) for pack in packs for g, outs in zip(pack, self._packed(pack))]
        done += [(g, evaluate_group(g, self._open_loop_group)) for g in alone]
        threads = evaluation_threads()

        def on_the_cpu(g: TaskGroup) -> list[EvaluationResult]:  # an open-loop group's rollout
            return _open_loop(g.tasks, g.built, g.controller, g.fitness_fn, threads)

        done += [(g, evaluate_group(g, on_the_cpu)) for g in here]
        for group, outs in done:
            for i, out in zip(group.indices, outs):
                results[i] = out
        return results  # type: ignore[return-value]

    # -- internals -------------------------------------------------------------------------------

    def _on_the_cpu(self, group: TaskGroup) -> bool:
        """Whether ``group`` runs on the CPU engine (backend ``mujoco``), said once per reason
        on stderr: a closed-loop controller (a policy per call), or a world with a heightfield,
        whose contacts MuJoCo Warp makes otherwise than MuJoCo: fewer of them, and robots on
        rugged ground were launched (fitness 10 to 200 times the CPU engine's, status ok)."""
        if not group.controller.open_loop:
            why = f"controller {group.tasks[0].controller!r} is closed-loop (a policy per call)"
        elif (group.built.model.geom_type == _HFIELD).any():
            why = (
                f"world {group.tasks[0].world!r} has a heightfield, whose contacts MuJoCo Warp "
                "computes unlike MuJoCo"
            )
        else:
            return False
        self._note(why, f"{why}: its evaluations run on the CPU engine")
        return True

    def _note(self, reason: str, said: str) -> None:
        """``note: gpu: <said> (docs/gpu.md)`` on stderr, once per ``reason``."""
        if reason not in self._noted:
            self._noted.add(reason)
            print(f"note: gpu: {said} (docs/gpu.md)", file=sys.stderr, flush=True)

    def _note_unpacked(self, reasons: dict[str, int]) -> None:
        """One line on stderr for each new reason why bodies could not be packed."""
        for reason, count in reasons.items():
            self._note(
                reason,
                f"{count} bodies of a generation are not packed into one model "
                f"({reason[:200]}); each runs alone on the device",
            )

    def _open_loop_group(self, group: TaskGroup) -> list[EvaluationResult]:
        """An open-loop group, ``max_worlds`` tasks at a time."""
        size = self.max_worlds or len(group.tasks)
        outs: list[EvaluationResult] = []
        for start in range(0, len(group.tasks), size):
            piece = group.tasks[start : start + size]
            outs.extend(self._open_loop(piece, group.built, group.controller, group.fitness_fn))
        return outs

    def _lone_body(self, task: EvaluationTask, built: BuiltBody) -> _DeviceBody:
        """The device copy of one task's body."""
        return self._device_body(_build_key(task), built, _Layout.of(built))

    def _open_loop(
        self,
        tasks: Sequence[EvaluationTask],
        built: BuiltBody,
        controller: Any,  # NaCPGController (the device CPG) or another open-loop controller
        fitness_fn: FitnessFunction,
    ) -> list[EvaluationResult]:
        head = tasks[0]
        run = _Run.of(head, built.model, len(tasks))
        start = _time.perf_counter()
        body = self._lone_body(head, built)
        parts: list[np.ndarray] = []
        if device_cpg_reason(controller) is None:
            nets = [(0, *net_inputs(tasks, built.model, controller))]
            controls: Any = cpg_inputs(controller, nets, run.call_times)  # then held controls
        else:
            controls = _kept(_control_pieces(tasks, built, controller, run.call_times), parts)
        frames, controls = self._stepped(body, controls, parts, run, head.smoothing, controller)
        wall = (_time.perf_counter() - start) / len(tasks)
        if frames.held is None:  # the control in force at each frame (the last step's at the
            # end), as on the CPU, from the host's held controls
            frames.held = controls[:, np.minimum(run.steps, run.nstep - 1) // run.period]
        return self._results(tasks, built, fitness_fn, body, frames, run.steps * run.dt, wall)

    def _packed(self, groups: list[TaskGroup]) -> list[list[EvaluationResult]]:
        """Groups of different bodies in one packed model, ``max_worlds`` worlds at a time."""
        heads = [g.tasks[0] for g in groups]
        key = json.dumps([_build_key(h) for h in heads])
        body = self._bodies.get(key)  # the same bodies again (their next CMA-ES iteration)
        if body is None or any(r.built is not g.built for r, g in zip(body.built.robots, groups)):
            packed = pack(heads, [g.built for g in groups])
            cores = np.array([r.core_geom for r in packed.robots])
            bodies = np.concatenate([r.robot_bodies for r in packed.robots])
            low, high = np.zeros(packed.model.nu), np.zeros(packed.model.nu)
            for robot in packed.robots:
                low[robot.ctrl], high[robot.ctrl] = robot.built.low, robot.built.high
            layout = _Layout(packed.model, cores, bodies, low, high)
            body = self._device_body(key, packed, layout)
        packed = body.built
        self._bodies.move_to_end(key)
        if body.sizes is None:  # room for every robot's contacts from the start
            body.sizes = tuple(len(groups) * n for n in self._default_sizes(body))  # type: ignore[assignment]
        most = max(len(g.tasks) for g in groups)
        size = self.max_worlds or most
        outs: list[list[EvaluationResult]] = [[] for _ in groups]
        for start in range(0, most, size):
            pieces = [g.tasks[start : start + size] or g.tasks[-1:] for g in groups]
            for k, results in enumerate(self._packed_piece(groups, packed, body, pieces)):
                outs[k].extend(results[: max(0, len(groups[k].tasks) - start)])
        return outs

    def _packed_piece(
        self,
        groups: list[TaskGroup],
        packed: PackedModel,
        body: _DeviceBody,
        pieces: list[list[EvaluationTask]],
    ) -> list[list[EvaluationResult]]:
        head = groups[0].tasks[0]
        run = _Run.of(head, packed.model, max(len(tasks) for tasks in pieces))
        start = _time.perf_counter()
        controller = groups[0].controller
        inputs = packed_inputs(pieces, packed, controller, run.call_times)
        frames, _ = self._stepped(body, inputs, [], run, head.smoothing, controller)
        wall = (_time.perf_counter() - start) / (run.nworld * len(groups))
        times = run.steps * run.dt
        return [
            self._results(tasks, g.built, g.fitness_fn, body, frames, times, wall, view)
            for g, tasks, view in zip(groups, pieces, robot_views(packed))
        ]

    def _stepped(
        self,
        body: _DeviceBody,
        controls: Any,  # CPGInputs, or an iterator of the host's held controls
        parts: list[np.ndarray],
        run: _Run,
        smoothing: float,
        controller: Any,  # NaCPGController (the device CPG) or another open-loop controller
    ) -> tuple[_Frames, Any]:
        """`_simulate`, run again with larger buffers while contacts or constraints overflow
        them (at most `_MAX_GROWTH` times); also the controls, as a re-run takes them."""
        frames = self._simulate(body, controls, run, smoothing, controller)
        if parts:  # the host's held controls, (B, calls, nu), for a re-run and the records
            controls = np.concatenate(parts, axis=1)
        for _ in range(_MAX_GROWTH):
            if not frames.overflowed.any():
                break
            nconmax, njmax = body.sizes  # type: ignore[misc]
            body.sizes = (2 * nconmax, 2 * njmax)  # kept for this body's later batches
            again = controls if isinstance(controls, CPGInputs) else iter([controls])
            frames = self._simulate(body, again, run, smoothing, controller)
        return frames, controls

    def _results(
        self,
        tasks: Sequence[EvaluationTask],
        built: BuiltBody,
        fitness_fn: FitnessFunction,
        body: _DeviceBody,
        frames: _Frames,
        times: np.ndarray,
        wall: float,
        view: RobotView | None = None,
    ) -> list[EvaluationResult]:
        """Results of the first ``len(tasks)`` worlds, for the robot ``view`` shows (the
        whole model: None)."""
        view = view or RobotView.lone()
        qpos = frames.qpos[:, :, view.qpos]  # (B, F, nq) of this robot
        within = np.abs(qpos) <= _MAX_VALUE  # False for NaN and inf
        final_qvel = np.abs(frames.final_qvel[:, view.qvel])
        stable = within.all(axis=(1, 2)) & (final_qvel <= _MAX_VALUE).all(axis=1)
        held = frames.held[:, :, view.ctrl]  # type: ignore[index]
        results = []
        for b, task in enumerate(tasks):
            if frames.overflowed[b]:
                results.append(_overflow_result(task, fitness_fn, body.sizes, self.backend))
                continue
            poses = None  # unstable: the host computes poses from the finite part, as on CPU
            if stable[b]:
                poses = (
                    frames.core[b, :, view.core],
                    None if frames.body_pos is None else frames.body_pos[b, :, view.bodies],
                    None if frames.body_quat is None else frames.body_quat[b, :, view.bodies],
                )
            results.append(
                _finish(
                    task,
                    built,
                    fitness_fn,
                    times,
                    qpos[b],
                    held[b],
                    bool(stable[b]),
                    wall,
                    poses=poses,
                    backend=self.backend,
                )
            )
        return results


def _control_pieces(
    tasks: Sequence[EvaluationTask],
    built: BuiltBody,
    controller: Any,  # an OpenLoopController, maybe with iter_targets (not in the protocol)
    call_times: np.ndarray,
) -> Iterator[np.ndarray]:
    """The held controls ``(B, n, nu)`` of consecutive controller calls: the CPU engine's.

    In pieces of 1, 2, 4, 8, then 16 calls where the controller computes its targets piecewise
    (`iter_targets`, as the NA-CPG does) and the tasks share one seed (a brain batch of the
    loop does), so the device starts stepping early; otherwise in one piece.
    """
    head = tasks[0]
    model = built.model
    params = np.array([t.params for t in tasks], dtype=np.float64)
    seeds = {t.seed for t in tasks}
    if not (hasattr(controller, "iter_targets") and len(seeds) == 1 and call_times.size > 1):
        seeds_in_order = [t.seed for t in tasks]
        targets = open_loop_targets(
            controller, params, seeds_in_order, call_times, model, name=head.controller
        )
        yield held_controls(targets, head.smoothing, built.low, built.high)
        return
    sizes = _call_chunks(call_times.size)
    label = f"controller {head.controller!r}"
    ctrl = None
    pieces = controller.iter_targets(params, call_times, model, seed=head.seed, chunks=sizes)
    for size, piece in zip(sizes, pieces, strict=True):
        piece = np.asarray(piece)
        if piece.shape != (len(tasks), size, model.nu):
            raise ValueError(
                f"{label}: iter_targets() gave a piece of shape {piece.shape}; expected "
                f"{(len(tasks), size, model.nu)} (candidates, calls, actuators)"
            )
        if not np.all(np.isfinite(piece)):
            raise ValueError(f"{label}: iter_targets() returned NaN or inf")
        held = held_controls(piece, head.smoothing, built.low, built.high, ctrl)
        ctrl = held[:, -1]
        yield held


def _kept(pieces: Iterator[np.ndarray], into: list[np.ndarray]) -> Iterator[np.ndarray]:
    """``pieces``, each also appended to ``into``."""
    for piece in pieces:
        into.append(piece)
        yield piece


def _overflow_result(
    task: EvaluationTask, fitness_fn: FitnessFunction, sizes: tuple[int, int] | None, backend: str
) -> EvaluationResult:
    worst = -np.inf if fitness_fn.maximise else np.inf
    return EvaluationResult(
        eval_id=task.eval_id,
        fitness=float(worst),
        status="error",
        error=(
            f"MuJoCo Warp: contacts or constraints overflowed the device buffers even at "
            f"(nconmax, njmax) = {sizes}"
        ),
        backend=backend,
    )
