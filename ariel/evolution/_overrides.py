"""``--set`` overrides and campaign ``set`` keys on raw config data: `apply_overrides`,
`set_value` and `check_key` (dotted keys checked against the config's sections, an old name
of a key read as the new one, never both).
"""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Mapping, Sequence
from typing import Any

from pydantic import AliasChoices, BaseModel

from ariel.errors import ConfigError
from ariel.evolution._config import ExperimentConfig, plain_copy
from ariel.evolution._toml import MAX_TOML_DEPTH
from ariel.utils import nests_deeper_than, strings_argument

__all__ = ["apply_overrides", "check_key", "set_value"]


def _parse_value(text: str, key: str) -> object:
    """A TOML value (``8``, ``true``, ``"flat"``, ``[0, 0, 0]``); anything else is a string.
    `ConfigError` for a value nested deeper than a TOML file may be (`MAX_TOML_DEPTH`)."""
    try:
        value = tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:  # tomllib recurses per nested array or inline table
        value = None
    if value is None or nests_deeper_than(value, MAX_TOML_DEPTH):
        raise ConfigError(f"--set {key}: nested too deeply (at most {MAX_TOML_DEPTH} levels)")
    return value


def apply_overrides(data: Mapping[str, object], overrides: Sequence[str]) -> dict[str, Any]:
    """Apply ``key=value`` overrides (dotted keys) to raw config data; the key must exist.

    Keys under an ``options`` table are free (plugins define them). `TypeError` for overrides
    that are not a list of strings; `ConfigError` for a malformed one, and for data nested
    deeper than a TOML file may be (`MAX_TOML_DEPTH`).
    """
    overrides = strings_argument("overrides", overrides, "brain.popsize=16")
    result = plain_copy(dict(data), "config", 1)  # also refuses data nested too deeply
    assert isinstance(result, dict)  # a Mapping is copied to a dict
    spelled: dict[str, str] = {}
    for item in overrides:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"--set {item!r}: expected key=value, e.g. brain.popsize=16")
        set_value(result, key, _parse_value(text.strip(), key), f"--set {key}", spelled=spelled)
    return result


def _spellings(model: type[BaseModel], part: str) -> list[str]:
    """The keys of ``model`` that set what ``part`` sets: a field's name and the old names it
    is still read under (``address``, ``scheduler``); [] where ``part`` sets nothing."""
    for name, field in model.model_fields.items():
        alias = field.validation_alias
        names = [name, *alias.choices] if isinstance(alias, AliasChoices) else [name]
        if part in names:
            return [str(n) for n in dict.fromkeys(names)]
    return []


def check_key(key: str, label: str) -> None:
    """Raise `ConfigError` (``label: ...``) unless dotted ``key`` names a config value."""
    _table_of(key, label)


def _table_of(key: str, label: str) -> type[BaseModel] | None:
    """The section (model) the last part of the checked dotted ``key`` is a key of; None
    inside a free ``options`` table."""
    parts = key.split(".")
    model: type[BaseModel] | None = ExperimentConfig
    for depth, part in enumerate(parts):
        if model is None:  # inside a free `options` table
            break
        spellings = _spellings(model, part)
        if not spellings:
            names = sorted(model.model_fields)
            where = ".".join(parts[:depth]) or "the top level"
            hint = _did_you_mean(parts, depth, names)
            raise ConfigError(f"{label}: no such key; keys under {where}: {', '.join(names)}{hint}")
        if depth < len(parts) - 1:
            annotation = model.model_fields[spellings[0]].annotation
            if isinstance(annotation, type) and issubclass(annotation, BaseModel):
                model = annotation
            elif part == "options":
                model = None
            else:
                raise ConfigError(f"{label}: '{part}' is a value, not a table")
    return model


def _did_you_mean(parts: list[str], depth: int, names: list[str]) -> str:
    """``; did you mean 'KEY'?`` for the closest name to ``parts[depth]``, or ``""``.

    The whole key is suggested when the rest of it exists under that name (``bodyy.population``
    -> ``body.population``), else the key up to that name.
    """
    close = difflib.get_close_matches(parts[depth], names, n=1)
    if not close:
        return ""
    whole = ".".join([*parts[:depth], close[0], *parts[depth + 1 :]])
    try:
        check_key(whole, "")
    except ConfigError:
        whole = ".".join([*parts[:depth], close[0]])
    return f"; did you mean '{whole}'?"


def set_value(
    data: dict[str, Any],
    key: str,
    value: object,
    label: str,
    *,
    spelled: dict[str, str] | None = None,
) -> None:
    """Set dotted ``key`` of raw config ``data`` (in place) to ``value``; errors name ``label``.
    ``spelled``: the keys set so far, by the spelling they were set under (updated): a key set
    again under its other name (``executor.scheduler``, then ``executor.address``: the last one
    won, silently) is refused."""
    table = _table_of(key, label)
    parts = key.split(".")
    names = _spellings(table, parts[-1]) if table is not None else []
    if spelled is not None:
        earlier = spelled.setdefault(".".join([*parts[:-1], names[0]]) if names else key, key)
        if earlier != key:
            raise ConfigError(f"{label}: sets {earlier} too ({' and '.join(names)} are one key)")
    node = data
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f"{label}: '{part}' is a value, not a table")
    for spelling in names:
        node.pop(spelling, None)  # the value under another name (an old one) is replaced too
    node[parts[-1]] = value
