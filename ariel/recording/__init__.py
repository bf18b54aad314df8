"""Run records: the run folder, its Parquet tables and checkpoints, `load_run`, `replay`,
campaigns (`load_campaign`, `compare`, `write_campaign_recording`), `make_report`,
`make_gallery` (a run's bodies side by side: a PNG contact sheet and an HTML page),
`joint_labels` (joint names for people), the lineage in the ALife phylogeny format (`lineage`,
`write_lineage_csv`, `lineage_statistics`, `lineage_statistics_by_run`, `ancestors`),
`load_exported` (an `ariel export` folder's robot), `table_schema` (a table's Arrow schema,
to read a table folder with pandas or pyarrow),
`watch` (a live view of a running run or campaign), and the Rerun writers
(`write_evaluation_recording`, `write_generation_recording`, `write_run_recording`,
`write_blueprint`).

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.recording.analysis import (
        Comparison as Comparison,
        Gallery as Gallery,
        GalleryBody as GalleryBody,
        Report as Report,
        compare as compare,
        make_gallery as make_gallery,
        make_report as make_report,
    )
    from ariel.recording.rerun import (
        joint_labels as joint_labels,
        write_blueprint as write_blueprint,
        write_campaign_recording as write_campaign_recording,
        write_evaluation_recording as write_evaluation_recording,
        write_generation_recording as write_generation_recording,
        write_run_recording as write_run_recording,
    )
    from ariel.recording.resim import (
        ExportedRobot as ExportedRobot,
        ReplayResult as ReplayResult,
        UnknownEvaluationError as UnknownEvaluationError,
        load_exported as load_exported,
        replay as replay,
    )
    from ariel.recording.store import (
        DESCRIPTORS as DESCRIPTORS,
        Campaign as Campaign,
        DamagedRunError as DamagedRunError,
        NotARunError as NotARunError,
        Run as Run,
        RunFolder as RunFolder,
        RunInUseError as RunInUseError,
        RunLock as RunLock,
        RunStorageError as RunStorageError,
        UnsafePathError as UnsafePathError,
        ancestors as ancestors,
        condition_colours as condition_colours,
        fitness_label as fitness_label,
        integer_ticks as integer_ticks,
        lineage as lineage,
        lineage_statistics as lineage_statistics,
        lineage_statistics_by_run as lineage_statistics_by_run,
        list_runs as list_runs,
        load_campaign as load_campaign,
        load_run as load_run,
        population_after_selection as population_after_selection,
        table_schema as table_schema,
        verify_run as verify_run,
        write_lineage_csv as write_lineage_csv,
    )
    from ariel.recording.viewer import (
        Watcher as Watcher,
        watch as watch,
    )

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "Campaign": "ariel.recording.store",
    "load_campaign": "ariel.recording.store",
    "Comparison": "ariel.recording.analysis",
    "compare": "ariel.recording.analysis",
    "write_campaign_recording": "ariel.recording.rerun",
    "Run": "ariel.recording.store",
    "load_run": "ariel.recording.store",
    "list_runs": "ariel.recording.store",
    "population_after_selection": "ariel.recording.store",
    "joint_labels": "ariel.recording.rerun",
    "NotARunError": "ariel.recording.store",
    "DamagedRunError": "ariel.recording.store",
    "UnsafePathError": "ariel.recording.store",
    "verify_run": "ariel.recording.store",
    "table_schema": "ariel.recording.store",
    "RunFolder": "ariel.recording.store",
    "RunStorageError": "ariel.recording.store",
    "RunInUseError": "ariel.recording.store",
    "RunLock": "ariel.recording.store",
    "ReplayResult": "ariel.recording.resim",
    "UnknownEvaluationError": "ariel.recording.resim",
    "replay": "ariel.recording.resim",
    "Report": "ariel.recording.analysis",
    "make_report": "ariel.recording.analysis",
    "Gallery": "ariel.recording.analysis",
    "GalleryBody": "ariel.recording.analysis",
    "make_gallery": "ariel.recording.analysis",
    "write_evaluation_recording": "ariel.recording.rerun",
    "write_run_recording": "ariel.recording.rerun",
    "write_blueprint": "ariel.recording.rerun",
    "write_generation_recording": "ariel.recording.rerun",
    "load_exported": "ariel.recording.resim",
    "watch": "ariel.recording.viewer",
    "Watcher": "ariel.recording.viewer",
    "ExportedRobot": "ariel.recording.resim",
    # The lineage in the ALife data standard's phylogeny format, and its statistics.
    "lineage": "ariel.recording.store",
    "write_lineage_csv": "ariel.recording.store",
    "lineage_statistics": "ariel.recording.store",
    "lineage_statistics_by_run": "ariel.recording.store",
    "ancestors": "ariel.recording.store",
    # The figures' conventions (units in labels, whole-number ticks, colours), for notebooks.
    "DESCRIPTORS": "ariel.recording.store",
    "condition_colours": "ariel.recording.store",
    "fitness_label": "ariel.recording.store",
    "integer_ticks": "ariel.recording.store",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_face(__name__, _LAZY)
