"""``campaign.rrd``: every run's best-so-far fitness on an ``evaluations`` timeline, at
``/condition/<name>/seed/<n>``, and ``campaign.rbl``: one time series view per condition.

Written whole (chunks, no `RecordingStream`), like `write_run_recording`; application id
``ariel``, recording id the campaign id.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ariel.recording._campaign import CAMPAIGN_RRD, load_campaign
from ariel.recording._curves import best_so_far
from ariel.recording._files import atomic_write, require_free_space
from ariel.recording._rerun import APPLICATION_ID, _rr, _static, _write_chunks

__all__ = ["CAMPAIGN_BLUEPRINT", "write_campaign_blueprint", "write_campaign_recording"]

CAMPAIGN_BLUEPRINT = "campaign.rbl"
# Distinct colours per condition (matplotlib's tab10), one shade for all seeds of a condition.
_COLOURS = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
]


def write_campaign_recording(campaign_dir: str | os.PathLike[str]) -> Path:
    """Write ``campaign.rrd`` and ``campaign.rbl`` of the campaign in ``campaign_dir`` from
    its runs' finished generations; returns the recording's path."""
    from rerun.chunk import Chunk

    rr = _rr()
    campaign = load_campaign(campaign_dir)
    colours = {name: _COLOURS[i % len(_COLOURS)] for i, name in enumerate(campaign.conditions)}
    chunks = []
    for (condition, seed), run in campaign.runs.items():
        x, best = best_so_far(run.evaluations, campaign.maximise)
        keep = np.isfinite(best)
        if not keep.any():
            continue
        entity = f"/condition/{condition}/seed/{seed}"
        style = rr.SeriesLines(names=[f"{condition} seed {seed}"], colors=[colours[condition]])
        chunks.append(_static(entity, style))
        index = [rr.TimeColumn("evaluations", sequence=x[keep])]
        chunks.append(Chunk.from_columns(entity, index, rr.Scalars.columns(scalars=best[keep])))
    path = Path(campaign.path) / CAMPAIGN_RRD
    _write_chunks(path, str(campaign.info.get("campaign_id", "campaign")), chunks, fsync=True)
    write_campaign_blueprint(Path(campaign.path) / CAMPAIGN_BLUEPRINT, campaign.path)
    return path


def write_campaign_blueprint(
    path: Path, campaign_dir: str | os.PathLike[str], *, panels: bool = True
) -> Path:
    """The campaign's layout: every run's curve in one view, then one view per condition
    (``panels=False``: the side panels collapsed, for pictures)."""
    from ariel.recording._campaign import read_campaign_info

    conditions = [c["name"] for c in read_campaign_info(campaign_dir).get("conditions", [])]
    rrb = _rr().blueprint
    views = [
        rrb.TimeSeriesView(name=f"best so far: {name}", origin=f"/condition/{name}")
        for name in conditions
    ]
    side = (
        []
        if panels
        else [
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="collapsed"),
        ]
    )
    layout = rrb.Blueprint(
        rrb.Vertical(
            rrb.TimeSeriesView(name="best so far: every run", origin="/condition"),
            rrb.Grid(*views),
            row_shares=[1, 1],
        ),
        *side,
        collapse_panels=False,
    )

    def write(temporary: Path) -> None:
        require_free_space(temporary.parent, 1 << 20)
        staging = temporary.with_name(temporary.name + ".rbl")  # rerun wants a .rbl name
        try:
            layout.save(APPLICATION_ID, str(staging))
            os.replace(staging, temporary)
        finally:
            if staging.exists():
                staging.unlink()

    atomic_write(path, write)
    return path
