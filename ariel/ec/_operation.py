"""`EAOperation` (a checked ``Population -> Population`` step) and upstream's older `EAStep`."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from ariel.ec.population import Population

__all__ = ["EAOperation", "EAStep", "run_operation"]


def _name(func: Callable[..., Any]) -> str:
    return getattr(func, "__name__", None) or type(func).__name__


def _is_population(annotation: Any) -> bool:
    # String annotations come from `from __future__ import annotations` in the user's script;
    # upstream rejects those, which forces scripts to drop postponed annotations.
    if isinstance(annotation, str):
        return annotation.rsplit(".", 1)[-1].strip("'\"") == "Population"
    return isinstance(annotation, type) and issubclass(annotation, Population)


def _check_signature(func: Callable[..., Any]) -> inspect.Signature:
    """The signature of ``func``; ``TypeError`` unless it reads ``(population: Population, ...)
    -> Population``."""
    if not callable(func):
        raise TypeError(f"EAOperation wraps a function, not {func!r}")
    sig = inspect.signature(func)
    params = list(sig.parameters.values())
    name = _name(func)
    if not params:
        raise TypeError(f"EAOperation function {name!r} must take a Population as first argument")
    if not _is_population(params[0].annotation):
        raise TypeError(
            f"EAOperation function {name!r}: annotate its first argument as Population, "
            f"not {params[0].annotation!r}"
        )
    if not _is_population(sig.return_annotation):
        raise TypeError(
            f"EAOperation function {name!r}: annotate its return as Population, "
            f"not {sig.return_annotation!r}"
        )
    return sig


def _check_result(name: str, result: Any) -> Population:
    if isinstance(result, Population):
        return result
    if isinstance(result, list):  # upstream's older operations return plain lists
        return Population(result)
    raise TypeError(
        f"operation {name!r} returned {type(result).__name__}; it must return the Population"
    )


class EAOperation:
    """One step of the EA's per-generation pipeline, with its configuration bound.

    Decorate ``def mutate(population: Population, p: float = 0.2) -> Population`` with
    ``@EAOperation``; ``mutate(p=0.5)`` then returns a configured copy for the ``operations``
    list, and ``mutate(population)`` runs it. The signature is checked when decorating.

    Args:
        func: the operation, annotated ``(population: Population, ...) -> Population``
            (string annotations from ``from __future__ import annotations`` are accepted).
        *args: positional arguments bound after the population, passed on every run.
        **kwargs: keyword arguments bound to every run; a call's own keyword arguments
            override them.

    Raises:
        TypeError: ``func`` is not callable, lacks the ``Population`` annotations, or the bound
            arguments do not fit its signature.

    Example:
        ```python
        from ariel.ec import EAOperation, Individual, Population

        @EAOperation
        def kill_unfit(population: Population, threshold: float = 0.0) -> Population:
            for ind in population:
                ind.alive = ind.fitness >= threshold
            return population

        population = Population([Individual(), Individual()])
        population[0].fitness, population[1].fitness = 0.2, 0.8
        strict = kill_unfit(threshold=0.5)  # a configured copy, for an EA's operations list
        print([ind.alive for ind in strict(population)])  # [False, True]
        ```
    """

    def __init__(self, func: Callable[..., Population], *args: Any, **kwargs: Any) -> None:
        self._signature = _check_signature(func)
        self.func = func
        self.args = args
        self.kwargs = kwargs
        self.name = _name(func)
        if args or kwargs:
            try:  # fail when configuring, not generations later when the EA first runs it
                self._signature.bind(None, *args, **kwargs)
            except TypeError as exc:
                raise TypeError(f"EAOperation {self.name!r}: {exc}") from None

    def __call__(self, *args: Any, **kwargs: Any) -> Population | EAOperation:
        """Run on ``args[0]`` if it is a Population, else return a copy with these arguments."""
        if args and isinstance(args[0], Population):
            return self.run(args[0], *args[1:], **kwargs)
        return EAOperation(self.func, *args, **kwargs)

    def run(self, population: Population, *args: Any, **kwargs: Any) -> Population:
        """Apply the operation to ``population`` with the bound (and any extra) arguments."""
        result = self.func(population, *self.args, *args, **{**self.kwargs, **kwargs})
        return _check_result(self.name, result)

    def __repr__(self) -> str:
        bound = [repr(a) for a in self.args] + [f"{k}={v!r}" for k, v in self.kwargs.items()]
        return f"{self.name}({', '.join(bound)})"


class EAStep:
    """Upstream's older step wrapper: ``EAStep("name", func)`` or ``EAStep(func, name=, **kw)``.

    Args:
        *args: either ``(name, operation)`` or ``(operation,)``; ``operation`` is any callable
            ``Population -> Population`` (a returned plain list is turned into a `Population`).
        name: the step's name; defaults to the operation's ``__name__``. A name given as the
            first positional argument wins over this one.
        **kwargs: keyword arguments passed to the operation on every call.

    Raises:
        TypeError: the positional arguments are neither form, or the operation is not callable.
    """

    def __init__(self, *args: Any, name: str | None = None, **kwargs: Any) -> None:
        if len(args) == 2 and isinstance(args[0], str | type(None)):
            name, operation = args[0] or name, args[1]
        elif len(args) == 1:
            operation = args[0]
        else:
            raise TypeError('EAStep takes ("name", operation) or (operation, name=..., **kwargs)')
        if not callable(operation):
            raise TypeError(f"EAStep operation must be callable, not {operation!r}")
        self.operation = operation
        self.name = name or _name(operation)
        self.kwargs = kwargs

    def __call__(self, population: Population) -> Population:
        """Apply the operation with the bound keyword arguments."""
        return _check_result(self.name, self.operation(population, **self.kwargs))

    def __repr__(self) -> str:
        return f"EAStep({self.name!r})"


def run_operation(operation: Callable[..., Any], population: Population) -> Population:
    """Apply one entry of an ``operations`` list (EAOperation, EAStep or plain function)."""
    if isinstance(operation, EAOperation):
        return operation.run(population)
    return _check_result(_name(operation), operation(population))
