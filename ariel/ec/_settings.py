"""`EASettings` and the module-level `config` the EA engine falls back on."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, computed_field
from pydantic_settings import BaseSettings, SettingsConfigDict

__all__ = ["DBHandlingMode", "EASettings", "config"]

#: What `EA` does when its database file already exists: delete it, or stop with an error.
DBHandlingMode = Literal["delete", "halt"]


def _one_line(error: ValidationError) -> ValueError:
    """pydantic's several lines (a count, the field, the reason, a web link) as one: the
    setting, its variable, what it must be and what it got."""
    first = error.errors()[0]
    name = ".".join(str(part) for part in first["loc"]) or "settings"
    return ValueError(
        f"ariel.ec config {name} (ARIEL_EC_{name.upper()}): {first['msg']}; "
        f"got {first.get('input')!r}"
    )


class EASettings(BaseSettings):
    """Defaults of the EA engine; each can be overridden by an ``ARIEL_EC_<NAME>`` variable.

    ``output_folder`` defaults to ``./__data__`` of the working directory when the settings are
    made; nothing is created until an `EA` opens its database.

    Args:
        values: Settings by name (the attributes below), before the ``ARIEL_EC_*`` variables;
            a bad one is a one-line `ValueError` naming it and its variable.

    Attributes:
        quiet: silence the EA's console output and progress bar (``ARIEL_EC_QUIET``).
        is_maximisation: ``True`` if a higher fitness is better; decides which individual
            `EA.get_solution` calls best.
        first_generation_id: the generation number of the initial population; each step adds 1.
        num_steps: generations `EA.run` performs (>= 0).
        target_population_size: the population size the EA records as
            ``EA.target_population_size`` for operations to read (>= 0); the engine itself
            enforces no size.
        output_folder: the folder of the database file; created when an `EA` opens it.
        db_file_name: the database file's name inside ``output_folder``.
        db_handling: what `EA` does when the database file already exists: ``"delete"`` it and
            start afresh, or ``"halt"`` with ``FileExistsError``.
    """

    # A prefix, because upstream's bare names (QUIET, NUM_STEPS, ...) collide with unrelated
    # environment variables.
    model_config = SettingsConfigDict(env_prefix="ARIEL_EC_", validate_assignment=True)

    quiet: bool = False
    is_maximisation: bool = True
    first_generation_id: int = 0
    num_steps: int = Field(default=100, ge=0)
    target_population_size: int = Field(default=100, ge=0)
    output_folder: Path = Field(default_factory=lambda: Path.cwd() / "__data__")
    db_file_name: str = "database.db"
    db_handling: DBHandlingMode = "delete"

    def __init__(self, **values: Any) -> None:
        try:
            super().__init__(**values)
        except ValidationError as error:  # an ARIEL_EC_* variable, read as the package loads
            raise _one_line(error) from None

    def __setattr__(self, name: str, value: Any) -> None:
        try:
            super().__setattr__(name, value)
        except ValidationError as error:
            raise _one_line(error) from None

    @computed_field  # type: ignore[prop-decorator]
    @property
    def db_file_path(self) -> Path:
        """``output_folder / db_file_name``."""
        return self.output_folder / self.db_file_name


#: The settings `EA` reads when an argument is not given (upstream's module-level ``config``).
config: EASettings = EASettings()
