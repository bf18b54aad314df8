"""``ariel config show``: the resolved experiment (every key, defaults included) as TOML.

The output is a valid experiment file: ``ariel config show > mine.toml`` then ``ariel run
mine.toml`` runs the same experiment. Given a run folder, it shows the config the run was
started with (run.json's), so a run that cannot be resumed can be started again. TOML has no
null, so a key that is not set (``none`` in docs/evolution.md) is a comment. A key that the
configured executor does not use (``executor.device`` unless ``executor.kind`` is ``gpu``) is a
comment too when it holds its default, and otherwise stays, with a comment saying that it is
not used.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shlex
import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING

from ariel import evolution
from ariel.cli._options import add_set_option
from ariel.errors import ConfigError
from ariel.recording.store import RunFolder
from ariel.utils import ariel_line

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers
    from ariel.evolution import ExperimentConfig

__all__ = ["add_config_commands", "to_toml"]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _key(name: str) -> str:
    return name if _BARE_KEY.fullmatch(name) else json.dumps(name)


def _value(value: object) -> str:
    """One TOML value: strings, numbers, booleans, arrays and inline tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a TOML basic string
    if isinstance(value, Mapping):
        items = [f"{_key(str(k))} = {_value(v)}" for k, v in value.items() if v is not None]
        return "{ " + ", ".join(items) + " }" if items else "{}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {type(value).__name__}: {value!r}")


def to_toml(
    config: Mapping[str, object], unused: Mapping[str, tuple[str, bool]] | None = None
) -> str:
    """``config`` as TOML: plain keys first, then one ``[table]`` per nested mapping whose values
    are inline (options tables as inline tables). ``None`` values become comments.

    ``unused`` maps a dotted key (``"executor.device"``) to ``(why, as_comment)``: the key is
    written as a comment (``# key = value  (why)``) when ``as_comment``, else as a key with
    ``# why`` after it."""
    lines: list[str] = []
    tables: list[tuple[str, Mapping[str, object]]] = []
    unused = unused or {}

    def write(entries: Mapping[str, object], prefix: str = "") -> None:
        for name, value in entries.items():
            if value is None:
                lines.append(f"# {_key(str(name))}: not set")
                continue
            line = f"{_key(str(name))} = {_value(value)}"
            why, as_comment = unused.get(prefix + str(name), ("", False))
            if not why:
                lines.append(line)
            elif as_comment:
                lines.append(f"# {line}  ({why})")
            else:
                lines.append(f"{line}  # {why}")

    top = {k: v for k, v in config.items() if not isinstance(v, Mapping)}
    tables = [(k, v) for k, v in config.items() if isinstance(v, Mapping)]
    write(top)
    for name, table in tables:
        lines += ["", f"[{_key(str(name))}]"]
        write(table, f"{name}.")
    return "\n".join(lines) + "\n"


def _unused_keys(config: ExperimentConfig) -> dict[str, tuple[str, bool]]:
    """The keys ``config``'s executor does not use: ``executor.device`` unless the kind is
    ``gpu``; a comment at its default, else kept (it reads back the same) with a note."""
    executor = config.executor
    if executor.kind == "gpu":
        return {}
    default = type(executor).model_fields["device"].default
    why = f'not used: only the gpu executor has a device, and executor.kind is "{executor.kind}"'
    return {"executor.device": (why, executor.device == default)}


def _run_config(folder: str, overrides: list[str]) -> tuple[ExperimentConfig, str]:
    """The config run.json of the run folder ``folder`` holds (every key, as the run began),
    with ``overrides``, and a warning ("" for none) where it is not the config the run began
    with (its ``config_hash`` differs: edited since, as ``ariel verify`` says); a folder that
    is no run, or whose config is no table or holds a bad value, is one line."""
    info = RunFolder(folder).read_info()
    plain = info.get("config")
    if not isinstance(plain, dict):
        raise ConfigError(f"{str(folder)!r}: run.json holds no config table")
    try:
        began = evolution.config_hash(evolution.ExperimentConfig.from_plain(plain))
        config = evolution.load_config(plain, overrides)
    except ConfigError as exc:
        raise ConfigError(f"{os.path.join(folder, 'run.json')}: {exc}") from None
    if began == info.get("config_hash"):
        return config, ""
    return config, (
        "warning: run.json's config does not match its config_hash: edited after the run began "
        f"({ariel_line('verify', folder)} says so), or written by an older ariel whose configs "
        "had other keys; this may not be what the run ran"
    )


def _cmd_config_show(args: argparse.Namespace) -> int:
    # a bad file, key or value: ConfigError, one line
    warning = ""
    if args.file is not None and os.path.isdir(args.file):  # a run folder
        config, warning = _run_config(args.file, args.set)
        source = f"the config of run {args.file}"
    else:
        config = evolution.load_config(args.file, args.set)
        source = args.file or "the default experiment (experiments/coevolve_flat.toml)"
    if warning:
        print(warning, file=sys.stderr)
        print(f"# {warning}")
    overrides = "".join(f" --set {shlex.quote(item)}" for item in args.set)
    print(f"# {source}{overrides}, resolved: every key, defaults included")
    print("# the keys: docs/evolution.md, 'Configuration keys'")
    print(to_toml(config.to_plain(), _unused_keys(config)), end="")
    return 0


def add_config_commands(sub: SubParsers) -> None:
    """Add ``config show`` to the sub-parsers."""
    config = sub.add_parser(
        "config", help="the resolved experiment: ariel config show [FILE | RUN_FOLDER]"
    )
    actions = config.add_subparsers(dest="action", metavar="ACTION", required=True)
    p = actions.add_parser(
        "show",
        help="print the resolved experiment as TOML (every key, defaults included)",
        description="Print the experiment that `ariel run [FILE] [--set ...]` would run, every "
        "key with its value (defaults included), as TOML that `ariel run` reads back. The keys "
        "are documented in docs/evolution.md, 'Configuration keys'. Given a run folder, the "
        "config that run was started with (to start a new run of it).",
    )
    p.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help="experiment TOML file, or a run folder (default: the default experiment)",
    )
    add_set_option(p, "override a config value, as with ariel run (repeatable)")
    p.set_defaults(func=_cmd_config_show)
