"""A quality-diversity run's archive as readers see it: its description (`describe_archive`).

A run records its archive's description in run.json (``archive``, written by the driver from
the optimizer's ``archive_description()``): ``kind`` (``"grid"`` or ``"cvt"``), ``measures``,
``ranges``, and a grid's ``bins`` or a CVT's ``cells`` and ``centroids`` (one list of measure
values per cell, in cell order, in the measures' units). A run made before it was recorded had
a grid, described here from its config and its ``archive`` table, as readers drew it then.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ariel.evolution import DEFAULT_MEASURES, DEFAULT_RANGES

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.store._run_folder import JsonObject

__all__ = ["ARCHIVE_KINDS", "archive_cell_count", "describe_archive"]

#: The kinds of archive a description names.
ARCHIVE_KINDS = ("grid", "cvt")


def describe_archive(info: Mapping[str, object], archive: pd.DataFrame | None) -> JsonObject | None:
    """The archive's description (see the module docstring).

    Args:
        info: The run's run.json (its ``archive`` and ``config``).
        archive: The run's ``archive`` table (`Run.archive`), or None.

    Returns:
        run.json's ``archive``; for a run made before it was recorded, a grid: the config's
        ``measures`` and ``ranges`` (``map_elites``' defaults where not given) and the
        table's ``grid`` column as ``bins``; None for a run without an archive.
    """
    recorded = info.get("archive")
    if isinstance(recorded, Mapping) and recorded.get("kind") in ARCHIVE_KINDS:
        return dict(recorded)
    if archive is None or not len(archive):
        return None
    config = info.get("config")
    config = config if isinstance(config, Mapping) else {}
    options = config.get("body", {}).get("optimizer_options") or {}
    measures = [str(m) for m in options.get("measures") or DEFAULT_MEASURES]
    ranges = options.get("ranges") or [DEFAULT_RANGES.get(m, (0.0, 1.0)) for m in measures]
    return {
        "kind": "grid",
        "measures": measures,
        "ranges": [[float(low), float(high)] for low, high in ranges],
        "bins": [int(n) for n in archive["grid"].iloc[0]],
    }


def archive_cell_count(description: Mapping[str, Any]) -> int:
    """The cells of a described archive: a grid's product of ``bins``, a CVT's centroids."""
    if description.get("kind") == "cvt":
        return len(description["centroids"])
    return math.prod(int(n) for n in description["bins"])
