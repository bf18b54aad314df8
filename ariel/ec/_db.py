"""The SQLite side of the EA engine: engines, sessions and copies of stored individuals."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import Engine, create_engine
from sqlalchemy.exc import StatementError
from sqlmodel import Session, select

from ariel.ec.individual import Individual, to_json

__all__ = ["database_error", "fresh_copy", "open_engine", "readable_engine", "session"]


def _json_default(value: Any) -> Any:
    # Genotypes and tags are usually plain lists already; numpy values left inside them
    # (np.int64, arrays in a tag) would otherwise fail the commit of a whole generation.
    if isinstance(value, np.ndarray | np.generic):
        return to_json(value)
    raise TypeError(f"{type(value).__name__} is not JSON data: store lists, numbers, strings")


def _dumps(value: Any) -> str:
    return json.dumps(value, default=_json_default)


def open_engine(path: Path) -> Engine:
    """An engine on the SQLite file ``path`` that can store numpy values in JSON columns."""
    return create_engine(f"sqlite:///{path}", json_serializer=_dumps)


def database_error(what: str, error: StatementError) -> ValueError:
    """One line for an SQLAlchemy error (a statement, its parameters, a web link and the driver's
    error otherwise): ``what`` failed, and the driver's reason."""
    reason = error.orig if error.orig is not None else error
    first = str(reason).splitlines()[0] if str(reason) else type(reason).__name__
    return ValueError(f"{what}: {first}")


def readable_engine(path: Path, role: str) -> Engine:
    """An engine on ``path`` once a query of its individuals works; ``ValueError`` in one line
    where the file is not an EA database (a text file, an empty file, another program's)."""
    engine = open_engine(path)
    try:
        with session(engine) as s:
            # one row of every column: no file of SQLite, no table, another program's table
            s.exec(select(Individual).limit(1)).all()
    except StatementError as error:
        engine.dispose()
        raise database_error(f"{role} {path} is not an EA database ariel can read", error) from None
    return engine


def session(engine: Engine) -> Session:
    """A session whose objects stay readable after commit and close (no lazy reloads)."""
    return Session(engine, expire_on_commit=False)


def fresh_copy(individual: Individual, **changes: Any) -> Individual:
    """A new, unsaved `Individual` with the same values (no id), for inserting elsewhere."""
    values = copy.deepcopy(individual.model_dump(exclude={"id"}))
    values["tags_"] = values.get("tags_") or {}
    values.update(changes)
    return Individual(**values)
