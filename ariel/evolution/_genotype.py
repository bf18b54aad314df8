"""A fixed body's genotype: ``body.genotype`` as a value or as a file (``.json`` / ``.npy``).

A run stores the genotype itself in run.json's resolved config, never the file's path: the
run folder then holds no path of this machine, and ``ariel resume`` / ``ariel replay`` of a
copied folder need nothing outside it. A changed file is therefore a changed config (another
config hash), as it should be.

Array genotypes are checked against the encoder's ``genotype_shape`` (when it declares one,
as ``nde`` does: ``(3, genotype_size)``) and must be finite.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, TypeGuard

import numpy as np

from ariel.errors import ConfigError

if TYPE_CHECKING:
    from ariel.plugins import BodyEncoder

__all__ = [
    "GENOTYPE_FILE_SUFFIXES",
    "check_genotype",
    "describe",
    "is_genotype_file",
    "read_genotype_file",
]

GENOTYPE_FILE_SUFFIXES = (".json", ".npy")


def is_genotype_file(value: object) -> TypeGuard[str]:
    """Whether ``body.genotype`` names a file (a string ending in .json or .npy)."""
    return isinstance(value, str) and value.lower().endswith(GENOTYPE_FILE_SUFFIXES)


def read_genotype_file(path: str | Path) -> object:
    """The genotype in ``path`` as plain data (lists, numbers, strings); `ConfigError` else. A
    leading ``~`` is the home folder."""
    path = Path(path).expanduser()
    where = f"body.genotype: file {str(path)!r}"
    if not path.is_file():
        raise ConfigError(f"{where} not found")
    if path.suffix.lower() == ".npy":
        try:
            array = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as exc:
            first = (str(exc).splitlines() or [""])[0]
            raise ConfigError(f"{where}: not a numeric .npy array ({first})") from None
        if not np.issubdtype(array.dtype, np.number):
            raise ConfigError(f"{where}: holds {array.dtype} values, not numbers")
        return array.tolist()
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise ConfigError(f"{where}: not a UTF-8 text file") from None
    except OSError as exc:
        raise ConfigError(f"{where}: unreadable ({exc.strerror})") from None
    except ValueError as exc:
        raise ConfigError(f"{where}: not valid JSON ({exc})") from None
    except RecursionError:  # json recurses per nested array or object
        raise ConfigError(f"{where}: not a genotype (its JSON nests too deeply)") from None


def check_genotype(genotype: object, encoder: BodyEncoder, where: str = "body.genotype") -> None:
    """Raise `ConfigError` unless ``genotype`` fits ``encoder``'s ``genotype_shape``.

    Encoders without a ``genotype_shape`` check their genotypes when building the body.
    """
    shape = getattr(encoder, "genotype_shape", None)
    if shape is None:
        return
    expected = tuple(int(n) for n in shape)
    name = getattr(encoder, "name", "?")
    try:
        array = np.asarray(genotype, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{where}: not an array of numbers; a {name!r} genotype has shape {expected}"
        ) from None
    if array.shape != expected:
        raise ConfigError(
            f"{where}: shape {array.shape}, expected {expected} for body encoder {name!r} "
            "with these body.options"
        )
    bad = int(np.count_nonzero(~np.isfinite(array)))
    if bad:
        raise ConfigError(f"{where}: {bad} of {array.size} values are not finite (NaN or infinite)")


def describe(genotype: object) -> str:
    """A short description of a genotype for an error line (never hundreds of numbers)."""
    if isinstance(genotype, str | int) or (isinstance(genotype, float) and math.isfinite(genotype)):
        return repr(genotype)
    try:
        return f"the fixed genotype of shape {np.asarray(genotype, dtype=object).shape}"
    except (TypeError, ValueError):
        return "the fixed genotype"
