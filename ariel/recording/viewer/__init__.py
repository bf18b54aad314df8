"""Viewing: `ariel view` (the Rerun viewer on a run, a campaign or an export) and
`ariel watch` (a live view of a running run or campaign).

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.viewer._child import (
        Stopped as Stopped,
        ViewerStopped as ViewerStopped,
        die_with_parent as die_with_parent,
        raise_stopped as raise_stopped,
        stop_on_signals as stop_on_signals,
    )
    from ariel.recording.viewer._view import (
        view as view,
    )
    from ariel.recording.viewer._watch import (
        Watcher as Watcher,
        watch as watch,
    )
    from ariel.recording.viewer._web import (
        LOCALHOST as LOCALHOST,
        tunnel_command as tunnel_command,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "LOCALHOST": "ariel.recording.viewer._web",
    "Stopped": "ariel.recording.viewer._child",
    "ViewerStopped": "ariel.recording.viewer._child",
    "Watcher": "ariel.recording.viewer._watch",
    "die_with_parent": "ariel.recording.viewer._child",
    "raise_stopped": "ariel.recording.viewer._child",
    "stop_on_signals": "ariel.recording.viewer._child",
    "tunnel_command": "ariel.recording.viewer._web",
    "view": "ariel.recording.viewer._view",
    "watch": "ariel.recording.viewer._watch",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
