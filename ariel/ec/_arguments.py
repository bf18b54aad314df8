"""Checks of the EA engine's arguments (operators, generators, populations, the archive):
one line naming the argument and what it takes, where NumPy would have taken a NaN, cut 1.5 to
1, or said something naming no argument."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

__all__ = ["bounds", "finite", "integer_genes", "probability", "whole"]


def probability(name: str, value: object) -> None:
    """``value`` is a probability: a real number in [0, 1]; `TypeError` or `ValueError` naming
    ``name`` otherwise."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a number in [0, 1], not {value!r}")
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"{name} must be in [0, 1], not {value!r}")


def whole(name: str, value: object, minimum: int = 0) -> int:
    """``value`` as an int when it is a whole number >= ``minimum`` (a NumPy integer too, never
    a bool): SQL reads ``LIMIT -1`` as "no limit", SQLite matched no ``np.int64(0)``."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < minimum:
        raise ValueError(f"{name} must be a whole number >= {minimum}, not {value!r}")
    return int(value)


def finite(name: str, value: object, *, at_least: float | None = None) -> float:
    """``value`` as a float when it is a finite real number (``>= at_least`` where given): a NaN
    or infinite step size or bound otherwise turns every gene it touches into NaN or inf,
    silently, and the EA stores those genotypes."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a real number, not {value!r}")
    number = float(value)
    if not math.isfinite(number) or (at_least is not None and number < at_least):
        allowed = "a finite number" + (f" >= {at_least:g}" if at_least is not None else "")
        raise ValueError(f"{name} must be {allowed}, not {value!r}")
    return number


def bounds(low: float, high: float, *, strict: bool = False, whole: bool = False) -> None:
    """``low`` and ``high`` finite (``whole``: whole numbers, NumPy truncated 1.5 to 1), in
    order, and ``high - low`` finite too (-1e308 to 1e308 made NaN genes)."""
    for name, bound in (("low", low), ("high", high)):
        finite(name, bound)
        if whole and float(bound) != round(float(bound)):
            raise ValueError(f"{name} must be a whole number, not {bound!r}")
    if not (low < high if strict else low <= high):
        sign = "<" if strict else "<="
        raise ValueError(f"low must be {sign} high, got low={low!r} and high={high!r}")
    if not math.isfinite(float(high) - float(low)):
        raise ValueError(f"high - low must be finite, got low={low!r} and high={high!r}")


def integer_genes(values: Any, name: str = "individual") -> np.ndarray:
    """``values`` as an int64 array; a gene that is not a whole number (1.7) is refused, where
    casting would have cut it to 1 whether or not the gene was chosen to mutate."""
    genes = np.asarray(values)
    if genes.dtype.kind == "f" and not np.all(np.isfinite(genes) & (genes == np.round(genes))):
        raise ValueError(f"{name} must hold whole numbers (an integer genotype), not {values!r}")
    if genes.dtype.kind not in "biuf":
        raise ValueError(f"{name} must hold whole numbers, not {genes.dtype} values")
    return genes.astype(np.int64)
