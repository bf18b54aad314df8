"""Brain learning: one learner per body over its controller's parameters, ask / tell one
iteration (a batch of ``brain.popsize`` candidates) at a time.

The learner is a `BrainOptimizer` plugin named by ``brain.optimizer`` (``cmaes``, the default:
CMA-ES, Hansen & Ostermeier 2001, with the ``cma`` package; ``nevergrad``; or one from an
entry point in group ``ariel.brain_optimizers``), made by ``brain_optimizers.make(name, x0=...,
popsize=..., sigma0=..., seed=..., maximise=..., **options)``: ``x0`` the first mean (its
length is the parameter count), ``popsize`` the batch every `ask` gives, ``sigma0`` the
initial step size (``brain.sigma0``; a learner without one ignores it), ``seed`` the body's
own seed (every draw of the learner derives from it, never from a shared generator), and
``maximise`` the fitness direction; ``options`` are the config's ``brain.optimizer_options``.

`BrainRun` wraps a body's learner for the loop: it keeps the iteration count and the best
candidate it was told (the same for every learner, so a body's fitness is always its best
evaluation's), and gives a body without parameters (no actuators) one evaluation of the empty
vector without a learner. A run is stored as plain data (`BrainRun.to_plain`): its settings,
its best, and its learner's `BrainOptimizer.state`; `BrainRun.from_plain` makes a fresh
learner and restores that state. Both built-in learners store what they were told
(`ToldHistory`) and restore by telling a fresh learner the same again (`replay_told`), which
rebuilds the same state bit for bit.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NotRequired, Protocol, TypedDict, runtime_checkable

import numpy as np
from threadpoolctl import threadpool_limits

from ariel.plugins import brain_optimizers

__all__ = [
    "BrainOptimizer",
    "BrainRun",
    "BrainRunPlain",
    "ToldHistory",
    "ToldState",
    "fitness_rank",
    "penalised_cost",
    "replay_told",
]


def fitness_rank(fitness: float, maximise: bool) -> float:
    """A sort key, smaller is better, whichever way the fitness points; failures (NaN, inf)
    rank last."""
    if not math.isfinite(fitness):
        return math.inf
    return -fitness if maximise else fitness


@runtime_checkable
class BrainOptimizer(Protocol):
    """Ask / tell over one body's controller parameters; see the module docstring."""

    def ask(self) -> np.ndarray:
        """The next iteration's candidates, ``(popsize, len(x0))`` floats."""
        ...

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> None:
        """The fitness of the candidates the last `ask` gave (same order), in the run's
        direction (``maximise``); a failed evaluation's is NaN or infinite (`penalised_cost`
        turns them into the worst finite cost)."""
        ...

    def state(self) -> Mapping[str, object]:
        """Plain data (JSON-able; NaN and infinities are allowed) that `restore` takes back."""
        ...

    # Any: what `state` gave, read back from JSON; its shape is the learner's own (a TypedDict
    # such as `ToldState`), which a protocol cannot name for every learner.
    def restore(self, state: Any) -> None:
        """Continue, on a fresh learner made with the same keywords, from `state`: the next
        `ask` gives exactly what the learner that gave `state` would have."""
        ...


def penalised_cost(fitness: np.ndarray, maximise: bool) -> np.ndarray:
    """Costs to minimise: the fitness (negated when maximised), failed candidates (NaN, inf)
    ranked last with a finite penalty (the batch's worst finite cost + 1e6).

    Args:
        fitness: One batch's fitness values, one per candidate; NaN or infinite for a failed
            evaluation.
        maximise: Whether higher fitness is better (then the cost is the negated fitness).

    Returns:
        A new float64 array of costs, the same shape as ``fitness``, smaller is better; every
        failed candidate gets the worst finite cost of the batch + 1e6 (1e6 when none is
        finite).
    """
    fitness = np.asarray(fitness, dtype=np.float64)
    finite = np.isfinite(fitness)
    cost = -fitness if maximise else fitness.copy()
    worst = float(np.max(cost[finite])) if finite.any() else 0.0
    cost[~finite] = worst + 1e6
    return cost


def _digest(params: np.ndarray) -> str:
    """A short fingerprint of a batch of candidates (float64 bytes)."""
    data = np.ascontiguousarray(params, dtype=np.float64).tobytes()
    return hashlib.sha256(data).hexdigest()[:16]


class ToldState(TypedDict):
    """A `ToldHistory` as plain data: each iteration's fitness (``told``) and, since it was
    stored, a fingerprint of each iteration's candidates (``asked``)."""

    told: list[list[float]]
    asked: NotRequired[list[str]]


class ToldHistory:
    """What a learner was told, as plain data: each iteration's fitness and a fingerprint of
    its candidates. The state of a learner whose asks depend only on its seed and what it was
    told; `replay_told` restores it."""

    def __init__(self) -> None:
        self.told: list[list[float]] = []
        self.asked: list[str] = []

    def add(self, params: np.ndarray, fitness: np.ndarray) -> None:
        self.told.append(np.asarray(fitness, dtype=np.float64).tolist())
        self.asked.append(_digest(params))

    def plain(self) -> ToldState:
        return {"told": [list(batch) for batch in self.told], "asked": list(self.asked)}


def replay_told(learner: BrainOptimizer, state: ToldState) -> None:
    """Tell a fresh ``learner`` what ``state`` (`ToldHistory.plain`) says, asking again before
    each tell.

    Args:
        learner: A fresh learner, made with the same keywords (seed included) as the one that
            gave ``state``; it is asked and told in place.
        state: `ToldHistory.plain` data: ``"told"``, each iteration's fitness, and optionally
            ``"asked"``, a fingerprint of each iteration's candidates to check against.

    Raises:
        ValueError: When the learner asks other candidates than the stored run did (e.g. made
            by another version of its package), which would continue another run.
    """
    asked = state.get("asked")
    with threadpool_limits(limits=1):  # as in the loop: the same eigendecompositions
        for k, fitness in enumerate(state["told"]):
            params = learner.ask()
            if asked is not None and _digest(params) != asked[k]:
                raise ValueError(
                    f"the restored brain optimizer asks other candidates in iteration {k} than "
                    "the stored run did (another version of its package?)"
                )
            learner.tell(params, np.asarray(fitness, dtype=np.float64))


class BrainRunPlain(TypedDict):
    """A `BrainRun` as plain data (`BrainRun.to_plain`): its settings, its best and its
    learner's `BrainOptimizer.state` (None without a learner)."""

    n_params: int
    popsize: int
    maximise: bool
    x0: list[float]
    sigma0: float
    seed: int
    optimizer: str
    options: dict[str, object]
    iteration: int
    best_params: list[float] | None
    best_fitness: float
    state: Mapping[str, object] | None


@dataclass
class BrainRun:
    """One body's brain run with learner ``optimizer`` (and its ``options``), `ask` / `tell`
    one iteration (a batch of ``popsize``) at a time.

    A body without parameters (no actuators) gets one evaluation of the empty vector.
    ``best_params`` / ``best_fitness`` track the best candidate seen (in the fitness's own
    direction, ``maximise``).

    Attributes:
        n_params: The number of controller parameters (the length of every candidate); 0 for a
            body without actuators, which gets no learner.
        popsize: Candidates per iteration (the batch every `ask` gives; ``brain.popsize``).
        maximise: Whether higher fitness is better.
        x0: The learner's first mean, ``(n_params,)`` floats.
        sigma0: The learner's initial step size (``brain.sigma0``); a learner without one
            ignores it.
        seed: The body's own seed: every draw of the learner derives from it.
        optimizer: The name of the `BrainOptimizer` plugin (``brain.optimizer``), e.g.
            ``"cmaes"`` or ``"nevergrad"``.
        options: Extra keywords for the learner (``brain.optimizer_options``).
        iteration: How many iterations (batches) have been told so far.
        best_params: The best candidate told so far, or None before the first finite fitness.
        best_fitness: The fitness of ``best_params``; NaN before the first finite fitness.
        learner: The learner, made from the fields above when the run is created; None when
            ``n_params`` is 0.
    """

    n_params: int
    popsize: int
    maximise: bool
    x0: np.ndarray
    sigma0: float
    seed: int
    optimizer: str = "cmaes"
    options: dict[str, object] = field(default_factory=dict)
    iteration: int = 0
    best_params: np.ndarray | None = None
    best_fitness: float = field(default=math.nan)
    learner: BrainOptimizer | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.n_params == 0:
            return
        self.learner = brain_optimizers.make(
            self.optimizer,
            x0=np.asarray(self.x0, dtype=np.float64),
            popsize=self.popsize,
            sigma0=self.sigma0,
            seed=self.seed,
            maximise=self.maximise,
            **self.options,
        )

    @property
    def batch_size(self) -> int:
        return 1 if self.n_params == 0 else self.popsize

    def ask(self) -> np.ndarray:
        """The next iteration's candidates, ``(batch_size, n_params)`` float64."""
        if self.learner is None:
            return np.zeros((1, 0))
        params = np.asarray(self.learner.ask(), dtype=np.float64)
        if params.shape != (self.popsize, self.n_params):
            raise ValueError(
                f"brain optimizer {self.optimizer!r} asked for candidates of shape "
                f"{params.shape}; the run needs ({self.popsize}, {self.n_params}): "
                "popsize x parameters"
            )
        finite = np.isfinite(params).all(axis=1)
        if not finite.all():  # a task's params must be finite: name the learner
            rows = np.flatnonzero(~finite)
            raise ValueError(
                f"brain optimizer {self.optimizer!r} asked for candidates with NaN or inf "
                f"(candidate {', '.join(map(str, rows[:3].tolist()))}"
                f"{', ...' if len(rows) > 3 else ''}); every parameter must be finite"
            )
        return params

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> int | None:
        """Report the fitness of the candidates `ask` gave (same order).

        Returns the index of this batch's candidate that became the best so far, or None.
        """
        fitness = np.asarray(fitness, dtype=np.float64)
        finite = np.isfinite(fitness)
        improved = None
        if finite.any():
            if self.maximise:
                best = int(np.argmax(np.where(finite, fitness, -np.inf)))
            else:
                best = int(np.argmin(np.where(finite, fitness, np.inf)))
            if self.best_params is None or self._better(fitness[best], self.best_fitness):
                self.best_fitness = float(fitness[best])
                self.best_params = np.array(params[best], dtype=np.float64)
                improved = best
        if self.learner is not None:
            self.learner.tell(params, fitness)
        self.iteration += 1
        return improved

    def to_plain(self) -> BrainRunPlain:
        """The run as JSON-able data: its settings, its best and its learner's state."""
        best = self.best_params
        return {
            "n_params": self.n_params,
            "popsize": self.popsize,
            "maximise": self.maximise,
            "x0": np.asarray(self.x0, dtype=np.float64).tolist(),
            "sigma0": self.sigma0,
            "seed": self.seed,
            "optimizer": self.optimizer,
            "options": self.options,
            "iteration": self.iteration,
            "best_params": None if best is None else np.asarray(best, dtype=np.float64).tolist(),
            "best_fitness": self.best_fitness,
            "state": None if self.learner is None else self.learner.state(),
        }

    # Any: a checkpoint's JSON, checked only by making the run from it (and older runs' form).
    @classmethod
    def from_plain(cls, data: Mapping[str, Any]) -> BrainRun:
        """The run `to_plain` describes: a fresh learner, its state restored."""
        data = dict(data)
        if "state" not in data:  # stored before brain optimizers: a CMA-ES run and its told
            return cls._told_again(data)
        state = data.pop("state")
        iteration, best = int(data.pop("iteration")), data.pop("best_params")
        best_fitness = float(data.pop("best_fitness"))
        run = cls(**data)
        run.x0 = np.asarray(run.x0, dtype=np.float64)
        if run.learner is not None:
            run.learner.restore(state)
        run.iteration, run.best_fitness = iteration, best_fitness
        run.best_params = None if best is None else np.asarray(best, dtype=np.float64)
        return run

    @classmethod
    def _told_again(cls, data: dict[str, Any]) -> BrainRun:
        """A run stored as its CMA-ES settings and every fitness it was told: a fresh run
        asked and told the same again."""
        told = data.pop("told")
        run = cls(**data)
        run.x0 = np.asarray(run.x0, dtype=np.float64)
        with threadpool_limits(limits=1):  # as in the loop: the same eigendecompositions
            for fitness in told:
                run.tell(run.ask(), np.asarray(fitness, dtype=np.float64))
        return run

    def _better(self, a: float, b: float) -> bool:
        if math.isnan(b):
            return True
        return a > b if self.maximise else a < b
