"""Rerun recordings: an evaluation's, a generation's, the run's and a campaign's, the scene
and camera they share, the lineage graph, and joint names for people.

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.rerun._archive import (
        ARCHIVE_ENTITY as ARCHIVE_ENTITY,
        CvtCells as CvtCells,
        archive_cells as archive_cells,
        archive_grid as archive_grid,
        archive_image as archive_image,
        archive_kind as archive_kind,
        archive_view as archive_view,
    )
    from ariel.recording.rerun._blueprint import (
        write_blueprint as write_blueprint,
    )
    from ariel.recording.rerun._camera import (
        three_quarter_view as three_quarter_view,
    )
    from ariel.recording.rerun._campaign_rerun import (
        CAMPAIGN_BLUEPRINT as CAMPAIGN_BLUEPRINT,
        campaign_views as campaign_views,
        condition_colours as condition_colours,
        curve_chunks as curve_chunks,
        write_campaign_blueprint as write_campaign_blueprint,
        write_campaign_recording as write_campaign_recording,
    )
    from ariel.recording.rerun._chunks import (
        APPLICATION_ID as APPLICATION_ID,
        rerun_module as rerun_module,
        static_chunk as static_chunk,
    )
    from ariel.recording.rerun._generation_rrd import (
        write_generation_blueprint as write_generation_blueprint,
        write_generation_recording as write_generation_recording,
    )
    from ariel.recording.rerun._graph import (
        graph_archetypes as graph_archetypes,
    )
    from ariel.recording.rerun._joint_names import (
        joint_labels as joint_labels,
    )
    from ariel.recording.rerun._lineage import (
        LINEAGE_ENTITY as LINEAGE_ENTITY,
        Lineage as Lineage,
        lineage_view as lineage_view,
    )
    from ariel.recording.rerun._recorder import (
        RerunRecorder as RerunRecorder,
        generation_summary as generation_summary,
    )
    from ariel.recording.rerun._rerun import (
        RUN_SERIES as RUN_SERIES,
        archive_chunks as archive_chunks,
        run_summary_chunks as run_summary_chunks,
        write_evaluation_recording as write_evaluation_recording,
        write_run_recording as write_run_recording,
        write_view_recording as write_view_recording,
    )
    from ariel.recording.rerun._views import (
        SUMMARY_SERIES as SUMMARY_SERIES,
        robot_view as robot_view,
        summary_bars as summary_bars,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "APPLICATION_ID": "ariel.recording.rerun._chunks",
    "ARCHIVE_ENTITY": "ariel.recording.rerun._archive",
    "CAMPAIGN_BLUEPRINT": "ariel.recording.rerun._campaign_rerun",
    "CvtCells": "ariel.recording.rerun._archive",
    "LINEAGE_ENTITY": "ariel.recording.rerun._lineage",
    "Lineage": "ariel.recording.rerun._lineage",
    "RUN_SERIES": "ariel.recording.rerun._rerun",
    "RerunRecorder": "ariel.recording.rerun._recorder",
    "SUMMARY_SERIES": "ariel.recording.rerun._views",
    "archive_chunks": "ariel.recording.rerun._rerun",
    "archive_cells": "ariel.recording.rerun._archive",
    "archive_grid": "ariel.recording.rerun._archive",
    "archive_image": "ariel.recording.rerun._archive",
    "archive_kind": "ariel.recording.rerun._archive",
    "archive_view": "ariel.recording.rerun._archive",
    "campaign_views": "ariel.recording.rerun._campaign_rerun",
    "condition_colours": "ariel.recording.rerun._campaign_rerun",
    "curve_chunks": "ariel.recording.rerun._campaign_rerun",
    "generation_summary": "ariel.recording.rerun._recorder",
    "graph_archetypes": "ariel.recording.rerun._graph",
    "joint_labels": "ariel.recording.rerun._joint_names",
    "lineage_view": "ariel.recording.rerun._lineage",
    "rerun_module": "ariel.recording.rerun._chunks",
    "robot_view": "ariel.recording.rerun._views",
    "run_summary_chunks": "ariel.recording.rerun._rerun",
    "static_chunk": "ariel.recording.rerun._chunks",
    "summary_bars": "ariel.recording.rerun._views",
    "three_quarter_view": "ariel.recording.rerun._camera",
    "write_blueprint": "ariel.recording.rerun._blueprint",
    "write_campaign_blueprint": "ariel.recording.rerun._campaign_rerun",
    "write_campaign_recording": "ariel.recording.rerun._campaign_rerun",
    "write_evaluation_recording": "ariel.recording.rerun._rerun",
    "write_generation_blueprint": "ariel.recording.rerun._generation_rrd",
    "write_generation_recording": "ariel.recording.rerun._generation_rrd",
    "write_run_recording": "ariel.recording.rerun._rerun",
    "write_view_recording": "ariel.recording.rerun._rerun",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
