"""`accept_aliases`: let a function take upstream ARIEL's keyword names, or our own old ones,
beside ours."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["accept_aliases"]

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
