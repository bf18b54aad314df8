"""How `make_executor` calls a kind's ``make``: the address keyword a kind takes (its name
before the rename included), and a plugin kind's ``make`` held to giving an executor."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from ariel.errors import ArielError, ConfigError, ExecutorStartError

__all__ = ["address_keyword", "kind_call", "made_by_plugin", "takes_address"]


def takes_address(kind: Any) -> bool:
    """``takes_address``, or ``takes_scheduler``: its name in kinds written before the rename."""
    return bool(kind.takes_address or getattr(kind, "takes_scheduler", False))


def address_keyword(make: Callable[..., object]) -> str:
    """The keyword a kind's ``make`` takes the Dask address by: ``address``, or ``scheduler``
    where a kind written before the rename names only that (its ``make`` keeps working)."""
    parameters = inspect.signature(make).parameters
    return "scheduler" if "scheduler" in parameters and "address" not in parameters else "address"


def made_by_plugin(name: str, kind: Any, **keywords: Any) -> Any:
    """``kind.make(**keywords)`` of a registered (not built-in) kind ``name``: what it raises
    or gives is its own code's, said in one line (`ExecutorStartError`) instead of a
    traceback from deep in the run."""
    try:
        made = kind.make(**keywords)
    except Exception as exc:  # its own ArielError too: said as the kind's, the folder goes
        raise ExecutorStartError(
            f"executor kind {name!r} could not make its executor: {type(exc).__name__}: "
            f"{(str(exc).splitlines() or [''])[0]}"
        ) from exc
    needed = ("submit_batch", "capacity", "__enter__", "__exit__")
    if not all(hasattr(made, attribute) for attribute in needed):
        raise ExecutorStartError(
            f"executor kind {name!r}: make() gave {type(made).__name__}, not an executor "
            "(one with submit_batch, capacity and a with block: docs/executors.md)"
        )
    return made


def kind_call(
    builtin: bool, name: str, what: str, call: Callable[[Any], None], settings: Any
) -> None:
    """``call(settings)``: kind ``name``'s ``check`` or ``reach``. A registered (not
    ``builtin``) kind's ValueError (a bad setting, as a built-in kind's check raises it) or
    `ArielError` passes as it is; any other exception of its code is one line naming the kind
    (`ConfigError`)."""
    if builtin:
        call(settings)
        return
    try:
        call(settings)
    except (ValueError, ArielError):
        raise
    except Exception as exc:
        raise ConfigError(
            f"executor.kind: executor kind {name!r}: its {what}() raised "
            f"{type(exc).__name__}: {(str(exc).splitlines() or [''])[0]}"
        ) from exc
