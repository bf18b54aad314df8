"""Plain data bound for or read from JSON and TOML: non-finite floats (JSON has no NaN or
infinity), and how deep it nests."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

__all__ = ["nests_deeper_than", "replace_non_finite"]


def replace_non_finite(value: Any, replacement: Callable[[float], Any]) -> Any:
    """``value`` (nested dicts, lists and tuples) with every NaN and infinity ``x`` replaced
    by ``replacement(x)``; tuples become lists, as JSON has them."""
    if isinstance(value, float) and not math.isfinite(value):
        return replacement(value)
    if isinstance(value, dict):
        return {key: replace_non_finite(item, replacement) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [replace_non_finite(item, replacement) for item in value]
    return value


def nests_deeper_than(data: Any, limit: int) -> bool:
    """Whether ``data`` (dicts and lists) nests more than ``limit`` levels. Walked without
    recursion, so data nested 100,000 deep cannot run this out of stack (whatever walks it
    later, a `json.dumps` or a validator, would)."""
    found: list[tuple[Any, int]] = [(data, 1)] if isinstance(data, dict | list) else []
    while found:
        value, depth = found.pop()
        if depth > limit:
            return True
        children = value.values() if isinstance(value, dict) else value
        found.extend((c, depth + 1) for c in children if isinstance(c, dict | list))
    return False
