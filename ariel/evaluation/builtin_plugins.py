"""The built-in controllers and fitness functions: small adapters over code that lives elsewhere
in the package (the numpy CPG kernel, the tutorial's task functions); nothing here
re-implements it.

Importing this module registers nothing: the registries name these objects by
``"module:attr"`` strings (``ariel._builtin_names``) and import this module on the first
lookup of one of them. Body encoders live beside their encodings and worlds are their own
factories, so neither needs an adapter here.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ariel.plugins import fitness_function
from ariel.simulation.controllers import cpg_kernel
from ariel.simulation.controllers.observations import hinge_observation
from ariel.simulation.tasks.gait_learning import (
    sustained_displacement as _sustained,
    x_speed as _x_speed,
    xy_displacement as _xy_displacement,
)
from ariel.simulation.tasks.targeted_locomotion import distance_to_target as _distance_to_target
from ariel.simulation.tasks.turning_in_place import turning_in_place as _turning_in_place
from ariel.utils import whole_numbers

if TYPE_CHECKING:
    from ariel.evaluation._results import TrajectoryRecord

__all__ = [
    "MLPController",
    "NaCPGController",
    "distance_to_target",
    "hinge_observation",  # re-exported from its home beside the controllers
    "sustained_displacement",
    "turning_in_place",
    "x_speed",
    "xy_displacement",
]


# --------------------------------------------------------------------------------------------
# Controllers
# --------------------------------------------------------------------------------------------


class NaCPGController:
    """Open-loop NA-CPG, one oscillator per actuator (the tutorial's NaCPG, batched in numpy).

    Parameters: ``5 * nu`` (phase, w, amplitudes, ha, b). The oscillators' initial state is
    drawn from the evaluation seed. The constructor's keywords are the controller's options (a
    task's ``controller_options``). Targets are rounded to float32, as the tutorial's ``NaCPG``
    returns them, so this path and the tutorial path drive the robot with identical numbers.

    Args:
        alpha: Rate of convergence to the limit cycle (default 0.1).
        dt: The oscillators' internal integration step, in seconds (default 0.01).
        coupling: ``"full"`` (default): every oscillator sees every other; ``"none"``:
            independent oscillators. Anything else raises `ValueError`.
        hard_bounds: ``(low, high)`` joint targets are clipped to, in radians (default ±π/2).
        initial_amplitude: Half-width of the range random amplitudes are drawn from
            (`random_parameters` draws them from U(-initial_amplitude, initial_amplitude);
            default 1.0); finite and > 0, else `ValueError`.
    """

    open_loop = True

    def __init__(
        self,
        *,
        alpha: float = 0.1,
        dt: float = 0.01,
        coupling: str = "full",
        hard_bounds: tuple[float, float] = (-math.pi / 2, math.pi / 2),
        initial_amplitude: float = 1.0,
    ) -> None:
        if not (math.isfinite(initial_amplitude) and initial_amplitude > 0):
            raise ValueError(f"initial_amplitude must be > 0, not {initial_amplitude!r}")
        self.initial_amplitude = float(initial_amplitude)
        if coupling not in ("full", "none"):
            raise ValueError(f"coupling must be 'full' or 'none', not {coupling!r}")
        self.alpha = float(alpha)
        self.dt = float(dt)
        self.coupling = coupling
        self.hard_bounds = (float(hard_bounds[0]), float(hard_bounds[1]))

    def num_parameters(self, model: mujoco.MjModel) -> int:
        return cpg_kernel.NUM_PARAMETER_GROUPS * model.nu

    def random_parameters(
        self, model: mujoco.MjModel, rng: np.random.Generator, n: int
    ) -> np.ndarray:
        params = cpg_kernel.random_parameters(model.nu, rng, size=n)
        # The same draws, amplitudes scaled from upstream's U(-2π, 2π) to the option's range.
        amplitudes = slice(2 * model.nu, 3 * model.nu)
        params[:, amplitudes] *= self.initial_amplitude / (2 * math.pi)
        return params

    def initial_state(self, model: mujoco.MjModel, seed: int) -> cpg_kernel.CPGState:
        """The oscillators' initial state for an evaluation seed (``(nu, 2)`` arrays)."""
        return cpg_kernel.random_state(model.nu, np.random.default_rng(seed))

    def adjacency(self, n: int) -> np.ndarray:
        if self.coupling == "none":
            return np.zeros((n, n), dtype=bool)
        return cpg_kernel.fully_connected_adjacency_matrix(n)

    def targets(
        self,
        params: np.ndarray,
        sample_times: np.ndarray,
        model: mujoco.MjModel,
        *,
        seed: int,
    ) -> np.ndarray:
        """Targets ``(B, T, nu)`` at ascending ``sample_times`` (seconds).

        ``seed``: the evaluation seed; every row starts from the state it draws (the engine
        groups candidates by seed).
        """
        (out,) = self.iter_targets(params, sample_times, model, seed=seed, chunks=1)
        return out

    def iter_targets(
        self,
        params: np.ndarray,
        sample_times: np.ndarray,
        model: mujoco.MjModel,
        *,
        seed: int,
        chunks: int | Sequence[int],
    ) -> Iterator[np.ndarray]:
        """`targets` in consecutive pieces along time, computed lazily: ``chunks`` equal pieces,
        or pieces of the given sizes (summing to ``len(sample_times)``).

        Lets the engine start stepping physics on the first piece while the rest is computed.
        """
        batch = np.atleast_2d(np.asarray(params, dtype=np.float64))
        kernel = cpg_kernel.NaCPGKernel(
            batch, self.adjacency(model.nu), alpha=self.alpha, dt=self.dt
        )
        # operator.index: a list of seeds is refused, not hashed into one seed by default_rng.
        kernel.set_state(*self.initial_state(model, operator.index(seed)))
        steps = cpg_kernel.cpg_steps(sample_times, self.dt)
        if np.any(np.diff(steps) < 0):
            raise ValueError("sample_times must be ascending")
        done = 0
        if np.ndim(chunks) == 0:
            pieces = np.array_split(np.arange(steps.size), max(1, int(chunks)))
        else:
            if sum(chunks) != steps.size:
                raise ValueError(f"chunk sizes sum to {sum(chunks)}, not {steps.size} samples")
            pieces = np.split(np.arange(steps.size), np.cumsum(chunks)[:-1])
        for piece in pieces:
            xy = np.empty((batch.shape[0], piece.size, model.nu, 2))
            for j, idx in enumerate(piece):
                kernel.advance(int(steps[idx]) - done)
                done = int(steps[idx])
                xy[:, j] = kernel.state().xy
            out = cpg_kernel.angles(batch[:, None, :], xy, self.hard_bounds)
            yield out.astype(np.float32).astype(np.float64)


class MLPController:
    """Closed-loop brain: a one-hidden-layer tanh network from joint state and body tilt.

    Input ``[q, qdot, g_body]`` (``2 nu + 3``), ``hidden`` tanh units, output
    ``tanh(.) * output_scale`` as joint targets. Parameters: both weight matrices and
    biases, flattened (``(2nu+3)·h + h + h·nu + nu``). The constructor's keywords are the
    controller's options (a task's ``controller_options``).

    Args:
        hidden: Number of hidden tanh units, h (default 16): an int (else `TypeError`), at
            least 1 (else `ValueError`).
        output_scale: Largest joint target, in radians: outputs lie in
            ``(-output_scale, output_scale)`` (default π/2).
    """

    open_loop = False

    def __init__(self, *, hidden: int = 16, output_scale: float = math.pi / 2) -> None:
        whole_numbers(hidden=hidden)
        if int(hidden) < 1:
            raise ValueError(f"hidden must be >= 1, not {hidden!r}")
        self.hidden = int(hidden)
        self.output_scale = float(output_scale)

    def _sizes(self, model: mujoco.MjModel) -> tuple[int, int, int]:
        return 2 * model.nu + 3, self.hidden, model.nu

    def num_parameters(self, model: mujoco.MjModel) -> int:
        n_in, h, n_out = self._sizes(model)
        return n_in * h + h + h * n_out + n_out

    def random_parameters(
        self, model: mujoco.MjModel, rng: np.random.Generator, n: int
    ) -> np.ndarray:
        return rng.normal(0.0, 0.5, (n, self.num_parameters(model)))

    def make_policy(self, params: np.ndarray, model: mujoco.MjModel) -> Callable[..., np.ndarray]:
        n_in, h, n_out = self._sizes(model)
        p = np.asarray(params, dtype=np.float64)
        if p.size != self.num_parameters(model):
            raise ValueError(
                f"mlp controller needs {self.num_parameters(model)} parameters for "
                f"{model.nu} actuators; got {p.size}"
            )
        w1 = p[: n_in * h].reshape(h, n_in)
        b1 = p[n_in * h : n_in * h + h]
        w2 = p[n_in * h + h : n_in * h + h + h * n_out].reshape(n_out, h)
        b2 = p[n_in * h + h + h * n_out :]
        scale = self.output_scale

        def policy(observation: np.ndarray) -> np.ndarray:
            return np.tanh(w2 @ np.tanh(w1 @ observation + b1) + b2) * scale

        return policy


# --------------------------------------------------------------------------------------------
# Fitness functions: each takes the trajectory record (see ariel.evaluation.TrajectoryRecord)
# --------------------------------------------------------------------------------------------


@fitness_function(maximise=True, unit="m")
def xy_displacement(record: TrajectoryRecord) -> float:
    """Planar distance between the core's first and last recorded position (m).

    Args:
        record: The evaluation's recorded frames (a `TrajectoryRecord`).

    Returns:
        The distance in the xy plane, in metres (maximise).
    """
    return float(_xy_displacement(record.core_pos[0, :2], record.core_pos[-1, :2]))


@fitness_function(maximise=True, unit="m")
def sustained_displacement(record: TrajectoryRecord, window: float = 1.0) -> float:
    """Planar displacement at the path's median pace over ``window``-second pieces (m).

    The locomotion measure of the default experiment (docs/methodology.md): a steady gait
    scores its displacement; a single fall or lunge in one window does not count.

    Args:
        record: The evaluation's recorded frames (a `TrajectoryRecord`).
        window: Length of the pieces the run is cut into, in seconds (default 1.0; > 0,
            else `ValueError`). A fitness option.

    Returns:
        The median piece's progress along the net direction, scaled to the whole run, in
        metres; never negative. A run shorter than one window scores its `xy_displacement`.
    """
    return _sustained(record.time, record.core_pos, float(window))


@fitness_function(maximise=True, unit="m/s")
def x_speed(record: TrajectoryRecord) -> float:
    """Mean speed along x over the run, |Δx| / duration (m/s), as upstream.

    Args:
        record: The evaluation's recorded frames (a `TrajectoryRecord`).

    Returns:
        The speed in m/s (maximise); 0.0 for a record that spans no time.
    """
    return float(
        _x_speed(record.core_pos[0, :2], record.core_pos[-1, :2], record.time[-1] - record.time[0])
    )


@fitness_function(maximise=False, unit="m")
def distance_to_target(record: TrajectoryRecord, target: Sequence[float] | None = None) -> float:
    """Planar distance from the core's final position to the target (m; minimise).

    Args:
        record: The evaluation's recorded frames (a `TrajectoryRecord`).
        target: The goal ``(x, y)`` in metres (a fitness option; a third coordinate is
            ignored). None (the default): the world's target (``record.target``), else (2, 0).

    Returns:
        The distance in the xy plane, in metres (minimise).
    """
    goal = target if target is not None else record.target
    goal = (2.0, 0.0) if goal is None else goal
    return float(_distance_to_target(record.core_pos[-1, :2], np.asarray(goal, float)[:2]))


@fitness_function(maximise=True)
def turning_in_place(record: TrajectoryRecord) -> float:
    """Total heading change of the core's path per metre of net displacement (upstream's).

    Args:
        record: The evaluation's recorded frames (a `TrajectoryRecord`).

    Returns:
        The sum of the absolute heading changes between successive displacements of the
        core (radians; a full circle counts 2π) divided by ``1 + net displacement`` (m),
        planar; 0.0 for fewer than two frames. Maximise: more turning, less drift.
    """
    return float(_turning_in_place(record.core_pos[:, :2]))
