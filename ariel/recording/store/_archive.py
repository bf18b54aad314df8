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
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ariel.evolution import DEFAULT_MEASURES, DEFAULT_RANGES
from ariel.recording.store._files import damaged

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.store._run_folder import JsonObject

__all__ = ["ARCHIVE_KINDS", "archive_cell_count", "archive_damage", "describe_archive"]

#: The kinds of archive a description names.
ARCHIVE_KINDS = ("grid", "cvt")
#: More cells than any archive ariel makes (100,000 a grid, 10,000 a CVT), far fewer than a
#: reader's arrays of them could hold.
_MOST_CELLS = 10_000_000


def describe_archive(
    info: Mapping[str, object], archive: pd.DataFrame | None, *, run_dir: str | Path = "."
) -> JsonObject | None:
    """The archive's description (see the module docstring), checked (`archive_damage`).

    Args:
        info: The run's run.json (its ``archive`` and ``config``).
        archive: The run's ``archive`` table (`Run.archive`), or None.
        run_dir: The run's folder, for the error's line.

    Returns:
        run.json's ``archive``; for a run made before it was recorded, a grid: the config's
        ``measures`` and ``ranges`` (``map_elites``' defaults where not given) and the
        table's ``grid`` column as ``bins``; None for a run without an archive.

    Raises:
        DamagedRunError: Where the description or the table's rows are what no ariel writes
            (readers would index past the archive, or divide by no cells).
    """
    recorded = info.get("archive")
    if recorded is None:  # absent (or null): a run made before it was recorded
        description = _from_config(info, archive)
    elif isinstance(recorded, Mapping) and recorded.get("kind") in ARCHIVE_KINDS:
        description = dict(recorded)
    else:
        kind = recorded.get("kind") if isinstance(recorded, Mapping) else type(recorded).__name__
        raise damaged(run_dir, "run.json's archive", f"describes no grid or CVT ({kind!r})")
    problem = None if description is None else archive_damage(description, archive)
    if problem is not None:
        raise damaged(run_dir, *problem)
    return description


def _from_config(info: Mapping[str, object], archive: pd.DataFrame | None) -> JsonObject | None:
    """A run made before run.json described its archive: the grid its config and its table
    (the ``grid`` column) describe; None without rows."""
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


def archive_damage(
    description: Mapping[str, Any], archive: pd.DataFrame | None
) -> tuple[str, str] | None:
    """(what, what is wrong with it) where ``description`` or the ``archive`` table's rows
    are what no ariel writes (readers would index past the archive, or divide by no cells),
    for `damaged`'s line; None where they agree."""
    measures = description.get("measures")
    if (
        not isinstance(measures, list)
        or not measures
        or not all(isinstance(m, str) for m in measures)
    ):
        return "run.json's archive", "names no list of measures"
    ranges = description.get("ranges")
    if not (isinstance(ranges, list) and len(ranges) == len(measures)) or not all(
        _numbers(pair, 2) and pair[0] < pair[1] for pair in ranges
    ):
        return "run.json's archive", "has no [low, high] range (low < high) per measure"
    if description.get("kind") == "grid":
        bins = description.get("bins")
        if not (
            isinstance(bins, list) and _numbers(bins, len(measures), whole=True) and min(bins) >= 1
        ):
            return "run.json's archive", "has no count of bins (>= 1) per measure"
        shape = [int(n) for n in bins]
    else:
        centroids = description.get("centroids")
        if not (isinstance(centroids, list) and centroids) or not all(
            _numbers(point, len(measures)) for point in centroids
        ):
            return "run.json's archive", "has no centroids of one number per measure"
        if description.get("cells", len(centroids)) != len(centroids):
            return "run.json's archive", "has another count of cells than of centroids"
        shape = [len(centroids)]
    cells = math.prod(shape)
    if cells > _MOST_CELLS:
        return "run.json's archive", f"has {cells:,} cells"
    return None if archive is None else _table_damage(archive, shape, cells)


def _numbers(values: object, count: int, *, whole: bool = False) -> bool:
    """Whether ``values`` is a list of ``count`` finite numbers (``whole``: integers)."""
    kinds = int if whole else (int, float)
    return (
        isinstance(values, list)
        and len(values) == count
        and all(isinstance(v, kinds) and not isinstance(v, bool) for v in values)
        and all(math.isfinite(v) for v in values)
    )


def _table_damage(archive: pd.DataFrame, shape: list[int], cells: int) -> tuple[str, str] | None:
    """Where the archive table's rows leave the archive ``shape`` (of ``cells``) describes."""
    if not len(archive):
        return None
    found = archive["cell"].to_numpy()
    if ((found < 0) | (found >= cells)).any():
        return "the archive table", f"has a cell outside the archive's {cells:,}"
    if any(list(grid) != shape for grid in archive["grid"].map(tuple).unique()):
        return "the archive table", f"has a grid other than run.json's archive ({shape})"
    return None


def archive_cell_count(description: Mapping[str, Any]) -> int:
    """The cells of a described archive: a grid's product of ``bins``, a CVT's centroids."""
    if description.get("kind") == "cvt":
        return len(description["centroids"])
    return math.prod(int(n) for n in description["bins"])
