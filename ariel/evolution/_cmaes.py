"""The brain optimizer ``cmaes`` (the default): CMA-ES (Hansen & Ostermeier 2001) with pycma.

pycma draws its samples from ``numpy.random``'s global generator unless given ``randn``; with
several runs progressing side by side that would make each run depend on the others' timing.
So every learner owns its generator (`_Randn`), seeded from the body's seed. Its state is what
it was told (`ToldHistory`); restoring tells a fresh learner the same again (`replay_told`).

pycma's defaults are kept, with one exception where they cannot work (`_options`): from 300
parameters (``cma.evolution_strategy.TPA_dimension``) pycma adapts the step size by two-point
adaptation, which injects two candidates into every later iteration; with its selective mirrors
(``CMA_mirrors``, on below popsize 6) that is three injected candidates, and at popsize 2 the
second `tell` raises ("Found unused injected direction/solutions"). There the learner keeps the
cumulative step-size adaptation pycma uses below 300 parameters (``AdaptSigma``); its first
`ask` is the same. (``CMA_mirrors = 0`` would not do: pycma refuses popsize 2 without a mirror.)
"""

from __future__ import annotations

import math
import warnings

import cma
import numpy as np
from cma.evolution_strategy import TPA_dimension
from cma.sigma_adaptation import CMAAdaptSigmaCSA

from ariel.evolution._brain import ToldHistory, ToldState, penalised_cost, replay_told

__all__ = ["CMAES"]


class _Randn:
    """``randn(*shape)`` from a run's own generator (pycma's ``randn`` option); picklable."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


def _options(n_params: int, popsize: int) -> dict[str, object]:
    """pycma options beyond the defaults that a learner of ``n_params`` needs (see the module
    docstring): none, but at popsize 2 from ``TPA_dimension`` parameters on, where two-point
    step-size adaptation's two injected candidates and a selective mirror do not fit."""
    if popsize < 3 and n_params >= TPA_dimension:
        return {"AdaptSigma": CMAAdaptSigmaCSA}
    return {}


class CMAES:
    """CMA-ES from ``x0`` with step size ``sigma0`` and ``popsize`` candidates an iteration
    (full covariance); no options.

    Made by the plugin registry (``brain_optimizers.make("cmaes", ...)``) with the keywords
    every brain optimizer takes.

    Args:
        x0: The first mean, ``(n_params,)`` floats; its length is the parameter count.
        popsize: Candidates per iteration (each `ask` gives this many).
        sigma0: The initial step size (standard deviation of the first samples).
        seed: The body's seed; the learner's own generator (never numpy's global one) is
            seeded from it.
        maximise: Whether higher fitness is better (CMA-ES minimises the penalised cost).
    """

    def __init__(
        self, *, x0: np.ndarray, popsize: int, sigma0: float, seed: int, maximise: bool
    ) -> None:
        self.maximise = maximise
        self.history = ToldHistory()
        options = {
            "popsize": popsize,
            "seed": math.nan,  # "do nothing" to the global RNG; samples come from randn
            "randn": _Randn(np.random.default_rng(seed)),
            "verbose": -9,
            "verb_log": 0,  # no outcmaes/ files
            "verb_disp": 0,
            "CMA_diagonal": False,
            **_options(np.size(x0), popsize),
        }
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._es = cma.CMAEvolutionStrategy(np.asarray(x0, float), sigma0, options)

    def ask(self) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.array(self._es.ask(), dtype=np.float64)

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> None:
        self.history.add(params, fitness)
        cost = penalised_cost(fitness, self.maximise)  # CMA-ES minimises
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._es.tell(list(params), cost.tolist())

    def state(self) -> ToldState:
        return self.history.plain()

    def restore(self, state: ToldState) -> None:
        replay_told(self, state)
