"""Checks of a Python call's arguments that a type checker would catch, for the scripts and
notebooks that have none: a wrong type is one line naming the function, the argument and what
it takes (`TypeError`), rather than an error from deep inside, or a truthy ``"no"`` read as
True (``overwrite="no"`` must not replace a run)."""

from __future__ import annotations

import numbers
import os
from collections.abc import Iterable
from pathlib import Path

__all__ = [
    "count_argument",
    "flag_argument",
    "number_argument",
    "path_argument",
    "paths_argument",
    "strings_argument",
    "whole_numbers",
]


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{type(value).__name__} {text[:37]}..."


def _refused(function: str, name: str, what: str, value: object) -> TypeError:
    where = f"{function}: {name}" if function else name
    return TypeError(f"{where} must be {what}, not {_shown(value)}")


def path_argument(name: str, value: object, *, function: str = "") -> Path:
    """``value`` as a `Path`: a `str` or an `os.PathLike` (a `pathlib.Path`); a leading ``~``
    is the home folder, as in a shell (a notebook's ``out="~/runs/x"`` made a folder named
    ``~`` in the current one)."""
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        path = Path(value)  # an os.PathLike of bytes: Path says so itself
        try:
            return path.expanduser()
        except RuntimeError:  # ~user of no such user: left as it is, as a shell leaves it
            return path
    raise _refused(function, name, "a path (a str or pathlib.Path)", value)


def paths_argument(name: str, value: object, *, function: str = "") -> list[Path]:
    """``value`` as a list of `Path`: a list or tuple of paths, never one path (a `str`
    iterated would be read a character at a time)."""
    if isinstance(value, str | bytes | os.PathLike) or not isinstance(value, Iterable):
        raise _refused(function, name, "a list of paths such as ['data/runs/RUN']", value)
    items = list(value)
    return [path_argument(f"{name}[{i}]", item, function=function) for i, item in enumerate(items)]


def flag_argument(
    name: str, value: object, *, none: bool = False, function: str = ""
) -> bool | None:
    """``value`` when it is True or False (a NumPy bool, ``(a > 0).any()``, as one; or None,
    where ``none`` allows it)."""
    if isinstance(value, bool) or (none and value is None):
        return value
    if type(value).__module__ == "numpy" and type(value).__name__ in ("bool", "bool_"):
        return bool(value)
    raise _refused(function, name, "True, False or None" if none else "True or False", value)


def strings_argument(
    name: str, value: object, example: str, *, function: str = ""
) -> tuple[str, ...]:
    """``value`` as a tuple of strings: a list or tuple of `str`, never one `str` (iterated,
    it would be read a character at a time)."""
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise _refused(function, name, f"a list of strings such as [{example!r}]", value)
    items = tuple(value)
    for item in items:
        if not isinstance(item, str):
            raise _refused(
                function, f"{name}[{items.index(item)}]", f"a string such as {example!r}", item
            )
    return items


def _is_int(value: object) -> bool:
    """An int or a NumPy integer; not a bool (an int to Python), a float or a str."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def count_argument(name: str, value: object, *, maximum: int, function: str = "") -> int:
    """``value`` as a whole number from 0 to ``maximum``: an int (a NumPy integer too, never a
    bool or a str), `TypeError` otherwise; `ValueError` outside that range (a count that
    would take all memory before saying anything)."""
    if not _is_int(value):
        raise _refused(function, name, f"an int from 0 to {maximum}", value)
    count = int(value)
    if not 0 <= count <= maximum:
        where = f"{function}: {name}" if function else name
        raise ValueError(f"{where} must be from 0 to {maximum}, not {count}")
    return count


def whole_numbers(**options: object) -> None:
    """Refuse any of ``options`` (name=value) that is not an int (a NumPy integer too): a bool,
    a float or a str is never truncated, as run.json records an option as it was given;
    `TypeError` naming the option."""
    for name, value in options.items():
        if not _is_int(value):
            raise TypeError(f"{name} must be a whole number (an int), not {_shown(value)}")


def number_argument(
    name: str, value: object, *, what: str = "a number (int, float or a one-element tensor)"
) -> float:
    """``value`` as a float: an int, float, numpy scalar or one-element array or tensor; a
    bool or a string (which ``float`` would read) is refused, `TypeError` naming ``name`` and
    ``what`` it must be."""
    dtype = str(getattr(value, "dtype", ""))
    if not (isinstance(value, bool | str | bytes) or dtype in ("bool", "torch.bool")):
        try:
            return float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError, RuntimeError):
            pass
    shown = f"{type(value).__name__} {value!r}".splitlines()[0]
    raise TypeError(f"{name} must be {what}, not {shown}")
