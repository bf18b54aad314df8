"""``campaign.rrd``: every run's best-so-far fitness on an ``evaluations`` timeline, at
``/condition/<name>/seed/<n>``, and ``campaign.rbl``: one time series view per condition.

Rerun's time series views have no axis titles, so each view's title says what its axes are
("best fitness so far (m) over evaluations"). Every series of a condition is named after the
condition, so a legend lists each condition once (the viewer merges series of one name); it
sits in the corner the best-so-far curves leave empty, and views of one condition have none.

Written whole (chunks, no `RecordingStream`), like `write_run_recording`; application id
``ariel``, recording id the campaign id.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ariel.recording.rerun._blueprint import save_blueprint
from ariel.recording.rerun._chunks import APPLICATION_ID, rerun_module, rgb, static_chunk
from ariel.recording.rerun._rerun import _write_chunks
from ariel.recording.store import (
    CAMPAIGN_RRD,
    best_so_far,
    condition_colours as store_colours,
    fitness_unit as fitness_unit_of,
    load_campaign,
    read_campaign_info,
)

if TYPE_CHECKING:
    from rerun.blueprint import TimeSeriesView
    from rerun.chunk import Chunk

    from ariel.recording.store import Campaign

__all__ = [
    "CAMPAIGN_BLUEPRINT",
    "campaign_views",
    "condition_colours",
    "curve_chunks",
    "write_campaign_blueprint",
    "write_campaign_recording",
]

CAMPAIGN_BLUEPRINT = "campaign.rbl"


def write_campaign_recording(
    campaign_dir: str | os.PathLike[str], *, into: str | os.PathLike[str] | None = None
) -> Path:
    """Write ``campaign.rrd`` and ``campaign.rbl`` of the campaign in ``campaign_dir`` from
    its runs' finished generations.

    The recording holds every run's best-so-far fitness over its evaluations, one line per
    run at ``/condition/<name>/seed/<n>``, coloured by condition; the blueprint lays it out.

    Args:
        campaign_dir: The campaign folder; both files are written into it, replacing any
            earlier ones.
        into: Another folder for the two files (``ariel view`` of a campaign that has none,
            which never writes into the campaign); None: ``campaign_dir``.

    Returns:
        The path of ``campaign.rrd``.

    Raises:
        NotACampaignError: When ``campaign_dir`` is not a campaign folder.
    """
    campaign = load_campaign(Path(campaign_dir))
    colours = condition_colours(campaign.conditions)
    chunks = []
    for (condition, seed), run in campaign.runs.items():
        x, best = best_so_far(run.evaluations, campaign.maximise)
        chunks += curve_chunks(condition, seed, x, best, colours[condition])
    folder = Path(campaign.path) if into is None else Path(into)
    path = folder / CAMPAIGN_RRD
    _write_chunks(path, str(campaign.info.get("campaign_id", "campaign")), chunks, fsync=True)
    write_campaign_blueprint(
        folder / CAMPAIGN_BLUEPRINT,
        campaign.path,
        fitness_unit=_fitness_unit(campaign),
        maximise=campaign.maximise,
    )
    return path


def condition_colours(conditions: Sequence[str]) -> dict[str, tuple[int, int, int]]:
    """Each condition's colour (one shade for all its seeds) as RGB, those of `ariel compare`
    and the notebooks (`ariel.recording.store.condition_colours`; ten repeated before)."""
    shared = store_colours(conditions)
    return {name: rgb(shared[name]) for name in conditions}


def curve_chunks(
    condition: str,
    seed: int,
    x: np.ndarray,
    best: np.ndarray,
    colour: tuple[int, int, int],
    *,
    style: bool = True,
) -> list[Chunk]:
    """The chunks of one run's best-so-far curve (``x``: evaluations, ``best``: the fitness
    so far, NaN before the first) at ``/condition/<condition>/seed/<seed>``: its style (with
    ``style``) and its points with a finite value; none when it has no such point."""
    rr = rerun_module()
    keep = np.isfinite(best)
    if not keep.any():
        return []
    entity = f"/condition/{condition}/seed/{seed}"
    chunks = []
    if style:
        # Named after the condition only: the legend then lists each condition once.
        lines = rr.SeriesLines(names=[condition], colors=[colour])
        chunks.append(static_chunk(entity, lines))
    index = [rr.TimeColumn("evaluations", sequence=x[keep])]
    chunks.append(
        rr.chunk.Chunk.from_columns(entity, index, rr.Scalars.columns(scalars=best[keep]))
    )
    return chunks


def _fitness_unit(campaign: Campaign) -> str | None:
    """The unit of the campaign's fitness function (its first run's), None where unknown."""
    for run in campaign.runs.values():
        name = run.config.get("task", {}).get("fitness")
        return fitness_unit_of(name) if isinstance(name, str) and name else None
    return None


def write_campaign_blueprint(
    path: Path,
    campaign_dir: str | os.PathLike[str],
    *,
    panels: bool = True,
    fitness_unit: str | None = None,
    maximise: bool | None = None,
) -> Path:
    """The campaign's layout: every run's curve in one view, with a legend of the conditions
    in the corner its curves leave empty (top left where fitness is maximised, bottom left
    where minimised), then one view per condition, without legend; each view's title names
    its axes, with the fitness function's unit. ``fitness_unit`` and ``maximise``: read from
    the campaign's runs when not given. ``panels=False``: the side panels collapsed, for
    pictures."""
    conditions = [c["name"] for c in read_campaign_info(Path(campaign_dir)).get("conditions", [])]
    if fitness_unit is None or maximise is None:
        campaign = load_campaign(Path(campaign_dir))
        fitness_unit = _fitness_unit(campaign) if fitness_unit is None else fitness_unit
        maximise = campaign.maximise if maximise is None else maximise
    rrb = rerun_module().blueprint
    every, views = campaign_views(conditions, fitness_unit=fitness_unit, maximise=maximise)
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
            every,
            rrb.Grid(*views),
            row_shares=[1, 1],
        ),
        *side,
        collapse_panels=False,
    )
    return save_blueprint(path, layout, APPLICATION_ID)


def campaign_views(
    conditions: Sequence[str], *, fitness_unit: str | None, maximise: bool
) -> tuple[TimeSeriesView, list[TimeSeriesView]]:
    """The campaign's curve views: every run's in one (a legend of the conditions in the
    corner the curves leave empty: top left where fitness is maximised, bottom left where
    minimised), and one per condition, without legend; each titled with its axes."""
    rrb = rerun_module().blueprint
    axes = f"best fitness so far{f' ({fitness_unit})' if fitness_unit else ''} over evaluations"
    views = [
        rrb.TimeSeriesView(
            name=f"{name}: {axes}",
            origin=f"/condition/{name}",
            plot_legend=rrb.PlotLegend(visible=False),
        )
        for name in conditions
    ]
    corner = rrb.Corner2D.LeftTop if maximise else rrb.Corner2D.LeftBottom
    every = rrb.TimeSeriesView(
        name=f"every run: {axes}",
        origin="/condition",
        plot_legend=rrb.PlotLegend(corner=corner),
    )
    return every, views
