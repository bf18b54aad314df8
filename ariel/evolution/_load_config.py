"""`load_config`: an experiment's config from a TOML file, a dict or a config object, with
``--set`` overrides applied and validated (`ariel.evolution._config`). A file is checked before
it is read (a FIFO or a folder is one line), a campaign file given here names its command, and
a relative genotype file is relative to the TOML file naming it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from os import PathLike
from pathlib import Path

from ariel.errors import ConfigError
from ariel.evolution._config import ExperimentConfig, _validate
from ariel.evolution._genotype import is_genotype_file
from ariel.evolution._overrides import apply_overrides
from ariel.evolution._toml import read_toml_file
from ariel.utils import ariel_line, file_kind, path_argument

__all__ = ["default_config_path", "load_config"]


def load_config(
    source: str | Path | Mapping[str, object] | ExperimentConfig | None = None,
    overrides: Sequence[str] = (),
) -> ExperimentConfig:
    """A validated config from a TOML file, a dict or a config (None: the default experiment).

    Args:
        source: A TOML file's path; raw config data (a mapping, as a TOML file reads); an
            `ExperimentConfig` (validated again, with ``overrides`` applied); or None, the
            default experiment (``experiments/coevolve_flat.toml`` of this checkout, or the
            built-in defaults with name ``coevolve_flat`` where that file is not installed).
            A relative ``body.genotype`` file named in a TOML file is relative to that file.
        overrides: ``key=value`` strings with dotted keys, as ``--set`` takes them (values
            read as TOML, e.g. ``"brain.popsize=16"``), applied in order.

    Returns:
        The validated, frozen config.

    Raises:
        ConfigError: For a file that is missing or not a regular file, an unknown key, a value
            of the wrong type or out of range, or a malformed override; one line naming the
            dotted key.

    Example:
        ```python
        from ariel.evolution import load_config

        config = load_config(overrides=["generations=3", "brain.popsize=16"])
        print(config.generations, config.brain.popsize)  # 3 16
        ```
    """
    if not isinstance(source, ExperimentConfig | Mapping | str | PathLike | None):
        raise TypeError(
            "config must be an ExperimentConfig, a TOML file's path, a dict or None (the "
            f"default experiment), not {type(source).__name__}"
        )
    if isinstance(source, ExperimentConfig):
        data: Mapping[str, object] = source.to_plain()
    elif isinstance(source, Mapping):
        data = source
    else:
        path = path_argument("config", source) if source is not None else default_config_path()
        if source is None and not path.is_file():  # an installed package without experiments/
            return _validate(apply_overrides({"name": "coevolve_flat"}, overrides))
        if not path.is_file():  # never opened: reading a FIFO would wait forever
            raise ConfigError(f"config file {str(path)!r} {not_a_file(path)}")
        data = read_toml_file(path)
        _refuse_campaign_file(data, path)
        data = _genotype_file_beside(data, path)
    return _validate(apply_overrides(data, overrides))


#: Top-level keys of a campaign file (`ariel.runs`) that no experiment has.
_CAMPAIGN_KEYS = ("base", "condition", "grid", "seeds")


def _refuse_campaign_file(data: Mapping[str, object], path: Path) -> None:
    """`ConfigError` saying which command takes ``path`` when it is a campaign file (an easy
    mix-up: both are TOML files under experiments/), rather than "unknown key 'base'"."""
    found = [key for key in _CAMPAIGN_KEYS if key in data]
    if "base" in data or len(found) >= 2:
        raise ConfigError(
            f"{str(path)!r} is a campaign file (it has {', '.join(found)}), not an experiment: "
            f"run it with {ariel_line('campaign', 'run', path)} (from Python: run_campaign)"
        )


def not_a_file(path: Path) -> str:
    """What ``path`` is instead of a TOML file, e.g. ``is a folder``."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return "not found"
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    return f"is {file_kind(mode)}, not a TOML file"


def _genotype_file_beside(data: dict[str, object], config_path: Path) -> dict[str, object]:
    """A relative ``body.genotype`` file named in a TOML file is relative to that file (a
    leading ``~`` is the home folder, as on the command line)."""
    body = data.get("body")
    if not isinstance(body, dict):
        return data
    genotype = body.get("genotype")
    if not is_genotype_file(genotype):
        return data
    home = Path(genotype).expanduser()
    if home.is_absolute():
        return data if str(home) == genotype else {**data, "body": {**body, "genotype": str(home)}}
    beside = str(config_path.parent / genotype)
    return {**data, "body": {**body, "genotype": beside}}


def default_config_path() -> Path:
    """``experiments/coevolve_flat.toml`` of this checkout (the default experiment)."""
    return Path(__file__).resolve().parents[2] / "experiments" / "coevolve_flat.toml"
