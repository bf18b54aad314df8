"""NA-CPG oscillator maths in numpy, vectorised over a population of parameter vectors.

This module is the single implementation of the Normalized Asymmetric CPG dynamics. The
torch ``NaCPG`` (tutorial API) runs it with a batch of one; the evaluation engine runs it over
all brain candidates of a body at once. Both go through the same arithmetic, so the same
parameters and initial state give bit-identical joint targets on either path, whatever the
batch size and however the integration is split into calls.

Conventions
-----------
* ``n`` oscillator nodes (one per actuator), batch of ``B`` candidates.
* A flat parameter vector has ``5 * n`` entries: the groups ``phase, w, amplitudes, ha, b``,
  each of length ``n``, in that order (``PARAMETER_GROUPS``).
* The state of one network is ``xy`` (shape ``(n, 2)``) and ``xy_dot_old`` (``(n, 2)``).
  Batched: ``(B, n, 2)`` each. As upstream, ``xy_dot_old`` holds the *previous state*, not the
  previous derivative (the name is historical; the dynamics depend on that quirk).
* The output (joint target, radians) of node ``i`` is ``amplitudes_i * y_i + b_i``, clipped to
  ``hard_bounds``.
* Time: the sample at time ``t`` is the output after ``floor(t / dt + 1e-9)`` internal steps
  from the initial state (``cpg_steps``), so the CPG is a function of simulated time.

One internal step (upstream ARIEL's update, with ``E = 1e-9``)
-------------------------------------------------------------
From the pre-update state, for every node ``i``::

    r2_i = x_i^2 + y_i^2;              a_i = alpha * (1 - r2_i^2)
    zeta_i = 1 - ha_i * (xo_i + E) / (|xo_i| + E)      (xo = xy_dot_old[:, 0])
    b_i = w_i / (zeta_i + E);          K_i = [[a_i, -b_i], [b_i, a_i]]

then nodes are updated in order ``i = 0 .. n-1`` (Gauss-Seidel: node ``i`` sees the already
updated ``xy_j`` for ``j < i`` and the old one for ``j > i``)::

    v = K_i xy_i + sum_{j in adj(i)} R(phase_i - phase_j) xy_j      (R: 2-D rotation)
    v = clip(v, xy_dot_old_i - 10, xy_dot_old_i + 10)                (per component)
    xy_dot_old_i <- xy_i;  xy_i <- xy_i + dt * v

Implementation
--------------
A node's 2-vector is held as one complex number, so ``K_i`` and the rotations are complex
multiplications. The sequential sweep cannot be vectorised over nodes, so the kernel loops over
steps and nodes in Python and vectorises over the batch; each node costs three numpy calls: the
clip that produces its new value (the derivative clamp, mapped through ``xy + dt * v``, which is
monotone so the result is the same) and a multiply-add that pushes the new value's coupling
into the accumulators of the nodes that see it next (later nodes this step, earlier nodes and
itself next step). Only elementwise ufuncs are used (no BLAS, no reductions, whose summation
order may depend on array shapes), so results do not depend on the batch size or on how the
integration is split into calls (tests check both bit for bit).

The operations are grouped differently from the literal update above, so the two agree to
rounding (about 1e-14 after 100 steps); as in any such oscillator network, some parameter
sets amplify rounding differences over long runs. Bit-identical results are promised between
the paths of this module (and ``NaCPG``) on one machine and numpy build, not across CPUs:
numpy may use fused multiply-add for complex products where the CPU has it.

Speed (2-core VM, shared): 1500 steps (15 s of CPG time) with 150 samples of 8 joints take
about 37 ms for one candidate and 63 ms for 32 candidates together.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ariel.utils import count_argument

try:  # the clip ufunc itself: one C call, unlike the np.clip Python wrapper
    from numpy._core.umath import clip as _clip_ufunc
except ImportError:  # pragma: no cover - numpy < 2.0
    from numpy.core.umath import clip as _clip_ufunc

__all__ = [
    "DEFAULT_HARD_BOUNDS",
    "DERIVATIVE_CLAMP",
    "EPSILON",
    "MAX_CPG_NODES",
    "NUM_PARAMETER_GROUPS",
    "PARAMETER_GROUPS",
    "STEP_TOLERANCE",
    "CPGState",
    "NaCPGKernel",
    "adjacency_matrix",
    "angles",
    "cpg_steps",
    "cpg_targets",
    "fully_connected_adjacency_matrix",
    "integrate",
    "random_parameters",
    "random_state",
    "split_parameters",
]

PARAMETER_GROUPS: tuple[str, ...] = ("phase", "w", "amplitudes", "ha", "b")
NUM_PARAMETER_GROUPS = len(PARAMETER_GROUPS)
EPSILON = 1e-9
"""Regulariser of upstream's ``zeta`` and ``b`` terms."""
DERIVATIVE_CLAMP = 10.0
"""Half-width of the derivative clamp around ``xy_dot_old``."""
STEP_TOLERANCE = 1e-9
"""Added to ``t / dt`` before flooring, so accumulated float time lands on the right step."""
DEFAULT_HARD_BOUNDS = (-math.pi / 2, math.pi / 2)
#: The most nodes (actuators) a full coupling is made for: the NDE's biggest body has 200.
MAX_CPG_NODES = 1024


class CPGState(NamedTuple):
    """Oscillator state: ``xy`` and ``xy_dot_old``, each ``(n, 2)`` or batched ``(B, n, 2)``.

    Attributes:
        xy: Each node's ``(x, y)``; ``y`` drives the joint target.
        xy_dot_old: Despite its (upstream) name, each node's previous ``(x, y)`` (see the
            module docstring).
    """

    xy: np.ndarray
    xy_dot_old: np.ndarray


# --------------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------------
def fully_connected_adjacency_matrix(n: int) -> np.ndarray:
    """Every node coupled to every other node, no self-coupling: ``(n, n)`` of 0/1 floats.

    Args:
        n: Number of oscillator nodes (>= 0).

    Returns:
        ``1 - eye(n)``, float64.

    Raises:
        TypeError: If ``n`` is not an int.
        ValueError: If ``n`` is negative or over `MAX_CPG_NODES`.
    """
    n = count_argument("n", n, maximum=MAX_CPG_NODES, function="fully_connected_adjacency_matrix")
    return 1.0 - np.eye(n)


def adjacency_matrix(
    adjacency: Mapping[int, Sequence[int]] | ArrayLike | None, n: int | None = None
) -> np.ndarray:
    """Coupling weights ``A`` (``A[i, j]``: how often node ``i`` receives from node ``j``).

    Args:
        adjacency: A dict ``{i: [j, ...]}`` (keys ``0 .. n-1``, as
            ``create_fully_connected_adjacency`` makes; a neighbour listed twice couples
            twice, as in upstream's loop), an ``(n, n)`` array of weights (booleans work), or
            None for fully connected (then ``n`` is required).
        n: The expected number of nodes, checked against ``adjacency``; None: taken from it.

    Returns:
        An ``(n, n)`` float64 array.

    Raises:
        ValueError: If ``adjacency`` is None without ``n``, its size is not ``n``, a dict's
            keys are not ``0 .. n-1`` or it lists an unknown node, or an array is not square
            or holds NaN or inf.
    """
    if adjacency is None:
        if n is None:
            raise ValueError("adjacency=None (fully connected) needs the number of nodes n")
        return fully_connected_adjacency_matrix(n)
    if isinstance(adjacency, Mapping):
        size = len(adjacency)
        if n is not None and n != size:
            raise ValueError(f"adjacency has {size} nodes; expected {n}")
        keys = sorted(adjacency)
        if keys != list(range(size)):
            raise ValueError(f"adjacency keys must be 0..{size - 1}; got {keys}")
        matrix = np.zeros((size, size))
        for i, neighbours in adjacency.items():
            for j in neighbours:
                if not isinstance(j, (int, np.integer)) or not 0 <= j < size:
                    raise ValueError(f"adjacency[{i}] lists node {j!r}; allowed: 0..{size - 1}")
                matrix[i, j] += 1.0
        return matrix
    matrix = np.asarray(adjacency)
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1]:
        raise ValueError(f"adjacency matrix must be square (n, n); got shape {matrix.shape}")
    if n is not None and matrix.shape[0] != n:
        raise ValueError(f"adjacency matrix has {matrix.shape[0]} nodes; expected {n}")
    matrix = matrix.astype(np.float64)
    if not np.all(np.isfinite(matrix)):
        raise ValueError("adjacency matrix contains NaN or inf")
    return matrix


def split_parameters(params: ArrayLike) -> dict[str, np.ndarray]:
    """Views of the five groups of a flat ``(..., 5n)`` parameter array, by group name.

    Args:
        params: Flat parameters, last axis ``5n`` (see the module docstring).

    Returns:
        ``{"phase", "w", "amplitudes", "ha", "b"}`` -> ``(..., n)`` float64 arrays, views of
        ``params`` when it already is a float64 array.

    Raises:
        ValueError: If the last axis is not a multiple of 5.
    """
    flat = np.asarray(params, dtype=np.float64)
    if flat.shape[-1] % NUM_PARAMETER_GROUPS:
        raise ValueError(f"a flat NA-CPG parameter vector has 5*n entries; got {flat.shape[-1]}")
    n = flat.shape[-1] // NUM_PARAMETER_GROUPS
    return {name: flat[..., k * n : (k + 1) * n] for k, name in enumerate(PARAMETER_GROUPS)}


def random_parameters(
    n: int, rng: np.random.Generator | int | None = None, *, size: int | None = None
) -> np.ndarray:
    """Random flat parameters, ``(5n,)`` (or ``(size, 5n)``), with upstream's distributions.

    ``phase``, ``w``, ``amplitudes`` ~ U(-2π, 2π); ``ha`` ~ N(0, 1); ``b`` (an output offset in
    radians, unused upstream) ~ U(-0.1, 0.1), a small offset so a random network stays centred.

    Args:
        n: Number of oscillator nodes (one per actuator).
        rng: A ``numpy.random.Generator``, a seed, or None (fresh OS entropy).
        size: Number of parameter vectors (a batch); None for a single ``(5n,)`` vector.

    Returns:
        Float64 parameters, ``(5n,)`` or ``(size, 5n)``, groups in ``PARAMETER_GROUPS`` order.
    """
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    shape = (n,) if size is None else (size, n)
    two_pi = 2.0 * math.pi
    phase = gen.uniform(-two_pi, two_pi, shape)
    amplitudes = gen.uniform(-two_pi, two_pi, shape)  # drawn in upstream's order
    w = gen.uniform(-two_pi, two_pi, shape)
    ha = gen.standard_normal(shape)
    b = gen.uniform(-0.1, 0.1, shape)
    return np.concatenate([phase, w, amplitudes, ha, b], axis=-1)


def random_state(n: int, rng: np.random.Generator | int | None = None) -> CPGState:
    """Random initial state: ``xy`` and ``xy_dot_old`` ~ N(0, 1), each ``(n, 2)``.

    Args:
        n: Number of oscillator nodes.
        rng: A ``numpy.random.Generator``, a seed, or None (fresh OS entropy).

    Returns:
        The state (unbatched: give it to a kernel to start every network of a batch there).
    """
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    return CPGState(gen.standard_normal((n, 2)), gen.standard_normal((n, 2)))


def cpg_steps(times: ArrayLike, dt: float) -> np.ndarray:
    """Number of internal steps for simulated time(s): ``floor(t / dt + 1e-9)`` as int64.

    Args:
        times: Simulated time(s) in seconds (finite, >= 0), any shape.
        dt: The CPG's internal step, in seconds.

    Returns:
        The step counts, int64, with the shape of ``times``.

    Raises:
        ValueError: If a time is NaN, infinite or negative.
    """
    t = np.asarray(times, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("CPG sample times must be finite (got NaN or inf)")
    steps = np.floor(t / dt + STEP_TOLERANCE).astype(np.int64)
    if np.any(steps < 0):
        raise ValueError(f"CPG sample times must be >= 0; got min {float(t.min())}")
    return steps


def angles(
    params: ArrayLike,
    xy: ArrayLike | CPGState,
    hard_bounds: tuple[float, float] | None = DEFAULT_HARD_BOUNDS,
) -> np.ndarray:
    """Joint targets ``clip(amplitudes * y + b, lo, hi)``.

    Args:
        params: Flat parameters ``(..., 5n)``; they broadcast against the states.
        xy: States ``(..., n, 2)``, or a ``CPGState`` (its ``xy`` is used).
        hard_bounds: ``(lo, hi)`` in radians; None skips the clip.

    Returns:
        The joint targets in radians, ``(..., n)`` float64.

    Raises:
        ValueError: If ``params`` is not ``5n`` long, or ``hard_bounds`` is not a pair with
            ``lo <= hi``.
    """
    if isinstance(xy, CPGState):
        xy = xy.xy
    groups = split_parameters(params)
    y = np.asarray(xy, dtype=np.float64)[..., 1]
    return _outputs(groups["amplitudes"], groups["b"], y, hard_bounds)


def _outputs(
    amplitudes: np.ndarray,
    b: np.ndarray,
    y: np.ndarray,
    hard_bounds: tuple[float, float] | None,
) -> np.ndarray:
    """The one place outputs are computed, so every path rounds identically."""
    out = amplitudes * y
    out += b
    if hard_bounds is not None:
        lo, hi = _check_bounds(hard_bounds)
        np.clip(out, lo, hi, out=out)
    return out


def _check_bounds(hard_bounds: tuple[float, float]) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in hard_bounds)
    except (TypeError, ValueError):
        raise ValueError(f"hard_bounds must be (low, high) or None; got {hard_bounds!r}") from None
    if not lo <= hi:
        raise ValueError(f"hard_bounds low must be <= high; got {hard_bounds!r}")
    return lo, hi


def _as_batch(params: ArrayLike) -> np.ndarray:
    flat = np.asarray(params, dtype=np.float64)
    if flat.ndim == 1:
        flat = flat[None, :]
    if flat.ndim != 2:
        raise ValueError(f"params must have shape (5n,) or (B, 5n); got {flat.shape}")
    if flat.shape[1] % NUM_PARAMETER_GROUPS:
        raise ValueError(f"a flat NA-CPG parameter vector has 5*n entries; got {flat.shape[1]}")
    if not np.all(np.isfinite(flat)):
        raise ValueError("NA-CPG parameters contain NaN or inf")
    return np.ascontiguousarray(flat)


# --------------------------------------------------------------------------------------------
# The kernel
# --------------------------------------------------------------------------------------------
class NaCPGKernel:
    """``B`` NA-CPG networks with the same topology, integrated in lock-step.

    Build it once per parameter batch (rotations and buffers are precomputed), load a state with
    ``set_state``, move it forward with ``advance(k)`` and read ``state()`` / ``y()`` /
    ``angles(...)``. ``advance(a)`` then ``advance(b)`` gives bit-for-bit the same state as
    ``advance(a + b)``, and row ``r`` of a batch is bit-for-bit what a batch holding only that
    row would compute.

    Args:
        params: Flat parameters, ``(5n,)`` (a batch of one) or ``(B, 5n)``, all finite.
        adjacency: Which nodes are coupled, in any form `adjacency_matrix` takes; None:
            fully connected.
        alpha: Convergence rate of each oscillator to its limit cycle (finite).
        dt: Internal integration step, in seconds (finite, > 0).

    Raises:
        ValueError: If ``params`` has the wrong shape or holds NaN or inf, ``dt`` or ``alpha``
            is out of range, or ``adjacency`` is invalid for ``n`` nodes.

    Example:
        ```python
        from ariel.simulation.controllers.cpg_kernel import (
            NaCPGKernel,
            random_parameters,
            random_state,
        )

        kernel = NaCPGKernel(random_parameters(8, rng=0, size=4), alpha=0.1, dt=0.01)
        kernel.set_state(*random_state(8, rng=1))  # the same start for all 4 networks
        kernel.advance(100)  # 1 s of CPG time
        print(kernel.angles().shape)  # (4, 8)
        ```
    """

    def __init__(
        self,
        params: ArrayLike,
        adjacency: Mapping[int, Sequence[int]] | ArrayLike | None = None,
        *,
        alpha: float = 0.1,
        dt: float = 0.01,
    ) -> None:
        flat = _as_batch(params)
        batch, size = flat.shape
        n = size // NUM_PARAMETER_GROUPS
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0; got {dt}")
        if not math.isfinite(alpha):
            raise ValueError(f"alpha must be finite; got {alpha}")
        coupling = adjacency_matrix(adjacency, n)
        self.params = flat
        self.adjacency = coupling
        self.alpha = float(alpha)
        self.dt = float(dt)
        self.batch_size = batch
        self.n = n
        groups = split_parameters(flat)
        # Node-major layout (n, B): each node's row is contiguous over the batch.
        phase = groups["phase"].T
        self._ha = np.ascontiguousarray(groups["ha"].T)
        self._dt_w = np.ascontiguousarray(self.dt * groups["w"].T)
        # rot[k, j, :] = dt * R(phase_k - phase_j) where node k receives from node j, else 0.
        rot = np.exp(1j * (phase[:, None, :] - phase[None, :, :]))
        rot *= self.dt
        rot *= coupling[:, :, None]
        # Column j scattered in the order its receivers are visited after node j's update:
        # later nodes j+1..n-1 this step, then nodes 0..j next step (see _advance).
        order = [np.roll(np.arange(n), -(j + 1)) for j in range(n)]
        self._scatter = [np.ascontiguousarray(rot[order[j], j]) for j in range(n)]
        self._columns = [np.ascontiguousarray(rot[:, j]) for j in range(n)]
        self._allocate()
        self._acc_valid = False
        self._has_state = False

    def _allocate(self) -> None:
        """State, work buffers and the views the inner loop uses (built once, reused).

        With a batch of one, every loop view drops the batch axis and a node's new value is
        scattered through a stride-0 view: 1-D operands take numpy's fast path (a broadcast
        multiply costs twice as much), with the same elementwise arithmetic.
        """
        n, batch = self.n, self.batch_size
        cplx = np.complex128
        self._z = np.zeros((n, batch), dtype=cplx)  # xy as x + iy
        self._z_old = np.zeros((n, batch), dtype=cplx)  # xy_dot_old
        # Rows 0..n-1: coupling for this step; rows n..2n-1: coupling gathered for the next.
        self._acc = np.zeros((2 * n, batch), dtype=cplx)
        self._tmp = np.empty((n, batch), dtype=cplx)
        self._y = self._z.imag.T  # (B, n) view of the y components
        sq = np.empty((n, 2 * batch))
        k1 = np.empty((n, batch), dtype=cplx)  # 1 + dt*K as one complex factor
        bounds = np.empty((2, n, batch), dtype=cplx)  # clamp bounds: [0] low, [1] high

        def loop(arr: np.ndarray) -> np.ndarray:
            return arr[..., 0] if batch == 1 else arr

        zf = self._z.view(np.float64)  # (n, 2B): x, y interleaved per candidate
        k1f = k1.view(np.float64)
        accf = self._acc.view(np.float64)
        boundsf = bounds.view(np.float64)
        acc, z, tmp = loop(self._acc), loop(self._z), loop(self._tmp)
        rows = []
        for i in range(n):
            if batch == 1:  # the new value z_i seen n times through a stride-0 view
                z_i = np.lib.stride_tricks.as_strided(self._z[i], shape=(n,), strides=(0,))
            else:
                z_i = self._z[i]
            rows.append(
                (accf[i], boundsf[0, i], boundsf[1, i], zf[i], z_i,
                 loop(self._scatter[i]), acc[i + 1 : i + 1 + n])
            )  # fmt: skip
        width = DERIVATIVE_CLAMP * self.dt * (1 + 1j)
        self._loop = {
            "z": z,
            "z_old": loop(self._z_old),
            "zf": zf,
            "acc_now": acc[:n],
            "acc_next": acc[n:],
            "x_old": loop(self._z_old.view(np.float64)[:, 0::2]),
            "t1": np.empty(n) if batch == 1 else np.empty((n, batch)),
            "t2": np.empty(n) if batch == 1 else np.empty((n, batch)),
            "sq": sq,
            "sq_x": loop(sq[:, 0::2]),
            "sq_y": loop(sq[:, 1::2]),
            "r2": np.empty(n) if batch == 1 else np.empty((n, batch)),
            "k1": loop(k1),
            "k1_re": loop(k1f[:, 0::2]),
            "k1_im": loop(k1f[:, 1::2]),
            "bounds": loop(bounds),
            "clamp": np.array([-width, width]).reshape((2, 1) if batch == 1 else (2, 1, 1)),
            "tmp": tmp,
            "ha": loop(self._ha),
            "dt_w": loop(self._dt_w),
            "rows": rows,
        }

    def __getstate__(self) -> dict[str, object]:
        # The inner loop's views must alias this object's buffers: rebuild them on unpickle or
        # deepcopy instead of copying them (a copied view would point at private copies).
        return {
            "params": self.params,
            "adjacency": self.adjacency,
            "alpha": self.alpha,
            "dt": self.dt,
            "state": self.state() if self._has_state else None,
        }

    def __setstate__(self, saved: dict[str, object]) -> None:
        self.__init__(saved["params"], saved["adjacency"], alpha=saved["alpha"], dt=saved["dt"])
        if saved["state"] is not None:
            self.set_state(*saved["state"])

    # -- state ---------------------------------------------------------------------------------
    def set_state(self, xy: ArrayLike, xy_dot_old: ArrayLike) -> None:
        """Load ``xy`` and ``xy_dot_old``: ``(n, 2)`` (same for every row) or ``(B, n, 2)``."""
        for name, value, target in (("xy", xy, self._z), ("xy_dot_old", xy_dot_old, self._z_old)):
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape not in ((self.n, 2), (self.batch_size, self.n, 2)):
                raise ValueError(
                    f"{name} must have shape ({self.n}, 2) or ({self.batch_size}, {self.n}, 2);"
                    f" got {arr.shape}"
                )
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains NaN or inf")
            arr = np.broadcast_to(arr, (self.batch_size, self.n, 2))
            target.real = arr[..., 0].T
            target.imag = arr[..., 1].T
        self._acc_valid = False
        self._has_state = True

    def state(self) -> CPGState:
        """Copy of the current state, ``(B, n, 2)`` arrays."""
        return CPGState(_complex_to_xy(self._z), _complex_to_xy(self._z_old))

    def y(self) -> np.ndarray:
        """Copy of the current ``y`` components, ``(B, n)``."""
        return self._y.copy()

    def angles(self, hard_bounds: tuple[float, float] | None = DEFAULT_HARD_BOUNDS) -> np.ndarray:
        """Current joint targets, ``(B, n)``."""
        groups = split_parameters(self.params)
        return _outputs(groups["amplitudes"], groups["b"], self._y, hard_bounds)

    # -- integration ---------------------------------------------------------------------------
    def advance(self, n_steps: int) -> None:
        """Integrate every network ``n_steps`` internal steps of ``dt`` in place."""
        if n_steps < 0:
            raise ValueError(f"n_steps must be >= 0; got {n_steps}")
        if not self._has_state:
            raise RuntimeError("NaCPGKernel.advance() before set_state()")
        if n_steps == 0 or self.n == 0:
            return
        if not self._acc_valid:
            self._seed_accumulators()
        self._advance(int(n_steps))
        self._acc_valid = True

    def _seed_accumulators(self) -> None:
        """Coupling that node k gets from nodes j >= k (old values), summed in ascending j.

        This is exactly what the scatter of the previous step leaves in the "next step" half of
        the accumulator (moved to the "this step" half at the end of a step), so a fresh start
        and a continued run agree bit for bit.
        """
        acc, tmp = self._acc, self._tmp
        acc.fill(0)
        for j in range(self.n):
            np.multiply(self._columns[j][: j + 1], self._z[j], out=tmp[: j + 1])
            acc[: j + 1] += tmp[: j + 1]

    def _advance(self, n_steps: int) -> None:
        v = self._loop
        z, z_old, zf, acc_now, acc_next = v["z"], v["z_old"], v["zf"], v["acc_now"], v["acc_next"]
        x_old, t1, t2, ha, dt_w = v["x_old"], v["t1"], v["t2"], v["ha"], v["dt_w"]
        sq, sq_x, sq_y, r2 = v["sq"], v["sq_x"], v["sq_y"], v["r2"]
        k1, k1_re, k1_im = v["k1"], v["k1_re"], v["k1_im"]
        bounds, clamp, tmp, rows = v["bounds"], v["clamp"], v["tmp"], v["rows"]
        lo = bounds[0]
        dt = self.dt
        dt_alpha = dt * self.alpha
        one_plus_dt_alpha = 1.0 + dt_alpha
        one_plus_eps = 1.0 + EPSILON
        for _ in range(n_steps):
            # Node-local terms from the pre-update state (vectorised over nodes and batch).
            # zeta + E = (1 + E) - ha * (xo + E) / (|xo| + E);  dt * b = dt * w / (zeta + E)
            np.abs(x_old, out=t1)
            t1 += EPSILON
            np.add(x_old, EPSILON, out=t2)
            t2 /= t1
            t2 *= ha
            np.subtract(one_plus_eps, t2, out=t2)
            np.divide(dt_w, t2, out=k1_im)
            # 1 + dt * a = (1 + dt * alpha) - dt * alpha * r2^2
            np.square(zf, out=sq)
            np.add(sq_x, sq_y, out=r2)
            np.square(r2, out=r2)
            r2 *= dt_alpha
            np.subtract(one_plus_dt_alpha, r2, out=k1_re)
            # acc_now already holds sum_{j >= k} dt R_kj z_j; add z_k + dt K_k z_k.
            np.multiply(k1, z, out=tmp)
            acc_now += tmp
            # Clamp dt*v to dt*(xy_dot_old -+ 10): new in [z + dt*xo - 10dt, z + dt*xo + 10dt].
            np.multiply(z_old, dt, out=lo)
            lo += z
            np.add(lo, clamp, out=bounds)  # both bounds in one call (lo read before written)
            np.copyto(z_old, z)  # the quirk: xy_dot_old <- previous xy
            # Gauss-Seidel sweep: clip node i's update into place, then scatter its coupling.
            for acc_i, lo_i, hi_i, zf_i, z_i, scatter, window in rows:
                _clip_ufunc(acc_i, lo_i, hi_i, out=zf_i)
                np.multiply(scatter, z_i, out=tmp)
                window += tmp
            np.copyto(acc_now, acc_next)
            acc_next.fill(0)


def _complex_to_xy(z: np.ndarray) -> np.ndarray:
    """(n, B) complex -> (B, n, 2) float64 copy."""
    out = np.empty((z.shape[1], z.shape[0], 2))
    out[..., 0] = z.real.T
    out[..., 1] = z.imag.T
    return out


# --------------------------------------------------------------------------------------------
# Functional entry points
# --------------------------------------------------------------------------------------------
def integrate(
    params: ArrayLike,
    state: CPGState | tuple[ArrayLike, ArrayLike],
    n_steps: int,
    *,
    alpha: float = 0.1,
    dt: float = 0.01,
    adjacency: Mapping[int, Sequence[int]] | ArrayLike | None = None,
) -> CPGState:
    """State after ``n_steps`` internal steps; batch-first ``(B, n, 2)`` arrays.

    Args:
        params: Flat parameters ``(B, 5n)``, or ``(5n,)`` (then the batch axis is dropped
            from the result).
        state: ``(xy, xy_dot_old)``, each ``(n, 2)`` (the same for every network) or
            ``(B, n, 2)``.
        n_steps: Internal steps of ``dt`` to take (>= 0).
        alpha: Convergence rate of each oscillator to its limit cycle.
        dt: Internal integration step, in seconds (> 0).
        adjacency: Which nodes are coupled (see `adjacency_matrix`); None: fully connected.

    Returns:
        The new state, ``(B, n, 2)`` arrays (``(n, 2)`` for unbatched ``params``).

    Raises:
        ValueError: If an argument has the wrong shape or value (see `NaCPGKernel`), or
            ``n_steps`` is negative.
    """
    kernel = NaCPGKernel(params, adjacency, alpha=alpha, dt=dt)
    kernel.set_state(*state)
    kernel.advance(n_steps)
    out = kernel.state()
    if np.ndim(params) == 1:
        return CPGState(out.xy[0], out.xy_dot_old[0])
    return out


def cpg_targets(
    params: ArrayLike,
    initial_state: CPGState | tuple[ArrayLike, ArrayLike],
    sample_times: ArrayLike,
    *,
    alpha: float = 0.1,
    dt: float = 0.01,
    adjacency: Mapping[int, Sequence[int]] | ArrayLike | None = None,
    hard_bounds: tuple[float, float] | None = DEFAULT_HARD_BOUNDS,
) -> np.ndarray:
    """Joint targets of ``B`` networks at the given simulated times, ``(B, T, n)`` float64.

    The value at time ``t`` is the output after ``cpg_steps(t, dt)`` internal steps from
    ``initial_state`` (what ``NaCPG.forward(t)`` returns, before its float32 cast). Times may
    come in any order and repeat. ``params`` ``(5n,)`` gives ``(T, n)``.

    To reproduce the tutorial path (``Controller`` + ``NaCPG``) bit for bit, cast the result to
    float32 and back, as ``forward`` does, and smooth it with ``controller.blend_and_clip``.
    NaN (possible only through float overflow with extreme parameters) is returned as is,
    where ``NaCPG.forward`` raises.

    Args:
        params: Flat parameters ``(B, 5n)``, or ``(5n,)`` for one network.
        initial_state: ``(xy, xy_dot_old)`` at time 0, each ``(n, 2)`` (the same for every
            network) or ``(B, n, 2)``.
        sample_times: 1-D simulated times in seconds (finite, >= 0).
        alpha: Convergence rate of each oscillator to its limit cycle.
        dt: Internal integration step, in seconds (> 0).
        adjacency: Which nodes are coupled (see `adjacency_matrix`); None: fully connected.
        hard_bounds: ``(lo, hi)`` the targets are clipped to, in radians; None: no clip.

    Returns:
        The joint targets in radians, ``(B, T, n)`` float64 (``(T, n)`` for ``(5n,)``
        params), ``T`` being the number of sample times.

    Raises:
        ValueError: If an argument has the wrong shape or value (see `NaCPGKernel` and
            `cpg_steps`), ``sample_times`` is not 1-D, or ``hard_bounds`` is invalid.

    Example:
        ```python
        import numpy as np

        from ariel.simulation.controllers.cpg_kernel import (
            cpg_targets,
            random_parameters,
            random_state,
        )

        params = random_parameters(8, rng=0, size=4)  # 4 candidate brains for 8 joints
        targets = cpg_targets(params, random_state(8, rng=1), np.linspace(0.0, 2.0, 21))
        print(targets.shape)  # (4, 21, 8): candidate, sample time, joint
        ```
    """
    kernel = NaCPGKernel(params, adjacency, alpha=alpha, dt=dt)
    kernel.set_state(*initial_state)
    steps = cpg_steps(sample_times, kernel.dt)
    if steps.ndim != 1:
        raise ValueError(f"sample_times must be 1-D; got shape {steps.shape}")
    if hard_bounds is not None:
        _check_bounds(hard_bounds)
    y_samples = np.empty((kernel.batch_size, steps.size, kernel.n))
    done = 0
    for idx in np.argsort(steps, kind="stable"):
        target = int(steps[idx])
        if target > done:
            kernel.advance(target - done)
            done = target
        y_samples[:, idx, :] = kernel._y
    groups = split_parameters(kernel.params[:, None, :])
    out = _outputs(groups["amplitudes"], groups["b"], y_samples, hard_bounds)
    return out[0] if np.ndim(params) == 1 else out
