"""The archive panel of `ariel view` and `ariel watch`: a MAP-Elites (or novelty) run's archive
as its description says it is drawn (a grid's tensor, a CVT's points:
`ariel.recording.rerun.archive_cells`), with its measures' names and ranges."""

from __future__ import annotations

from types import SimpleNamespace
from typing import TYPE_CHECKING

from ariel.recording.rerun import archive_cells
from ariel.recording.store import describe_archive

if TYPE_CHECKING:
    import numpy as np

    from ariel.recording.rerun import CvtCells
    from ariel.recording.store import Run

__all__ = ["archive_beside"]


def archive_beside(run: Run | SimpleNamespace) -> tuple[np.ndarray | CvtCells, list[str]] | None:
    """A MAP-Elites run's archive after its last finished generation as drawn (a grid of
    fitness per cell, NaN: empty; or a CVT's `CvtCells`), and its measures' names with their
    ranges ("num_limbs (0 to 8)"); None for a run without an archive.

    ``run``: a `Run`, or anything with its ``archive`` table and ``config`` (and ``info``,
    run.json, whose ``archive`` description is used where the run recorded it; else the grid
    of the config's options, `ariel.recording.store.describe_archive`).
    """
    archive = run.archive
    if not len(archive):
        return None
    last = archive[archive["generation"] == archive["generation"].max()]
    info = getattr(run, "info", None) or {"config": run.config}
    description = describe_archive(info, archive, run_dir=getattr(run, "path", "."))
    assert description is not None  # the archive has rows
    cells = archive_cells(last.to_dict("records"), description)
    dimensions = getattr(cells, "ndim", len(description["measures"]))
    names = [
        f"{measure} ({float(low):g} to {float(high):g})"
        for measure, (low, high) in zip(description["measures"], description["ranges"])
    ][:dimensions]
    return cells, names + [f"measure {d}" for d in range(len(names), dimensions)]
