"""`accept_aliases`: let a function take upstream ARIEL's keyword names, or our own old ones,
beside ours; `unknown_option`: an option a plugin has no keyword for, and the ones it has."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Collection, Mapping
from typing import Any, TypeVar

__all__ = ["accept_aliases", "unknown_option"]

F = TypeVar("F", bound=Callable[..., Any])


def accept_aliases(**aliases: str) -> Callable[[F], F]:
    """``@accept_aliases(initial_pos="initial_position")``: a call may name the parameter
    ``initial_position`` by its alias ``initial_pos`` (upstream's name, or an old name of
    ours: ``@accept_aliases(scheduler="address")``); giving both is a
    ``TypeError``. The signature shown (``help``, ``inspect``) stays ours."""

    def decorate(function: F) -> F:
        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            for alias, name in aliases.items():
                if alias in kwargs:
                    if name in kwargs:
                        raise TypeError(
                            f"{function.__name__}() got both {name!r} and its alias {alias!r}; "
                            "give one"
                        )
                    kwargs[name] = kwargs.pop(alias)
            return function(*args, **kwargs)

        return wrapper  # type: ignore[return-value]

    return decorate


def unknown_option(
    factory: Callable[..., Any],
    options: Mapping[str, Any],
    *,
    given: Collection[str] = (),
    skip: int = 0,
) -> str | None:
    """What is wrong with an option ``factory`` has no keyword for, and the options it has
    ("unknown option 'colour'; allowed: alpha, dt"): Python's own "__init__() got an unexpected
    keyword argument" named nothing allowed.

    Args:
        factory: The plugin's class or function.
        options: The options a config gives it.
        given: Keywords the caller passes itself, not options (left out of "allowed").
        skip: Leading parameters the caller passes by position (a fitness function's record).

    Returns:
        The message, or None where every option is a keyword of ``factory``, or it takes any
        keyword (``**kwargs``), or its signature cannot be read (a C function: its call says).
    """
    try:
        parameters = list(inspect.signature(factory).parameters.values())[skip:]
    except (TypeError, ValueError):
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    named = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    allowed = [p.name for p in parameters if p.kind in named and p.name not in given]
    unknown = sorted(set(options) - set(allowed) - set(given))
    if not unknown:
        return None
    allowed_text = f"allowed: {', '.join(allowed)}" if allowed else "it takes no options"
    return f"unknown option {unknown[0]!r}; {allowed_text}"
