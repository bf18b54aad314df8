"""Reading an experiment or campaign TOML file: every way it can be bad is one `ConfigError`
line naming the file."""

from __future__ import annotations

import tomllib
from pathlib import Path

from ariel.errors import ConfigError
from ariel.utils import nests_deeper_than

__all__ = ["MAX_TOML_DEPTH", "read_toml_file"]

#: How deep a TOML file may nest (tables, arrays): a config nests a few levels; run.json and
#: campaign.json, which hold it a few levels down, are read to 100 levels.
MAX_TOML_DEPTH = 90


def read_toml_file(path: Path) -> dict[str, object]:
    """The data of the TOML file ``path`` (an existing file): `ConfigError` for malformed
    TOML, text that is not UTF-8, and nesting deeper than `MAX_TOML_DEPTH`."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: malformed TOML: {exc}") from None
    except RecursionError:  # tomllib recurses per nested array or inline table
        raise ConfigError(f"{path}: malformed TOML: nested too deeply") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file") from None
    if nests_deeper_than(data, MAX_TOML_DEPTH):  # dotted keys (a.a.a...) nest without recursing
        raise ConfigError(
            f"{path}: malformed TOML: nested too deeply (more than {MAX_TOML_DEPTH} levels)"
        )
    return data
