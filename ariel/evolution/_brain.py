"""Brain learning: CMA-ES (Hansen & Ostermeier 2001; the ``cma`` package) over controller
parameters, one ask/tell run per body.

pycma draws its samples from ``numpy.random``'s global generator unless given ``randn``; with
several runs progressing side by side that would make each run depend on the others' timing.
So every run owns its generator (`_Randn`), seeded from the run seed and the body. A run is
stored as plain data (`BrainRun.to_plain`): its settings and the fitness it was told; loading
it tells a fresh run the same again (`BrainRun.from_plain`), which rebuilds the same state.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BrainRun", "fitness_rank"]


def fitness_rank(fitness: float, maximise: bool) -> float:
    """A sort key, smaller is better, whichever way the fitness points; failures (NaN, inf)
    rank last."""
    if not math.isfinite(fitness):
        return math.inf
    return -fitness if maximise else fitness


class _Randn:
    """``randn(*shape)`` from a run's own generator (pycma's ``randn`` option); picklable."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


@dataclass
class BrainRun:
    """One body's CMA-ES run, `ask` / `tell` one iteration (a batch of ``popsize``) at a time.

    A body without parameters (no actuators) gets one evaluation of the empty vector.
    ``best_params`` / ``best_fitness`` track the best candidate seen (in the fitness's own
    direction, ``maximise``).
    """

    n_params: int
    popsize: int
    maximise: bool
    x0: np.ndarray
    sigma0: float
    seed: int
    iteration: int = 0
    best_params: np.ndarray | None = None
    best_fitness: float = field(default=math.nan)
    told: list[list[float]] = field(default_factory=list)  # each iteration's fitness, in order
    _es: object | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.n_params == 0:
            return
        import cma

        options = {
            "popsize": self.popsize,
            "seed": math.nan,  # "do nothing" to the global RNG; samples come from randn
            "randn": _Randn(np.random.default_rng(self.seed)),
            "verbose": -9,
            "verb_log": 0,  # no outcmaes/ files
            "verb_disp": 0,
            "CMA_diagonal": False,
        }
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._es = cma.CMAEvolutionStrategy(np.asarray(self.x0, float), self.sigma0, options)

    @property
    def batch_size(self) -> int:
        return 1 if self.n_params == 0 else self.popsize

    def ask(self) -> np.ndarray:
        """The next iteration's candidates, ``(batch_size, n_params)`` float64."""
        if self._es is None:
            return np.zeros((1, 0))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.array(self._es.ask(), dtype=np.float64)

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> int | None:
        """Report the fitness of the candidates `ask` gave (same order).

        Returns the index of this batch's candidate that became the best so far, or None.
        """
        fitness = np.asarray(fitness, dtype=np.float64)
        self.told.append(fitness.tolist())
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
        if self._es is not None:
            # CMA-ES minimises; failed candidates (inf/NaN) rank last with a finite penalty.
            cost = -fitness if self.maximise else fitness.copy()
            worst = float(np.max(cost[finite])) if finite.any() else 0.0
            cost[~finite] = worst + 1e6
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self._es.tell(list(params), cost.tolist())
        self.iteration += 1
        return improved

    def to_plain(self) -> dict[str, Any]:
        """The run as JSON-able data: its settings and every fitness it was told."""
        return {
            "n_params": self.n_params,
            "popsize": self.popsize,
            "maximise": self.maximise,
            "x0": np.asarray(self.x0, dtype=np.float64).tolist(),
            "sigma0": self.sigma0,
            "seed": self.seed,
            "told": [list(batch) for batch in self.told],
        }

    @classmethod
    def from_plain(cls, data: dict[str, Any]) -> BrainRun:
        """The run `to_plain` describes: a fresh run asked and told the same again."""
        from threadpoolctl import threadpool_limits

        told = data["told"]
        run = cls(**{key: value for key, value in data.items() if key != "told"})
        run.x0 = np.asarray(run.x0, dtype=np.float64)
        with threadpool_limits(limits=1):  # as in the loop: the same eigendecompositions
            for fitness in told:
                run.tell(run.ask(), np.asarray(fitness, dtype=np.float64))
        return run

    def _better(self, a: float, b: float) -> bool:
        if math.isnan(b):
            return True
        return a > b if self.maximise else a < b
