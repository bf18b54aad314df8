"""Rerun chunks as every recording of this package builds them: the ``rerun`` module (loaded
on first use), static chunks of archetypes, component columns of one row, and a recording's
name and ``ariel`` properties (``/__properties``).
"""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rerun import AsComponents, ComponentColumn
    from rerun.chunk import Chunk

__all__ = ["APPLICATION_ID", "rerun_module", "rgb", "static_chunk"]

APPLICATION_ID = "ariel"
#: Guards the caches of what recordings share (a model's scene, a graph's chunk): recordings
#: are written from threads.
_CACHE_LOCK = threading.Lock()


def rgb(colour: str) -> tuple[int, int, int]:
    """``"#rrggbb"`` (`ariel.recording.store.condition_colours`) as Rerun's 0-255 channels."""
    red, green, blue = (int(colour[k : k + 2], 16) for k in (1, 3, 5))
    return red, green, blue


def rerun_module() -> ModuleType:
    import rerun  # lazy: heavy optional library

    return rerun


def _property_value(value: object) -> list[bool | int | float | str] | None:
    """A value `AnyValues` holds: a number, bool or string; lists of them; else JSON text."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        return None
    if isinstance(value, bool | int | float | str):
        return [value]
    if isinstance(value, Sequence) and value and all(isinstance(v, str) for v in value):
        return list(value)
    if (
        isinstance(value, Sequence)
        and value
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        return [float(v) for v in value]
    return [json.dumps(value, default=str)]


def _property_chunks(properties: Mapping[str, object], name: str) -> list[Chunk]:
    """The recording's name and the ``ariel`` recording property (``/__properties``)."""
    rr = rerun_module()

    chunks = [
        rr.chunk.Chunk.from_columns(
            "/__properties", [], rr.archetypes.RecordingInfo.columns(name=[name])
        )
    ]
    values = {str(k): _property_value(v) for k, v in properties.items()}
    values = {k: v for k, v in values.items() if v is not None}
    if values:
        chunks.append(rr.chunk.Chunk.from_property("ariel", rr.AnyValues(**values)))
    return chunks


def _one_row(*archetypes: AsComponents) -> list[ComponentColumn]:
    """Component columns of one row holding every batch of ``archetypes``."""
    return [
        batch.partition([len(batch.as_arrow_array())])
        for archetype in archetypes
        for batch in archetype.as_component_batches()
    ]


def static_chunk(path: str, *archetypes: AsComponents) -> Chunk:
    """One static chunk at ``path`` holding ``archetypes``."""
    rr = rerun_module()

    return rr.chunk.Chunk.from_columns(path, [], _one_row(*archetypes))
