"""NA-CPG controls computed on the device, inside the captured graphs of a Warp batch.

The host uploads each world's CPG parameters, coupling and initial state once per batch; at
every controller call a kernel advances every world's oscillators, computes the targets
(``clip(amplitudes * y + b)``, rounded to float32 as the host path rounds them), blends and
clips them into the held control (``blend_and_clip``) and writes it into MuJoCo Warp's
``ctrl``. The held control is kept in float64, as the CPU engine keeps it, and is what the
frames record as joint targets.

The arithmetic follows `ariel.simulation.controllers.cpg_kernel` step for step and sums the
coupling in the same order (the node's coupling from nodes ``j >= k`` before the update, its
own ``(1 + dt K) z``, then nodes ``j < k`` after theirs), in float64, so the targets equal the
host's to rounding (the device may fuse multiply-adds where numpy does not), and the float32
targets agree to float32 rounding.

A world may hold several networks (one per robot of a packed model): ``nets`` lists each
network's first actuator and size; a network's coupling is its own block.

Only `NaCPGController` runs here; other open-loop controllers compute their targets on the
host (`device_cpg_reason` says why).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ariel.evaluation.builtin_plugins import NaCPGController
from ariel.simulation.controllers import cpg_kernel

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation._task import EvaluationTask
    from ariel.plugins import ControllerPlugin

__all__ = [
    "CPGInputs",
    "DeviceCPG",
    "batch_key",
    "bump_kernel",
    "cpg_inputs",
    "device_cpg_reason",
    "net_inputs",
]


def device_cpg_reason(controller: ControllerPlugin) -> str | None:
    """None if ``controller``'s targets can be computed on the device; else why not."""
    if type(controller) is not NaCPGController:
        return f"{type(controller).__name__} has no device kernel (its targets come from the host)"
    return None


@dataclass
class CPGInputs:
    """One batch's CPG inputs on the host, world-major: ``nworld`` worlds, ``nu`` nodes."""

    z: np.ndarray  # (nworld, nu, 2) initial xy
    z_old: np.ndarray  # (nworld, nu, 2) initial xy_dot_old
    node: np.ndarray  # (nworld, nu, 5): dt * w, ha, amplitudes, b, unused
    rot: np.ndarray  # (nworld, sum n_k^2, 2): dt * R(phase_i - phase_j) * adjacency, per net
    nets: np.ndarray  # (nnet, 3) int32: first node, size, first coupling entry
    advance: np.ndarray  # (ncalls,) int32: CPG steps before each call's sample


def net_inputs(
    tasks: Sequence[EvaluationTask], model: mujoco.MjModel, controller: NaCPGController
) -> tuple[np.ndarray, np.ndarray]:
    """One network's ``(params (B, 5n), state (B, n, 2, 2))`` for tasks of one body: each
    task's parameters and its seed's initial state (xy, xy_dot_old), as the host draws it."""
    params = np.array([t.params for t in tasks], dtype=np.float64)
    if not np.all(np.isfinite(params)):
        raise ValueError(f"controller {tasks[0].controller!r}: parameters contain NaN or inf")
    state = np.empty((len(tasks), model.nu, 2, 2))
    drawn: dict[int, np.ndarray] = {}
    for b, task in enumerate(tasks):
        if task.seed not in drawn:
            xy, xy_dot_old = controller.initial_state(model, task.seed)
            drawn[task.seed] = np.stack([xy, xy_dot_old], axis=-1)
        state[b] = drawn[task.seed]
    return params, state


def cpg_inputs(
    controller: NaCPGController,
    nets: Sequence[tuple[int, np.ndarray, np.ndarray]],
    call_times: np.ndarray,
) -> CPGInputs:
    """The device inputs of a batch.

    ``nets``: per network (robot), ``(first_node, params (nworld, 5n), xy0 and xy_dot_old0
    as (nworld, n, 2, 2))``; worlds are the batch's tasks.
    """
    nworld = nets[0][1].shape[0]
    nu = sum(p.shape[1] // cpg_kernel.NUM_PARAMETER_GROUPS for _, p, _ in nets)
    dt = controller.dt
    z = np.zeros((nworld, nu, 2))
    z_old = np.zeros((nworld, nu, 2))
    node = np.zeros((nworld, nu, 5))
    blocks, table, start = [], [], 0
    for first, params, state in nets:
        n = params.shape[1] // cpg_kernel.NUM_PARAMETER_GROUPS
        groups = cpg_kernel.split_parameters(params)
        span = slice(first, first + n)
        z[:, span], z_old[:, span] = state[..., 0], state[..., 1]
        node[:, span, 0] = dt * groups["w"]
        node[:, span, 1] = groups["ha"]
        node[:, span, 2] = groups["amplitudes"]
        node[:, span, 3] = groups["b"]
        phase = groups["phase"]
        # rot[w, i, j] = dt * R(phase_i - phase_j) where node i receives from node j (the host
        # kernel's product, in its order: exp, then * dt, then * adjacency).
        rot: npt.NDArray[np.complex128] = np.exp(1j * (phase[:, :, None] - phase[:, None, :]))
        rot *= dt
        rot *= controller.adjacency(n)[None]
        blocks.append(np.stack([rot.real, rot.imag], axis=-1).reshape(nworld, n * n, 2))
        table.append((first, n, start))
        start += n * n
    steps = cpg_kernel.cpg_steps(call_times, dt)
    advance = np.diff(steps, prepend=0).astype(np.int32)
    return CPGInputs(
        z=z,
        z_old=z_old,
        node=node,
        rot=np.concatenate(blocks, axis=1),
        nets=np.array(table, dtype=np.int32).reshape(-1, 3),
        advance=advance,
    )


@functools.cache
def _node_update(wp: Any) -> Any:
    """``new z`` of node ``k`` of a network: its coupling from nodes ``j >= k`` (not yet
    updated this step), its own ``(1 + dt K) z``, then nodes ``j < k`` (already updated), in
    that order, clamped around ``z + dt * z_old`` (see the module docs)."""
    eps = float(cpg_kernel.EPSILON)

    @wp.func
    def cmul(a: wp.vec2d, b: wp.vec2d) -> wp.vec2d:
        return wp.vec2d(a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])

    @wp.func
    def update(
        world: int, first: int, n: int, k: int, r0: int, consts: wp.array(dtype=wp.float64),
        node: wp.array3d(dtype=wp.float64), rot: wp.array2d(dtype=wp.vec2d),
        z: wp.array2d(dtype=wp.vec2d), zk: wp.vec2d, zo: wp.vec2d,
    ) -> wp.vec2d:  # fmt: skip
        one = wp.float64(1.0)
        e = wp.float64(eps)
        acc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
        for j in range(k, n):
            acc = acc + cmul(rot[world, r0 + k * n + j], z[world, first + j])
        t2 = one + e - (zo[0] + e) / (wp.abs(zo[0]) + e) * node[world, first + k, 1]
        r2 = zk[0] * zk[0] + zk[1] * zk[1]
        k1 = wp.vec2d(one + consts[1] - r2 * r2 * consts[1], node[world, first + k, 0] / t2)
        acc = acc + cmul(k1, zk)
        for j in range(k):
            acc = acc + cmul(rot[world, r0 + k * n + j], z[world, first + j])
        lo = zo * consts[0] + zk
        return wp.vec2d(
            wp.clamp(acc[0], lo[0] - consts[2], lo[0] + consts[2]),
            wp.clamp(acc[1], lo[1] - consts[2], lo[1] + consts[2]),
        )

    return update


@functools.cache
def _kernels(wp: Any) -> Any:
    update = _node_update(wp)

    @wp.kernel
    def cpg_call(
        counter: wp.array(dtype=wp.int32),
        advance: wp.array(dtype=wp.int32),
        nets: wp.array2d(dtype=wp.int32),
        consts: wp.array(dtype=wp.float64),
        low: wp.array(dtype=wp.float64),
        high: wp.array(dtype=wp.float64),
        node: wp.array3d(dtype=wp.float64),
        rot: wp.array2d(dtype=wp.vec2d),
        z: wp.array2d(dtype=wp.vec2d),
        z_old: wp.array2d(dtype=wp.vec2d),
        held: wp.array2d(dtype=wp.float64),
        ctrl: wp.array2d(dtype=wp.float32),
    ):
        world, net = wp.tid()
        first = nets[net, 0]
        n = nets[net, 1]
        for _step in range(advance[counter[0]]):
            for k in range(n):
                zk = z[world, first + k]
                zo = z_old[world, first + k]
                new = update(world, first, n, k, nets[net, 2], consts, node, rot, z, zk, zo)
                z_old[world, first + k] = zk
                z[world, first + k] = new
        smoothing = consts[3]
        for k in range(n):
            i = first + k
            target = node[world, i, 2] * z[world, i][1] + node[world, i, 3]
            target = wp.clamp(target, consts[4], consts[5])
            target = wp.float64(wp.float32(target))  # the host path's float32 targets
            blended = held[world, i] * (wp.float64(1.0) - smoothing) + target * smoothing
            blended = wp.clamp(blended, low[i], high[i])
            held[world, i] = blended
            ctrl[world, i] = wp.float32(blended)

    return cpg_call, bump_kernel(wp)


@functools.cache
def bump_kernel(wp: Any) -> Any:
    """A kernel adding 1 to a device counter (a call's or a frame's index, read by the
    kernels after it in the same captured graph)."""

    @wp.kernel
    def bump(counter: wp.array(dtype=wp.int32)):
        counter[wp.tid()] = counter[wp.tid()] + 1

    return bump


class DeviceCPG:
    """The device arrays of one batch shape; `load` a batch, `launch` a controller call.

    Arrays keep their addresses from batch to batch (graphs captured with them stay valid).
    """

    def __init__(self, wp: Any, inputs: CPGInputs, controller: NaCPGController, smoothing: float,
                 low: np.ndarray, high: np.ndarray) -> None:  # fmt: skip
        self.key = batch_key(inputs, controller, smoothing, low, high)
        nworld, nu = inputs.z.shape[:2]
        self.counter = wp.zeros(1, dtype=wp.int32)
        self.advance = wp.array(inputs.advance, dtype=wp.int32)
        self.nets = wp.array(inputs.nets, dtype=wp.int32)
        lo_hb, hi_hb = controller.hard_bounds
        width = cpg_kernel.DERIVATIVE_CLAMP * controller.dt
        consts = [controller.dt, controller.dt * controller.alpha, width, smoothing, lo_hb, hi_hb]
        self.consts = wp.array(np.array(consts), dtype=wp.float64)
        self.low = wp.array(np.asarray(low, np.float64), dtype=wp.float64)
        self.high = wp.array(np.asarray(high, np.float64), dtype=wp.float64)
        self.node = wp.empty((nworld, nu, 5), dtype=wp.float64)
        self.rot = wp.empty(inputs.rot.shape[:2], dtype=wp.vec2d)
        self.z = wp.empty((nworld, nu), dtype=wp.vec2d)
        self.z_old = wp.empty((nworld, nu), dtype=wp.vec2d)
        self.held = wp.zeros((nworld, nu), dtype=wp.float64)
        self.wp = wp

    def matches(self, key: tuple[object, ...]) -> bool:
        """Whether these arrays serve a batch of this `key` (shape, constants, bounds)."""
        return self.key == key

    def load(self, inputs: CPGInputs) -> None:
        """This batch's parameters and initial state; the call counter and controls reset."""
        self.node.assign(inputs.node)
        self.rot.assign(np.ascontiguousarray(inputs.rot))
        self.z.assign(np.ascontiguousarray(inputs.z))
        self.z_old.assign(np.ascontiguousarray(inputs.z_old))
        self.held.zero_()
        self.counter.zero_()

    def launch(self, ctrl: Any) -> None:
        """One controller call: advance, targets, blend and clip into ``ctrl``; count it."""
        cpg_call, bump = _kernels(self.wp)
        nworld = self.z.shape[0]
        self.wp.launch(
            cpg_call,
            dim=(nworld, self.nets.shape[0]),
            inputs=[self.counter, self.advance, self.nets, self.consts, self.low, self.high,
                    self.node, self.rot, self.z, self.z_old, self.held, ctrl],
        )  # fmt: skip
        self.wp.launch(bump, dim=1, inputs=[self.counter])


def batch_key(
    inputs: CPGInputs,
    controller: NaCPGController,
    smoothing: float,
    low: np.ndarray,
    high: np.ndarray,
) -> tuple[object, ...]:
    """What a `DeviceCPG` is made for: array shapes, the calls' steps and the constants."""
    return (
        inputs.z.shape,
        inputs.rot.shape,
        inputs.nets.tobytes(),
        inputs.advance.tobytes(),
        (controller.dt, controller.alpha, tuple(controller.hard_bounds), float(smoothing)),
        np.asarray(low, np.float64).tobytes(),
        np.asarray(high, np.float64).tobytes(),
    )
