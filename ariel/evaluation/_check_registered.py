"""Everything registered, checked: one ``(kind, name, error or None)`` row per name.

`check_rows` makes the rows for any registries and their checkers; `check_engine_plugins` uses
it for the kinds the engine checks (`ariel.evaluation._checks`), and ``check_all`` of
`ariel.evolution` (``ariel plugins --check``) for those and the body and brain optimizers.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from ariel.errors import PluginCheckError
from ariel.evaluation._checks import (
    check_body_encoder,
    check_controller,
    check_fitness,
    check_world,
)
from ariel.evaluation._engine import _one_line
from ariel.plugins import REGISTRIES

__all__ = ["check_engine_plugins", "check_rows"]

_CHECKERS: dict[str, Callable[[str], None]] = {
    "body_encoder": check_body_encoder,
    "world": check_world,
    "controller": check_controller,
    "fitness": check_fitness,
}


def check_rows(
    kinds: Iterable[tuple[str, Any, Callable[[str], None]]],
) -> list[tuple[str, str, str | None]]:
    """``(kind, name, error or None)`` per registered name of each ``(kind, registry,
    checker)``, names sorted; a broken plugin (one that fails its check, an entry point that
    fails to load or clashes with another provider) is its row's one-line error, never raised."""
    report: list[tuple[str, str, str | None]] = []
    for kind, registry, checker in kinds:
        for name in registry.names():
            error: str | None = None
            try:
                checker(name)
            except PluginCheckError as exc:
                error = str(exc)
            except Exception as exc:  # not expected (checkers wrap what they call): still a row
                error = f"{registry.label} {name!r}: {_one_line(exc)}"
            report.append((kind, name, error))
    return report


def check_engine_plugins() -> list[tuple[str, str, str | None]]:
    """Check every registered body encoder, world, controller and fitness function, entry
    points included, with default options (`ariel.plugins.check_all` checks the body and brain
    optimizers too). Nothing is raised for a broken plugin: an entry point that fails to load,
    or clashes with another provider, is reported as its row's error.

    Returns:
        One ``(kind, name, error or None)`` row per name, kinds in `REGISTRIES` order and
        names sorted; ``error`` is the one-line failure message, None for a plugin that passed.
    """
    return check_rows(
        (kind, registry, _CHECKERS[kind])
        for kind, registry in REGISTRIES.items()
        if kind in _CHECKERS  # body and brain optimizers: checked a layer up
    )
