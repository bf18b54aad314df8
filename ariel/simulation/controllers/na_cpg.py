"""Normalized Asymmetric CPG (NA-CPG) as a torch module: the tutorial API.

The arithmetic lives in `ariel.simulation.controllers.cpg_kernel` (numpy, batch of one
here); this module adds the torch parameter interface the tutorials use. Differences from
upstream ARIEL (see docs/decisions.md, Control):

* ``forward(time)`` is a function of simulated time: it integrates from its last internal step
  to ``floor(time / dt + 1e-9)`` steps of ``dt``, so the gait does not depend on how often it is
  called. ``time == 0`` or a time before the last one restarts from the initial state;
  ``time=None`` takes one step (upstream's behaviour).
* All five parameter groups act; ``b`` is a per-joint output offset in radians.
* Parameters are float64 (so a float64 parameter vector from an optimiser is used exactly, on
  this path and on the vectorised evaluation path alike); ``forward`` returns float32.
* ``seed`` seeds a private generator (no global side effect); ``seed=None`` draws from torch's
  global RNG, so ``torch.manual_seed`` makes an unseeded CPG reproducible.
* Changing the parameters (through any API, including in-place edits of the tensors) restarts
  the oscillators from the initial state at the next ``forward`` call, so the output is always
  a function of (parameters, initial state, time).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any

import numpy as np
import torch
from torch import nn

from ariel.simulation.controllers.cpg_kernel import (
    DEFAULT_HARD_BOUNDS,
    EPSILON,
    MAX_CPG_NODES,
    NUM_PARAMETER_GROUPS,
    PARAMETER_GROUPS,
    STEP_TOLERANCE,
    CPGState,
    NaCPGKernel,
    _check_bounds,
    _clip_ufunc,
    _outputs,
    adjacency_matrix,
)
from ariel.utils import count_argument, number_argument

__all__ = ["MAX_STEPS_PER_CALL", "NaCPG", "create_fully_connected_adjacency", "time_step"]

_TWO_PI = 2.0 * math.pi
_B_INIT_RANGE = 0.1  # b ~ U(-0.1, 0.1) rad: a small offset, so a random network stays centred
#: Most internal steps one `NaCPG.forward` call integrates (10,000 s at dt 0.01; about 45 s of
#: work for 8 nodes): a wall-clock or epoch ``time`` would otherwise run for hours unannounced.
MAX_STEPS_PER_CALL = 1_000_000


def create_fully_connected_adjacency(num_nodes: int) -> dict[int, list[int]]:
    """``{i: [every j != i, ascending]}`` for ``i`` in ``0 .. num_nodes-1`` (``{}`` for 0).

    Args:
        num_nodes: Number of oscillator nodes (one per actuator, >= 0).

    Returns:
        The adjacency dict that `NaCPG` and `SimpleCPG` take: every node coupled to every
        other node.

    Raises:
        TypeError: If ``num_nodes`` is not an int (e.g. ``model.nu``).
        ValueError: If ``num_nodes`` is negative or over `MAX_CPG_NODES` (1024).
    """
    num_nodes = count_argument(
        "num_nodes", num_nodes, maximum=MAX_CPG_NODES, function="create_fully_connected_adjacency"
    )
    return {i: [j for j in range(num_nodes) if j != i] for i in range(num_nodes)}


def time_step(owner: str, time: object, dt: float, last: int) -> tuple[int, bool]:
    """The internal step a CPG's ``forward(time)`` integrates to, and whether it restarts
    first (``time`` 0, or a step before ``last``).

    Args:
        owner: The CPG class's name, for the messages.
        time: Simulated seconds (a number >= 0, finite).
        dt: The CPG's internal step, in seconds.
        last: The step the CPG is at.

    Returns:
        ``(target step, restart)``.

    Raises:
        TypeError: If ``time`` is not a number.
        ValueError: If ``time`` is negative, NaN or infinite, or lies more than
            `MAX_STEPS_PER_CALL` steps past where the CPG is.
    """
    where = f"{owner}.forward(time)"
    t = time if type(time) is float else number_argument(f"{owner}.forward: time", time)
    if not math.isfinite(t):
        raise ValueError(f"{where}: time must be finite, not NaN or inf; got {t}")
    steps = t / dt + STEP_TOLERANCE
    beyond = not math.isfinite(steps)  # 1e308 / 0.01: no step count at all (OverflowError)
    if beyond:
        steps = float(MAX_STEPS_PER_CALL + 1 + last)
    target = math.floor(steps)
    if target < 0:
        raise ValueError(f"{where}: time must be >= 0; got {t}")
    restart = abs(t) <= 1e-8 or target < last
    ahead = target - (0 if restart else last)
    if ahead > MAX_STEPS_PER_CALL:
        # written out up to a trillion, then as a float (a 300-digit count was printed)
        shown = "more than 1e308" if beyond else f"{ahead:,}" if ahead < 10**12 else f"{t / dt:.3g}"
        raise ValueError(
            f"{where}: time {t:g} s is {shown} steps of dt={dt:g} s past the last call; at "
            f"most {MAX_STEPS_PER_CALL:,} at a time (time is simulated seconds, such as "
            "data.time, not wall-clock or epoch time)"
        )
    return target, restart


def _check_seed(seed: Any) -> int | None:
    """``seed`` as an int in torch's range (or None), or a one-line ValueError."""
    if seed is None:
        return None
    if (
        isinstance(seed, numbers.Integral)
        and not isinstance(seed, bool)
        and -(2**63) <= seed < 2**64
    ):
        return int(seed)
    raise ValueError(f"NaCPG: seed must be None or an int (torch's seed range), not {seed!r}")


def _initial_draws(n: int, seed: int | None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """A network's random start: its parameters as one flat buffer (groups phase, w,
    amplitudes, ha, b), its initial ``xy`` and ``xy_dot_old``. From a private generator when
    seeded; torch's global RNG otherwise (docs/decisions.md)."""
    generator = None if seed is None else torch.Generator().manual_seed(seed)

    def uniform(low: float, high: float, *shape: int) -> torch.Tensor:
        draw = torch.rand(*shape, generator=generator, dtype=torch.float64)
        return low + (high - low) * draw

    # Drawn in upstream's order (phase, amplitudes, w, ha, b), stored in group order.
    phase = uniform(-_TWO_PI, _TWO_PI, n)
    amplitudes = uniform(-_TWO_PI, _TWO_PI, n)
    w = uniform(-_TWO_PI, _TWO_PI, n)
    ha = torch.randn(n, generator=generator, dtype=torch.float64)
    b = uniform(-_B_INIT_RANGE, _B_INIT_RANGE, n)
    flat = torch.cat([phase, w, amplitudes, ha, b])
    xy = torch.randn(n, 2, generator=generator, dtype=torch.float64)
    xy_dot_old = torch.randn(n, 2, generator=generator, dtype=torch.float64)
    return flat, xy, xy_dot_old


def _to_float64_array(values: Any, what: str) -> np.ndarray:
    """List / tuple / ndarray / tensor -> flat float64 numpy array (a copy)."""
    if isinstance(values, torch.Tensor):
        arr = values.detach().to(device="cpu", dtype=torch.float64).numpy()
    else:
        try:
            arr = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(
                f"{what} must be a list, numpy array or torch tensor of numbers; "
                f"got {type(values).__name__}"
            ) from None
    arr = np.array(arr, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or inf")
    return arr


class NaCPG(nn.Module):
    """One NA-CPG node per joint; ``forward(time)`` returns the joint targets (radians).

    Parameters: ``phase``, ``w``, ``amplitudes``, ``ha``, ``b`` (each ``(n,)``, float64
    ``nn.Parameter`` with ``requires_grad=False``). Output of node ``i``:
    ``clip(amplitudes_i * y_i + b_i, *hard_bounds)``.

    The parameters and the initial state are drawn at random (as `random_parameters` and
    `random_state` in `cpg_kernel` describe, through torch); set them with
    ``set_flat_params`` / ``set_initial_state``.

    Args:
        adjacency_dict: ``{node: [neighbours]}`` with keys ``0 .. n-1``, one node per
            actuator (e.g. ``create_fully_connected_adjacency(n)``).
        alpha: Convergence rate of each oscillator to its limit cycle (finite).
        dt: Internal integration step, in seconds (finite, > 0).
        hard_bounds: ``(low, high)`` the joint targets are clipped to, in radians; None: no
            clip.
        angle_tracking: Append every output of ``forward`` to ``angle_history``.
        seed: Seed of a private torch generator for the initial draws; None: torch's global
            RNG (so ``torch.manual_seed`` makes it reproducible).

    Raises:
        TypeError: If ``adjacency_dict`` is not a mapping.
        TypeError: If ``dt`` or ``alpha`` is not a number.
        ValueError: If ``adjacency_dict`` has keys other than ``0 .. n-1`` or lists an
            unknown node, ``dt`` or ``alpha`` is out of range, ``hard_bounds`` is not a pair
            with ``low <= high``, or ``seed`` is neither None nor an int.

    Example:
        ```python
        from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency

        cpg = NaCPG(create_fully_connected_adjacency(8), seed=42)
        print(cpg(0.5).shape)  # torch.Size([8]): joint targets at 0.5 s, radians
        ```
    """

    def __init__(
        self,
        adjacency_dict: Mapping[int, Sequence[int]],
        alpha: float = 0.1,
        dt: float = 0.01,
        hard_bounds: tuple[float, float] | None = DEFAULT_HARD_BOUNDS,
        *,
        angle_tracking: bool = False,
        seed: int | None = None,
    ) -> None:
        super().__init__()
        seed = _check_seed(seed)
        dt = number_argument("NaCPG: dt", dt)
        alpha = number_argument("NaCPG: alpha", alpha)
        if not isinstance(adjacency_dict, Mapping):
            raise TypeError(
                "adjacency_dict must be a dict {node: [neighbours]}, e.g. "
                f"create_fully_connected_adjacency(n); got {type(adjacency_dict).__name__}"
            )
        self._adjacency = adjacency_matrix(adjacency_dict)  # validates keys and neighbours
        self.adjacency_dict = {int(k): [int(j) for j in v] for k, v in adjacency_dict.items()}
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0; got {dt}")
        if not math.isfinite(alpha):
            raise ValueError(f"alpha must be finite; got {alpha}")
        self.n = len(adjacency_dict)
        self.alpha = float(alpha)
        self.dt = float(dt)
        self.hard_bounds = None if hard_bounds is None else _check_bounds(hard_bounds)
        self.angle_tracking = bool(angle_tracking)
        self.clamping_error = 0.0
        self.angle_history: list[list[float]] = []
        self.num_of_parameters = NUM_PARAMETER_GROUPS * self.n
        self.num_of_parameter_groups = NUM_PARAMETER_GROUPS

        n = self.n
        # The five parameters are views of one flat float64 buffer, so a single byte
        # comparison per forward call tells whether any of them changed.
        self._flat, xy, xy_dot_old = _initial_draws(n, seed)
        self._flat_np = self._flat.numpy()
        for k, name in enumerate(PARAMETER_GROUPS):
            view = self._flat[k * n : (k + 1) * n]
            setattr(self, name, nn.Parameter(view, requires_grad=False))
        self._expected_ptrs = [getattr(self, name).data_ptr() for name in PARAMETER_GROUPS]
        self._initial_xy = xy.numpy().copy()
        self._initial_xy_dot_old = xy_dot_old.numpy().copy()

        self._kernel: NaCPGKernel | None = None
        self._kernel_bytes = b""
        self._amplitudes = self._offsets = np.zeros(0)
        self._step = 0
        self.angles = torch.zeros(n, dtype=torch.float32)

    # -- parameters ------------------------------------------------------------------------
    @property
    def parameter_groups(self) -> dict[str, nn.Parameter]:
        """The five parameter tensors by name, in order ``phase, w, amplitudes, ha, b``."""
        return {name: getattr(self, name) for name in PARAMETER_GROUPS}

    def _flat_numpy(self) -> np.ndarray:
        """Current parameter values, flat float64 (a view of the shared buffer when possible)."""
        params = self._parameters
        for name, ptr in zip(PARAMETER_GROUPS, self._expected_ptrs):
            param = params[name]
            if param is None or param.data_ptr() != ptr:
                break
        else:
            return self._flat_np
        # A tensor's storage was replaced (``.data = ...``, deepcopy, unpickling, ``.to(...)``).
        values = [getattr(self, name).detach() for name in PARAMETER_GROUPS]
        if all(
            v.dtype == torch.float64 and v.device.type == "cpu" and v.numel() == self.n
            for v in values
        ):
            self._rehome(values)
            return self._flat_np
        return np.concatenate([v.cpu().numpy().reshape(-1) for v in values]).astype(np.float64)

    def _rehome(self, values: list[torch.Tensor]) -> None:
        """Make the parameters views of one fresh flat buffer again (same values and dtype)."""
        n = self.n
        flat = torch.cat([v.reshape(-1) for v in values]).clone()
        self._flat = flat
        self._flat_np = flat.numpy()
        for k, name in enumerate(PARAMETER_GROUPS):
            getattr(self, name).data = flat[k * n : (k + 1) * n]
        self._expected_ptrs = [getattr(self, name).data_ptr() for name in PARAMETER_GROUPS]

    def get_flat_params(self) -> torch.Tensor:
        """All parameters as one float64 tensor, groups in order ``phase, w, amplitudes, ha, b``."""
        return torch.from_numpy(np.array(self._flat_numpy(), dtype=np.float64))

    def set_flat_params(self, params: Any) -> None:
        """Set all ``5n`` parameters from a list, numpy array or tensor (group order as above)."""
        flat = _to_float64_array(params, "params")
        if flat.size != self.num_of_parameters:
            raise ValueError(
                f"expected {self.num_of_parameters} parameters ({NUM_PARAMETER_GROUPS} groups x "
                f"{self.n} nodes); got {flat.size}"
            )
        for k, name in enumerate(PARAMETER_GROUPS):
            self._assign(name, flat[k * self.n : (k + 1) * self.n])

    def set_params_by_group(self, group_name: str, params: Any) -> None:
        """Set one group (``phase``, ``w``, ``amplitudes``, ``ha`` or ``b``) of ``n`` values."""
        if group_name not in PARAMETER_GROUPS:
            raise ValueError(
                f"unknown parameter group {group_name!r}; allowed: {', '.join(PARAMETER_GROUPS)}"
            )
        values = _to_float64_array(params, f"parameter group {group_name!r}")
        if values.size != self.n:
            raise ValueError(
                f"parameter group {group_name!r} needs {self.n} values; got {values.size}"
            )
        self._assign(group_name, values)

    def set_param_with_dict(self, params: Mapping[str, Any]) -> None:
        """``set_params_by_group`` for every ``name: values`` item."""
        for name, values in params.items():
            self.set_params_by_group(name, values)

    def _assign(self, name: str, values: np.ndarray) -> None:
        param = getattr(self, name)
        with torch.no_grad():
            param.copy_(torch.from_numpy(values).to(dtype=param.dtype, device=param.device))

    # -- state -----------------------------------------------------------------------------
    @property
    def initial_state(self) -> CPGState:
        """Copy of the initial ``(xy, xy_dot_old)``, float64 ``(n, 2)`` each.

        Pass it to ``cpg_kernel.cpg_targets`` to reproduce this CPG's outputs bit for bit.
        """
        return CPGState(self._initial_xy.copy(), self._initial_xy_dot_old.copy())

    @initial_state.setter
    def initial_state(self, state: tuple[Any, Any]) -> None:
        self.set_initial_state(*state)

    def set_initial_state(self, xy: Any, xy_dot_old: Any) -> None:
        """Replace the initial state (``(n, 2)`` each) and restart from it."""
        arrays = []
        for name, value in (("xy", xy), ("xy_dot_old", xy_dot_old)):
            arr = _to_float64_array(value, name)
            if arr.size != 2 * self.n:
                raise ValueError(f"{name} must have shape ({self.n}, 2); got {arr.size} values")
            arrays.append(arr.reshape(self.n, 2))
        self._initial_xy, self._initial_xy_dot_old = arrays
        self.reset()

    @property
    def xy(self) -> torch.Tensor:
        """Current oscillator state ``(n, 2)`` (a copy)."""
        return torch.from_numpy(self._current_state().xy)

    @property
    def xy_dot_old(self) -> torch.Tensor:
        """Previous oscillator state ``(n, 2)`` (a copy; upstream's name)."""
        return torch.from_numpy(self._current_state().xy_dot_old)

    def _current_state(self) -> CPGState:
        if self._kernel is None:
            return self.initial_state
        state = self._kernel.state()
        return CPGState(state.xy[0], state.xy_dot_old[0])

    def reset(self) -> None:
        """Back to the initial state at step 0; clears ``angle_history``."""
        if self._kernel is not None:
            self._kernel.set_state(self._initial_xy, self._initial_xy_dot_old)
        self._step = 0
        self.angle_history = []
        self.clamping_error = 0.0
        self.angles = torch.zeros(self.n, dtype=torch.float32)

    def _current_kernel(self) -> NaCPGKernel:
        """The kernel for the current parameter values (rebuilt, and restarted, on change)."""
        flat = self._flat_numpy()
        kernel = self._kernel
        if kernel is None or flat.tobytes() != self._kernel_bytes:
            kernel = NaCPGKernel(flat, self._adjacency, alpha=self.alpha, dt=self.dt)
            self._kernel = kernel
            self._kernel_bytes = kernel.params.tobytes()
            n = self.n
            self._amplitudes = kernel.params[0, 2 * n : 3 * n]
            self._offsets = kernel.params[0, 4 * n : 5 * n]
            self.reset()
        return kernel

    # -- dynamics --------------------------------------------------------------------------
    def forward(self, time: float | None = None) -> torch.Tensor:
        """Joint targets at simulated ``time`` (float32, ``(n,)``); ``None`` = one more step.

        ``time`` is a number of seconds >= 0: an int, float, numpy scalar or one-element
        tensor (``data.time``); a string or bool is refused (TypeError)."""
        kernel = self._current_kernel()
        if time is None:
            target = self._step + 1
        else:
            target, restart = time_step("NaCPG", time, self.dt, self._step)
            if restart:
                self.reset()
        # Plain attributes are written through __dict__: nn.Module.__setattr__ costs
        # microseconds per call, and forward() runs once per control period.
        attrs = self.__dict__
        if target > self._step:
            kernel.advance(target - self._step)
            attrs["_step"] = target

        angles = _outputs(self._amplitudes, self._offsets, kernel._y[0], None)
        if self.hard_bounds is not None:
            clipped = _clip_ufunc(angles, *self.hard_bounds)
            np.subtract(angles, clipped, out=angles)
            check = attrs["clamping_error"] = float(np.abs(angles, out=angles).sum())
            angles = clipped
        else:
            check = float(angles.sum())
        if math.isnan(check):
            raise ValueError(f"NaCPG produced NaN joint targets at step {self._step}")
        if self.angle_tracking:
            self.angle_history.append(angles.tolist())
        out = attrs["angles"] = torch.from_numpy(angles.astype(np.float32))
        return out

    # -- persistence -----------------------------------------------------------------------
    def save(self, path: str | PathLike[str]) -> None:
        """``torch.save`` the five groups (and the initial state) as a dict of tensors."""
        payload = {name: getattr(self, name).detach().clone() for name in PARAMETER_GROUPS}
        payload["initial_xy"] = torch.from_numpy(self._initial_xy.copy())
        payload["initial_xy_dot_old"] = torch.from_numpy(self._initial_xy_dot_old.copy())
        torch.save(payload, path)

    def load(self, path: str | PathLike[str]) -> None:
        """Load what ``save`` wrote (files holding only the five groups work too)."""
        payload = torch.load(path, weights_only=True)
        missing = [name for name in PARAMETER_GROUPS if name not in payload]
        if missing:
            raise ValueError(f"{path} lacks parameter group(s) {missing}")
        self.set_param_with_dict({name: payload[name] for name in PARAMETER_GROUPS})
        if "initial_xy" in payload and "initial_xy_dot_old" in payload:
            self.set_initial_state(payload["initial_xy"], payload["initial_xy_dot_old"])
        else:
            self.reset()

    # -- upstream's term helpers (work on floats, numpy arrays and tensors) ----------------
    @staticmethod
    def term_a(alpha: Any, r2: Any) -> Any:
        """``alpha * (1 - r2**2)``: pull towards the limit cycle."""
        return alpha * (1 - r2**2)

    @staticmethod
    def term_b(zeta: Any, w: Any) -> Any:
        """``w / (zeta + 1e-9)``: the (asymmetric) angular velocity."""
        return w / (zeta + EPSILON)

    @staticmethod
    def zeta(ha: Any, x_old: Any) -> Any:
        """``1 - ha * (x_old + 1e-9) / (|x_old| + 1e-9)``: about ``1 - ha * sign(x_old)``."""
        return 1 - ha * (x_old + EPSILON) / (abs(x_old) + EPSILON)

    def extra_repr(self) -> str:
        return f"n={self.n}, alpha={self.alpha}, dt={self.dt}, hard_bounds={self.hard_bounds}"
