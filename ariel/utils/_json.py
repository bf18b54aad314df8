"""Non-finite floats in data bound for JSON, which has no NaN or infinity."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

__all__ = ["replace_non_finite"]


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
