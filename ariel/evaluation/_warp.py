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

Closed-loop controllers (a policy per call) are not batched here: their tasks run on the CPU
engine in this process (backend ``mujoco``). Import cost: `warp` and `mujoco_warp` load on the
first evaluator only.
"""

from __future__ import annotations

import functools
import itertools
import json
import sys
import time as _time
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco  # loaded with the engine already
import numpy as np

from ariel.errors import WarpUnavailableError
from ariel.evaluation._engine import (
    BuiltBody,
    TaskGroup,
    _build_key,
    _finish,
    evaluate_group,
    frame_steps,
    held_controls,
    num_steps,
    open_loop_targets,
    prepare_groups,
)
from ariel.evaluation._task import EvaluationResult, EvaluationTask
from ariel.evaluation._warp_cpg import (
    CPGInputs,
    DeviceCPG,
    batch_key,
    bump_kernel,
    cpg_inputs,
    device_cpg_reason as device_cpg_reason,
    net_inputs,
)
from ariel.evaluation._warp_pack import pack
from ariel.evaluation._warp_packed import RobotView, pack_plan, packed_inputs, robot_views

__all__ = [
    "BACKEND",
    "DEVICES",
    "INSTALL_HINT",
    "WarpEvaluator",
    "WarpUnavailableError",
    "check_device",
    "cuda_available",
]

BACKEND = "mujoco-warp"
#: Devices the evaluator runs on: "cuda" (an NVIDIA GPU), "cpu" (Warp's CPU device: slow,
#: for tests and machines without a GPU).
DEVICES: tuple[str, ...] = ("cuda", "cpu")
INSTALL_HINT = "pip install 'ariel[gpu]'"

# MuJoCo's limit on |qpos|, |qvel| (mjMAXVAL): beyond it the CPU engine warns and stops.
_MAX_VALUE = 1e10
# Buffer sizes grow this many times at most when contacts or constraints overflow them.
_MAX_GROWTH = 4
_CACHE_SIZE = 4


def warp_modules() -> tuple[Any, Any]:
    """``(warp, mujoco_warp)``, imported now; `WarpUnavailableError` naming the extra if not."""
    try:
        import mujoco_warp
        import warp
    except ImportError as exc:
        raise WarpUnavailableError(
            f"the gpu backend needs MuJoCo Warp ({exc.name} is not installed): {INSTALL_HINT}"
        ) from None
    if warp.config.log_level < warp.LOG_WARNING:
        # Warp logs one line per kernel module it loads (hundreds on a first compile).
        warp.config.log_level = warp.LOG_WARNING
    _init_quietly(warp)
    return warp, mujoco_warp


# What Warp's native library prints on a machine without an NVIDIA driver, at initialisation;
# the device check says it in its own words (one line), and the CPU device works without it.
_NO_DRIVER_NOTE = b"Could not find or load the NVIDIA CUDA driver"


@functools.cache
def _init_quietly(wp: Any) -> None:
    """``wp.init()`` with the native no-driver note dropped from stderr (the rest kept)."""
    import os
    import sys
    import tempfile

    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            captured.seek(0)
            kept = [line for line in captured.readlines() if _NO_DRIVER_NOTE not in line]
    if kept:
        sys.stderr.write(b"".join(kept).decode(errors="replace"))


def cuda_available() -> bool:
    """Whether Warp sees a CUDA device here (imports Warp)."""
    wp, _ = warp_modules()
    return bool(wp.is_cuda_available())


def check_device(device: str) -> str:
    """``device`` if the evaluator can run there; `WarpUnavailableError` (one line) if not."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {', '.join(DEVICES)}, not {device!r}")
    if device == "cuda" and not cuda_available():
        raise WarpUnavailableError(
            "the gpu executor found no CUDA device (no NVIDIA GPU or driver visible to Warp); "
            "to run MuJoCo Warp on the CPU instead (slow; for tests), set "
            'executor.device = "cpu" in the config or add --set executor.device=cpu to the '
            "command"
        )
    return device


# --------------------------------------------------------------------------------------------
# Device kernels (defined on first use, so that importing this module needs no Warp)
# --------------------------------------------------------------------------------------------


@functools.cache
def _kernels() -> Any:
    wp, _ = warp_modules()

    # The frame index is read from a device counter (bumped after each frame), so the same
    # captured graph records any frame.
    @wp.kernel
    def record_state(
        counter: wp.array(dtype=wp.int32),
        qpos: wp.array2d(dtype=wp.float32),
        out_qpos: wp.array3d(dtype=wp.float32),
    ):
        world, i = wp.tid()
        out_qpos[counter[0], world, i] = qpos[world, i]

    @wp.kernel
    def record_cores(
        counter: wp.array(dtype=wp.int32),
        cores: wp.array(dtype=wp.int32),
        geom_xpos: wp.array2d(dtype=wp.vec3),
        out_core: wp.array3d(dtype=wp.vec3),
    ):
        world, k = wp.tid()
        out_core[counter[0], world, k] = geom_xpos[world, cores[k]]

    @wp.kernel
    def record_bodies(
        counter: wp.array(dtype=wp.int32),
        bodies: wp.array(dtype=wp.int32),
        xpos: wp.array2d(dtype=wp.vec3),
        xquat: wp.array2d(dtype=wp.quat),
        out_pos: wp.array3d(dtype=wp.vec3),
        out_quat: wp.array3d(dtype=wp.quat),
    ):
        world, j = wp.tid()
        frame = counter[0]
        out_pos[frame, world, j] = xpos[world, bodies[j]]
        out_quat[frame, world, j] = xquat[world, bodies[j]]

    @wp.kernel
    def record_held(
        counter: wp.array(dtype=wp.int32),
        held: wp.array2d(dtype=wp.float64),
        out_held: wp.array3d(dtype=wp.float64),
    ):
        world, i = wp.tid()
        out_held[counter[0], world, i] = held[world, i]

    return record_state, record_cores, record_bodies, record_held, bump_kernel(wp)


# --------------------------------------------------------------------------------------------
# One body on the device
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Run:
    """The shape of one batch's run."""

    nworld: int
    ncalls: int
    nstep: int
    period: int
    steps: np.ndarray  # physics steps of the recorded frames
    record_bodies: bool
    call_times: np.ndarray  # simulated seconds of the controller calls
    dt: float

    @classmethod
    def of(cls, head: EvaluationTask, model: Any, nworld: int) -> _Run:
        """The run of ``nworld`` worlds of tasks timed like ``head`` on ``model``."""
        nstep, period, dt = num_steps(head, model), head.control_period, model.opt.timestep
        call_times = np.arange(0, nstep, period) * dt
        steps = frame_steps(nstep, head.record_every)
        ncalls, bodies = call_times.size, head.record_bodies
        return cls(nworld, ncalls, nstep, period, steps, bodies, call_times, dt)


@dataclass
class _Buffers:
    """Frame buffers (and the device CPG) of one batch shape, with the graphs that use them."""

    key: tuple[Any, ...]
    cores: Any  # (K,) int32: each robot's core geom
    bodies: Any | None  # (nbody,) int32: the robots' bodies, when their poses are recorded
    counter: Any  # (1,) int32: frames recorded so far
    qpos: Any  # (F, B, nq) float32
    core: Any  # (F, B, K) vec3
    held: Any | None  # (F, B, nu) float64, with the device CPG
    pos: Any | None  # (F, B, nbody) vec3
    quat: Any | None  # (F, B, nbody) quat
    cpg: DeviceCPG | None
    graphs: dict[tuple[bool, bool, int], Any]  # (cpg call, frame, steps) -> captured graph

    def zero_counters(self) -> None:
        """The frame counter, and the device CPG's call counter, back to 0."""
        self.counter.zero_()
        if self.cpg is not None:
            self.cpg.counter.zero_()


@dataclass
class _Worlds:
    """Device state for ``nworld`` copies of a body, and graphs captured on it."""

    data: Any
    nworld: int
    sizes: tuple[int, int]  # (nconmax, njmax) it was made with
    graphs: dict[int, Any]  # steps -> captured graph of that many steps
    buffers: _Buffers | None = None


@dataclass(frozen=True)
class _Layout:
    """What the device records of a model: one robot (a body) or several (a packed model)."""

    model: Any  # mujoco.MjModel
    core_geoms: np.ndarray  # (K,) each robot's core geom
    robot_bodies: np.ndarray  # every robot's bodies, robot after robot
    low: np.ndarray  # (nu,) actuator bounds, robot after robot
    high: np.ndarray

    @classmethod
    def of(cls, built: BuiltBody) -> _Layout:
        core = np.array([built.core_geom])
        return cls(built.model, core, built.robot_bodies, built.low, built.high)


@dataclass
class _DeviceBody:
    built: Any  # the BuiltBody (or packed model) it was made from
    layout: _Layout
    model: Any  # mujoco_warp.Model
    sizes: tuple[int, int] | None = None  # grown (nconmax, njmax), None: MuJoCo Warp's defaults
    worlds: _Worlds | None = None


@dataclass
class _Frames:
    """A batch's frames, world-major (one world's frames contiguous: its results read them)."""

    qpos: np.ndarray  # (B, F, nq)
    core: np.ndarray  # (B, F, K, 3): each robot's core
    body_pos: np.ndarray | None  # (B, F, nbody, 3)
    body_quat: np.ndarray | None  # (B, F, nbody, 4), MuJoCo's (w, x, y, z) order
    final_qvel: np.ndarray  # (B, nv)
    overflowed: np.ndarray  # (B,) bool: contacts or constraints did not fit
    held: np.ndarray | None = None  # (B, F, nu): the control in force, from the device CPG


class WarpEvaluator:
    """Evaluates batches of tasks on MuJoCo Warp (see the module docs for the semantics).

    Args:
        device: ``"cuda"`` (default) or ``"cpu"``; checked now (`WarpUnavailableError`).
        max_worlds: most worlds stepped at once (a larger group runs in pieces); None: all of
            a group at once.
    """

    def __init__(self, device: str = "cuda", *, max_worlds: int | None = None) -> None:
        if max_worlds is not None and (not isinstance(max_worlds, int) or max_worlds < 1):
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
        alone, packs, reasons = pack_plan(ready)
        self._note_unpacked(reasons)
        done = [(g, outs) for pack in packs for g, outs in zip(pack, self._packed(pack))]
        done += [(g, evaluate_group(g, self._open_loop_group)) for g in alone]
        for group, outs in done:
            for i, out in zip(group.indices, outs):
                results[i] = out
        return results  # type: ignore[return-value]

    # -- internals -------------------------------------------------------------------------------

    def _note_unpacked(self, reasons: dict[str, int]) -> None:
        """One line on stderr for each new reason why bodies could not be packed."""
        for reason, count in reasons.items():
            if reason not in self._noted:
                self._noted.add(reason)
                print(
                    f"note: gpu: {count} bodies of a generation are not packed into one model "
                    f"({reason[:200]}); each runs alone on the device (docs/gpu.md)",
                    file=sys.stderr,
                    flush=True,
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

    def _device_body(self, key: str, built: Any, layout: _Layout) -> _DeviceBody:
        """The device copy of ``built`` (a body, or a packed model), kept for later batches."""
        body = self._bodies.get(key)
        if body is None or body.built is not built:
            wp, mjw = warp_modules()
            with wp.ScopedDevice(self.device):
                model = mjw.put_model(layout.model)
            model.opt.warn_overflow = 0  # overflows are handled here (re-run, larger buffers)
            body = self._bodies[key] = _DeviceBody(built=built, layout=layout, model=model)
        self._bodies.move_to_end(key)
        while len(self._bodies) > _CACHE_SIZE:
            self._bodies.popitem(last=False)
        return body

    def _worlds(self, body: _DeviceBody, nworld: int) -> _Worlds:
        """Device data for ``nworld`` worlds (kept for the next batch of the same size)."""
        worlds = body.worlds
        if worlds is not None and worlds.nworld == nworld and worlds.sizes == body.sizes:
            return worlds
        wp, mjw = warp_modules()
        body.worlds = None  # free the old buffers first
        model = body.layout.model
        nconmax, njmax = body.sizes or (None, None)
        with wp.ScopedDevice(self.device):
            data = mjw.put_data(
                model, mujoco.MjData(model), nworld=nworld, nconmax=nconmax, njmax=njmax
            )
            # One step outside any graph capture: every kernel a step needs is compiled and
            # loaded now, not while a graph is being captured. Each batch resets the data.
            mjw.step(body.model, data)
            wp.synchronize()
        body.worlds = _Worlds(data, nworld, (data.naconmax // nworld, data.njmax), {})
        if body.sizes is None:
            body.sizes = body.worlds.sizes
        return body.worlds

    def _open_loop(
        self,
        tasks: Sequence[EvaluationTask],
        built: BuiltBody,
        controller: Any,
        fitness_fn: Any,
    ) -> list[EvaluationResult]:
        head = tasks[0]
        run = _Run.of(head, built.model, len(tasks))
        start = _time.perf_counter()
        body = self._lone_body(head, built)
        parts: list[np.ndarray] = []
        if device_cpg_reason(controller) is None:
            nets = [(0, *net_inputs(tasks, built.model, controller))]
            controls: Any = cpg_inputs(controller, nets, run.call_times)
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
        self, groups: list[TaskGroup], packed: Any, body: _DeviceBody, pieces: list[Any]
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

    def _default_sizes(self, body: _DeviceBody) -> tuple[int, int]:
        """MuJoCo Warp's default ``(nconmax, njmax)`` per world for this model."""
        wp, mjw = warp_modules()
        model = body.layout.model
        with wp.ScopedDevice(self.device):
            data = mjw.put_data(model, mujoco.MjData(model), nworld=1)
        return int(data.naconmax), int(data.njmax)

    def _stepped(
        self,
        body: _DeviceBody,
        controls: Any,
        parts: list[np.ndarray],
        run: _Run,
        smoothing: float,
        controller: Any,
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
        fitness_fn: Any,
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

    def _simulate(
        self,
        body: _DeviceBody,
        controls: CPGInputs | Iterator[np.ndarray],
        run: _Run,
        smoothing: float,
        controller: Any,
    ) -> _Frames:
        """Step every world from the initial state with its controls; frames at ``run.steps``.

        ``controls``: the device CPG's inputs (the controls are computed in the graphs), or
        the host's held controls ``(B, n, nu)`` of consecutive controller calls in pieces:
        each is uploaded and its steps launched before the next is asked for (on a GPU,
        launches return at once, so the host computes the next piece while the device steps).
        """
        wp, mjw = warp_modules()
        layout = body.layout
        nworld, nstep, period = run.nworld, run.nstep, run.period
        frames = set(run.steps.tolist())
        events = sorted(set(range(0, nstep, period)) | frames)
        on_device = isinstance(controls, CPGInputs)
        with wp.ScopedDevice(self.device):
            worlds = self._worlds(body, nworld)
            m, d = body.model, worlds.data
            cpg = (controls, smoothing, controller) if on_device else None
            bufs = self._buffers(worlds, layout, run, cpg)
            keys = []
            for i, k in enumerate(events):
                end = events[i + 1] if i + 1 < len(events) else nstep
                keys.append((on_device and k % period == 0 and k < nstep, k in frames, end - k))
            self._prepare_graphs(worlds, bufs, m, set(keys))
            mjw.reset_data(m, d)
            bufs.counter.zero_()
            if on_device:
                bufs.cpg.load(controls)  # type: ignore[union-attr]
                for key in keys:
                    wp.capture_launch(bufs.graphs[key])
            else:
                self._host_controlled(d, bufs, events, keys, controls, run)  # type: ignore[arg-type]
            wp.synchronize()
            return _Frames(
                qpos=_world_major(bufs.qpos),
                core=_world_major(bufs.core),
                body_pos=None if bufs.pos is None else _world_major(bufs.pos),
                # MuJoCo Warp keeps MuJoCo's (w, x, y, z) order in its quaternions.
                body_quat=None if bufs.quat is None else _world_major(bufs.quat),
                final_qvel=d.qvel.numpy().astype(np.float64),
                overflowed=(d.overflow.numpy() & _capacity_bits(mjw)) != 0,
                held=None if bufs.held is None else _world_major(bufs.held),
            )

    def _host_controlled(
        self,
        d: Any,
        bufs: _Buffers,
        events: list[int],
        keys: list[tuple[bool, bool, int]],
        pieces: Iterator[np.ndarray],
        run: _Run,
    ) -> None:
        """Run the events with controls computed on the host, uploaded piece by piece."""
        wp, _ = warp_modules()
        nworld, nu, period = run.nworld, d.ctrl.shape[1], run.period
        cuda = wp.get_device().is_cuda
        # Controls as (call, world, actuator): one contiguous block per controller call,
        # staged in page-locked host memory on a GPU so that uploads do not wait.
        controls = wp.empty((run.ncalls, nworld, nu), dtype=wp.float32)
        staging = wp.empty((run.ncalls, nworld, nu), dtype=wp.float32, device="cpu", pinned=cuda)
        staged = staging.numpy()
        uploaded = 0  # controller calls on the device
        i = 0  # next event
        for piece in itertools.chain(pieces, [None]):
            if piece is not None:
                n = piece.shape[1]
                staged[uploaded : uploaded + n] = piece.transpose(1, 0, 2)
                offset = uploaded * nworld * nu
                wp.copy(controls, staging, offset, offset, n * nworld * nu)
                uploaded += n
            elif uploaded != run.ncalls:
                raise RuntimeError(f"controls for {uploaded} controller calls, not {run.ncalls}")
            # The last frame, at the end of the run, comes after every piece.
            while i < len(events) and (events[i] < uploaded * period or piece is None):
                k = events[i]
                if k % period == 0 and k < run.nstep:
                    wp.copy(d.ctrl, controls[k // period])
                wp.capture_launch(bufs.graphs[keys[i]])
                i += 1

    def _buffers(
        self, worlds: _Worlds, layout: _Layout, run: _Run, cpg: tuple[Any, ...] | None
    ) -> _Buffers:
        """The frame buffers (and device CPG) for this batch shape: kept while it repeats."""
        wp, _ = warp_modules()
        nworld, nframes = run.nworld, run.steps.size
        nq, nu, nrobot = layout.model.nq, layout.model.nu, len(layout.robot_bodies)
        ncore = len(layout.core_geoms)
        low, high = layout.low, layout.high
        record_bodies = run.record_bodies and nrobot > 0
        cpg_key = None if cpg is None else batch_key(cpg[0], cpg[2], cpg[1], low, high)
        key = (nframes, record_bodies, cpg_key)
        bufs = worlds.buffers
        if bufs is not None and bufs.key == key:
            return bufs
        worlds.buffers = None  # free the old buffers (and their graphs) first
        bodies = wp.array(layout.robot_bodies.astype(np.int32), dtype=wp.int32)
        bufs = worlds.buffers = _Buffers(
            key=key,
            cores=wp.array(layout.core_geoms.astype(np.int32), dtype=wp.int32),
            bodies=bodies if record_bodies else None,
            counter=wp.zeros(1, dtype=wp.int32),
            qpos=wp.empty((nframes, nworld, nq), dtype=wp.float32),
            core=wp.empty((nframes, nworld, ncore), dtype=wp.vec3),
            held=None if cpg is None else wp.empty((nframes, nworld, nu), dtype=wp.float64),
            pos=wp.empty((nframes, nworld, nrobot), dtype=wp.vec3) if record_bodies else None,
            quat=wp.empty((nframes, nworld, nrobot), dtype=wp.quat) if record_bodies else None,
            cpg=None if cpg is None else DeviceCPG(wp, cpg[0], cpg[2], cpg[1], low, high),
            graphs={},
        )
        return bufs

    def _prepare_graphs(
        self, worlds: _Worlds, bufs: _Buffers, model: Any, keys: set[tuple[bool, bool, int]]
    ) -> None:
        """Capture the graph of every event kind not captured yet on these buffers.

        Each event's work runs once outside a capture first, so that every kernel it needs is
        compiled and loaded before a graph is captured (the caller resets the state after).
        """
        wp, _ = warp_modules()
        for key in sorted(keys - bufs.graphs.keys()):
            bufs.zero_counters()  # in range for the warm-up run
            self._event_work(worlds, bufs, model, key)
            bufs.zero_counters()  # and for the capture (on the CPU device it runs too)
            with wp.ScopedCapture() as capture:
                self._event_work(worlds, bufs, model, key)
            bufs.graphs[key] = capture.graph

    def _event_work(
        self, worlds: _Worlds, bufs: _Buffers, model: Any, key: tuple[bool, bool, int]
    ) -> None:
        """One event: a device controller call, a recorded frame, then the steps to the next."""
        wp, mjw = warp_modules()
        record_state, record_cores, record_pose, record_held, bump = _kernels()
        d, nworld = worlds.data, worlds.nworld
        call, frame, nsteps = key
        if call and bufs.cpg is not None:
            bufs.cpg.launch(d.ctrl)
        if frame:
            mjw.kinematics(model, d)
            wp.launch(
                record_state,
                dim=(nworld, bufs.qpos.shape[2]),
                inputs=[bufs.counter, d.qpos, bufs.qpos],
            )
            wp.launch(
                record_cores,
                dim=(nworld, bufs.core.shape[2]),
                inputs=[bufs.counter, bufs.cores, d.geom_xpos, bufs.core],
            )
            if bufs.pos is not None:
                wp.launch(
                    record_pose,
                    dim=(nworld, bufs.pos.shape[2]),
                    inputs=[bufs.counter, bufs.bodies, d.xpos, d.xquat,
                            bufs.pos, bufs.quat],
                )  # fmt: skip
            if bufs.held is not None and bufs.cpg is not None:
                wp.launch(
                    record_held,
                    dim=(nworld, bufs.held.shape[2]),
                    inputs=[bufs.counter, bufs.cpg.held, bufs.held],
                )
            wp.launch(bump, dim=1, inputs=[bufs.counter])
        for _ in range(nsteps):
            mjw.step(model, d)

    def _graph(self, worlds: _Worlds, model: Any, nsteps: int) -> Any:
        """The captured graph of ``nsteps`` physics steps on these worlds (captured once)."""
        graph = worlds.graphs.get(nsteps)
        if graph is None:
            wp, mjw = warp_modules()
            with wp.ScopedCapture() as capture:
                for _ in range(nsteps):
                    mjw.step(model, worlds.data)
            graph = worlds.graphs[nsteps] = capture.graph
        return graph


def _control_pieces(
    tasks: Sequence[EvaluationTask], built: BuiltBody, controller: Any, call_times: np.ndarray
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
    sizes: list[int] = []
    while sum(sizes) < call_times.size:
        sizes.append(min(2 ** len(sizes), 16, call_times.size - sum(sizes)))
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


def _world_major(frames: Any) -> np.ndarray:
    """A device array of frames ``(F, B, ...)`` as float64 ``(B, F, ...)``, in one copy."""
    out = frames.numpy()
    return np.ascontiguousarray(out.swapaxes(0, 1), dtype=np.float64)


def _kept(pieces: Iterator[np.ndarray], into: list[np.ndarray]) -> Iterator[np.ndarray]:
    """``pieces``, each also appended to ``into``."""
    for piece in pieces:
        into.append(piece)
        yield piece


def _capacity_bits(mjw: Any) -> int:
    """Overflow flags that mean dropped contacts or constraints (not solver iteration limits)."""
    kinds = mjw.OverflowType
    bits = 0
    for name in ("NEFC", "NJMAX_NNZ", "BROADPHASE", "NARROWPHASE", "CCD", "HFIELD", "NVMAX"):
        bits |= int(getattr(kinds, name, 0))
    return bits


def _overflow_result(
    task: EvaluationTask, fitness_fn: Any, sizes: Any, backend: str
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
