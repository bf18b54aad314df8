"""The brain optimizer ``nevergrad``: any optimizer of Nevergrad (Rapin & Teytaud 2018) over a
body's controller parameters, ``method`` ``TwoPointsDE`` (differential evolution) by default.

The parameters are one ``ng.p.Array`` starting at ``x0`` with mutation scale ``sigma0``
(``brain.sigma0``); the optimizer is made with ``num_workers = popsize`` and asked for
``popsize`` candidates each iteration. Every draw comes from the parametrization's own
``random_state``, seeded from the body's seed, so a learner never touches numpy's global
generator. A Nevergrad optimizer has no plain-data state, so the state is what it was told
(`ToldHistory`), and restoring tells a fresh one the same again (`replay_told`): the same asks,
bit for bit.
"""

from __future__ import annotations

import difflib
import warnings
from typing import TYPE_CHECKING

import nevergrad as ng
import numpy as np

from ariel.evolution._brain import ToldHistory, ToldState, penalised_cost, replay_told

if TYPE_CHECKING:
    from nevergrad.optimization.base import OptCls
    from nevergrad.parametrization.core import Parameter

__all__ = ["Nevergrad"]

DEFAULT_METHOD = "TwoPointsDE"


def _optimizer_class(method: object) -> OptCls:
    """``nevergrad.optimizers.registry[method]``; `ValueError` naming the closest for others."""
    registry = ng.optimizers.registry
    if not isinstance(method, str) or method not in registry:
        close = difflib.get_close_matches(str(method), sorted(registry), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ValueError(
            f"unknown nevergrad method {method!r}{hint} (any name of "
            f"nevergrad.optimizers.registry, {len(registry)} of them, e.g. {DEFAULT_METHOD!r}, "
            "'NGOpt', 'CMA', 'PSO', 'OnePlusOne')"
        )
    return registry[method]


class Nevergrad:
    """Nevergrad's ``method`` from ``x0``; options ``method`` and ``budget``.

    Made by the plugin registry (``brain_optimizers.make("nevergrad", ...)``) with the keywords
    every brain optimizer takes; ``method`` and ``budget`` come from
    ``brain.optimizer_options``.

    Args:
        x0: The starting point, ``(n_params,)`` floats; its length is the parameter count.
        popsize: Candidates per iteration (each `ask` gives this many); also the optimizer's
            ``num_workers``.
        sigma0: The mutation scale of the parameters (``ng.p.Array.set_mutation(sigma=...)``).
        seed: The body's seed; the parametrization's own ``random_state`` is seeded from it.
        maximise: Whether higher fitness is better (Nevergrad minimises the penalised cost).
        method: The name of an optimizer in ``nevergrad.optimizers.registry``, e.g.
            ``"TwoPointsDE"`` (the default), ``"NGOpt"``, ``"CMA"``, ``"PSO"``.
        budget: Evaluations, for methods that plan with one, such as ``NGOpt``; None (the
            default) gives no budget.

    Raises:
        ValueError: When ``method`` is not in Nevergrad's registry (the message names the
            closest one), or ``budget`` is not a whole number >= 1.
    """

    def __init__(
        self,
        *,
        x0: np.ndarray,
        popsize: int,
        sigma0: float,
        seed: int,
        maximise: bool,
        method: str = DEFAULT_METHOD,
        budget: int | None = None,
    ) -> None:
        cls = _optimizer_class(method)
        if budget is not None and (type(budget) is not int or budget < 1):
            raise ValueError(f"budget must be a whole number of evaluations >= 1 (got {budget!r})")
        if getattr(cls, "no_parallelization", False) and popsize > 1:
            # Checked before making it: nevergrad's own refusal leaves a half-made optimizer
            # whose __del__ prints a traceback, and names an internal class.
            raise ValueError(
                f"method {method!r} evaluates one candidate at a time (nevergrad: no "
                f"parallelization), but brain.popsize asks for {popsize} an iteration: choose "
                f"a method that takes several, e.g. {DEFAULT_METHOD!r}, 'CMA' or 'NGOpt'"
            )
        self.maximise, self.popsize, self.method, self.budget = maximise, popsize, method, budget
        self.history = ToldHistory()
        parameters = ng.p.Array(init=np.asarray(x0, dtype=np.float64)).set_mutation(sigma=sigma0)
        parameters.random_state = np.random.RandomState(np.random.MT19937(seed))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._optimizer = cls(parametrization=parameters, budget=budget, num_workers=popsize)
        self._asked: list[Parameter] = []  # the candidates of the last ask, to tell

    def ask(self) -> np.ndarray:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self._asked = [self._optimizer.ask() for _ in range(self.popsize)]
        except (AssertionError, TypeError) as exc:
            if self.budget is not None or self.history.told:
                raise
            # NGOpt and the sampling searches (LHSSearch, ScrHammersleySearch...) plan with a
            # budget and fail their first ask without one: say so rather than nevergrad's
            # bare AssertionError.
            # (nevergrad's own words, "AssertionError: Error:", said nothing: chained only)
            raise ValueError(
                f"method {self.method!r} needs a budget (it plans its asks with one): give it "
                "one in brain.optimizer_options, e.g. budget = brain.popsize x "
                "brain.iterations (x generations in a brain-only run)"
            ) from exc
        return np.array([c.value for c in self._asked], dtype=np.float64)

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> None:
        asked = np.array([c.value for c in self._asked], dtype=np.float64)
        if not np.array_equal(np.asarray(params, dtype=np.float64), asked):
            raise ValueError("tell() needs the candidates of the last ask(), in order")
        self.history.add(params, fitness)
        cost = penalised_cost(fitness, self.maximise)  # Nevergrad minimises
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for candidate, value in zip(self._asked, cost.tolist()):
                self._optimizer.tell(candidate, value)
        self._asked = []

    def state(self) -> ToldState:
        return self.history.plain()

    def restore(self, state: ToldState) -> None:
        replay_told(self, state)
