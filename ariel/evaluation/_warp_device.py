"""The device side of the Warp evaluator: bodies, worlds, frame buffers and captured graphs.

`_WarpDevice` (the base of `ariel.evaluation._warp.WarpEvaluator`) keeps a device copy of each
recent body or packed model (`_DeviceBody`), the device data of its worlds (`_Worlds`) and the
frame buffers of a batch shape (`_Buffers`), captures one graph per kind of event (a controller
call, a recorded frame, the steps to the next event) and steps a batch (`_simulate`): its
frames come back to the host once, world-major (`_Frames`). The kernels that record frames are
defined on first use, so that importing this module needs no Warp.

Warp's objects (its modules, arrays, kernels and graphs, MuJoCo Warp's ``Model`` and ``Data``)
are typed `Any` here: Warp is imported on first use only (`warp_modules`). So is a controller
that may run on the device or on the host (an `NaCPGController` or another open-loop one).
"""

from __future__ import annotations

import functools
import itertools
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import mujoco  # loaded with the engine already
import numpy as np

from ariel.evaluation._engine import BuiltBody, frame_steps, num_steps
from ariel.evaluation._task import EvaluationTask
from ariel.evaluation._warp_cpg import CPGInputs, DeviceCPG, batch_key, bump_kernel
from ariel.evaluation._warp_runtime import warp_modules

# Device copies of bodies (or packed models) kept for later batches.
_CACHE_SIZE = 4


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
    def of(cls, head: EvaluationTask, model: mujoco.MjModel, nworld: int) -> _Run:
        """The run of ``nworld`` worlds of tasks timed like ``head`` on ``model``."""
        nstep, period, dt = num_steps(head, model), head.control_period, model.opt.timestep
        call_times = np.arange(0, nstep, period) * dt
        steps = frame_steps(nstep, head.record_every)
        ncalls, bodies = call_times.size, head.record_bodies
        return cls(nworld, ncalls, nstep, period, steps, bodies, call_times, dt)


@dataclass
class _Buffers:
    """Frame buffers (and the device CPG) of one batch shape, with the graphs that use them.

    The arrays are Warp arrays and the graphs Warp graphs, typed Any: Warp is imported on
    first use only (`warp_modules`).
    """

    key: tuple[object, ...]
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

    data: Any  # mujoco_warp.Data (Warp is imported on first use only)
    nworld: int
    sizes: tuple[int, int]  # (nconmax, njmax) it was made with
    graphs: dict[int, Any]  # steps -> captured graph of that many steps
    buffers: _Buffers | None = None


@dataclass(frozen=True)
class _Layout:
    """What the device records of a model: one robot (a body) or several (a packed model)."""

    model: mujoco.MjModel
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
    built: Any  # the BuiltBody or PackedModel it was made from (the caller knows which)
    layout: _Layout
    model: Any  # mujoco_warp.Model (Warp is imported on first use only)
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


class _WarpDevice:
    """Device copies of bodies, their worlds and buffers, and a batch's stepping on them.

    Subclasses set ``device`` (a Warp device name) and ``_bodies`` (an empty `OrderedDict`).
    """

    device: str
    _bodies: OrderedDict[str, _DeviceBody]

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

    def _default_sizes(self, body: _DeviceBody) -> tuple[int, int]:
        """MuJoCo Warp's default ``(nconmax, njmax)`` per world for this model."""
        wp, mjw = warp_modules()
        model = body.layout.model
        with wp.ScopedDevice(self.device):
            data = mjw.put_data(model, mujoco.MjData(model), nworld=1)
        return int(data.naconmax), int(data.njmax)

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


def _world_major(frames: Any) -> np.ndarray:
    """A device array of frames ``(F, B, ...)`` as float64 ``(B, F, ...)``, in one copy."""
    out = frames.numpy()
    return np.ascontiguousarray(out.swapaxes(0, 1), dtype=np.float64)


def _capacity_bits(mjw: Any) -> int:
    """Overflow flags that mean dropped contacts or constraints (not solver iteration limits)."""
    kinds = mjw.OverflowType
    bits = 0
    for name in ("NEFC", "NJMAX_NNZ", "BROADPHASE", "NARROWPHASE", "CCD", "HFIELD", "NVMAX"):
        bits |= int(getattr(kinds, name, 0))
    return bits
