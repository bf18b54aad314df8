"""Run records: the run folder, its Parquet tables and checkpoints, `load_run`, `replay`,
campaigns (`load_campaign`, `compare`, `write_campaign_recording`), `make_report`,
`joint_labels` (joint names for people), `load_exported` (an `ariel export` folder's robot),
`watch` (a live view of a running run or campaign), and the Rerun writers
(`write_evaluation_recording`, `write_generation_recording`, `write_run_recording`,
`write_blueprint`).

Cheap to import: names are loaded from their modules on first access.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.recording._axes import (
        DESCRIPTORS as DESCRIPTORS,
        fitness_label as fitness_label,
        integer_ticks as integer_ticks,
    )
    from ariel.recording._campaign import (
        Campaign as Campaign,
        load_campaign as load_campaign,
    )
    from ariel.recording._campaign_rerun import (
        write_campaign_recording as write_campaign_recording,
    )
    from ariel.recording._compare import (
        Comparison as Comparison,
        compare as compare,
    )
    from ariel.recording._exported import (
        ExportedRobot as ExportedRobot,
        load_exported as load_exported,
    )
    from ariel.recording._files import (
        UnsafePathError as UnsafePathError,
    )
    from ariel.recording._generation_rrd import (
        write_generation_recording as write_generation_recording,
    )
    from ariel.recording._joint_names import (
        joint_labels as joint_labels,
    )
    from ariel.recording._load import (
        Run as Run,
        list_runs as list_runs,
        load_run as load_run,
        population_after_selection as population_after_selection,
    )
    from ariel.recording._lock import (
        RunInUseError as RunInUseError,
        RunLock as RunLock,
    )
    from ariel.recording._manifest import (
        verify_run as verify_run,
    )
    from ariel.recording._replay import (
        ReplayResult as ReplayResult,
        UnknownEvaluationError as UnknownEvaluationError,
        replay as replay,
    )
    from ariel.recording._report import (
        Report as Report,
        make_report as make_report,
    )
    from ariel.recording._rerun import (
        write_blueprint as write_blueprint,
        write_evaluation_recording as write_evaluation_recording,
        write_run_recording as write_run_recording,
    )
    from ariel.recording._run_folder import (
        DamagedRunError as DamagedRunError,
        NotARunError as NotARunError,
        RunFolder as RunFolder,
        RunStorageError as RunStorageError,
    )
    from ariel.recording._watch import (
        Watcher as Watcher,
        watch as watch,
    )

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "Campaign": "ariel.recording._campaign",
    "load_campaign": "ariel.recording._campaign",
    "Comparison": "ariel.recording._compare",
    "compare": "ariel.recording._compare",
    "write_campaign_recording": "ariel.recording._campaign_rerun",
    "Run": "ariel.recording._load",
    "load_run": "ariel.recording._load",
    "list_runs": "ariel.recording._load",
    "population_after_selection": "ariel.recording._load",
    "joint_labels": "ariel.recording._joint_names",
    "NotARunError": "ariel.recording._run_folder",
    "DamagedRunError": "ariel.recording._run_folder",
    "UnsafePathError": "ariel.recording._files",
    "verify_run": "ariel.recording._manifest",
    "RunFolder": "ariel.recording._run_folder",
    "RunStorageError": "ariel.recording._run_folder",
    "RunInUseError": "ariel.recording._lock",
    "RunLock": "ariel.recording._lock",
    "ReplayResult": "ariel.recording._replay",
    "UnknownEvaluationError": "ariel.recording._replay",
    "replay": "ariel.recording._replay",
    "Report": "ariel.recording._report",
    "make_report": "ariel.recording._report",
    "write_evaluation_recording": "ariel.recording._rerun",
    "write_run_recording": "ariel.recording._rerun",
    "write_blueprint": "ariel.recording._rerun",
    "write_generation_recording": "ariel.recording._generation_rrd",
    "load_exported": "ariel.recording._exported",
    "watch": "ariel.recording._watch",
    "Watcher": "ariel.recording._watch",
    "ExportedRobot": "ariel.recording._exported",
    # The figures' conventions (units in labels, whole-number ticks), for notebooks.
    "DESCRIPTORS": "ariel.recording._axes",
    "fitness_label": "ariel.recording._axes",
    "integer_ticks": "ariel.recording._axes",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'ariel.recording' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
