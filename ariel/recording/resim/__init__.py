"""Re-simulation: `replay` of a recorded evaluation, and `ariel export` of a body (its
MJCF, genotype and brain) with `load_exported` that reads it back.

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.resim._export import (
        export as export,
    )
    from ariel.recording.resim._exported import (
        ExportedRobot as ExportedRobot,
        load_exported as load_exported,
    )
    from ariel.recording.resim._rebuild import (
        BEST as BEST,
        BODY_PLUGINS as BODY_PLUGINS,
        check_config as check_config,
        check_options as check_options,
        missing_plugin as missing_plugin,
    )
    from ariel.recording.resim._replay import (
        ReplayResult as ReplayResult,
        UnknownEvaluationError as UnknownEvaluationError,
        has_body_poses as has_body_poses,
        on_demand_recording as on_demand_recording,
        replay as replay,
        replay_task as replay_task,
    )
    from ariel.recording.resim._replay_video import (
        drive_replay as drive_replay,
        replay_video as replay_video,
    )
    from ariel.recording.resim._replay_window import (
        play_replay as play_replay,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "BEST": "ariel.recording.resim._rebuild",
    "BODY_PLUGINS": "ariel.recording.resim._rebuild",
    "ExportedRobot": "ariel.recording.resim._exported",
    "ReplayResult": "ariel.recording.resim._replay",
    "UnknownEvaluationError": "ariel.recording.resim._replay",
    "check_config": "ariel.recording.resim._rebuild",
    "check_options": "ariel.recording.resim._rebuild",
    "missing_plugin": "ariel.recording.resim._rebuild",
    "drive_replay": "ariel.recording.resim._replay_video",
    "export": "ariel.recording.resim._export",
    "has_body_poses": "ariel.recording.resim._replay",
    "load_exported": "ariel.recording.resim._exported",
    "on_demand_recording": "ariel.recording.resim._replay",
    "play_replay": "ariel.recording.resim._replay_window",
    "replay": "ariel.recording.resim._replay",
    "replay_task": "ariel.recording.resim._replay",
    "replay_video": "ariel.recording.resim._replay_video",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
