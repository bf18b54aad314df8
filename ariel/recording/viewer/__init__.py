"""Viewing: `ariel view` (the Rerun viewer on a run, a campaign or an export) and
`ariel watch` (a live view of a running run or campaign).

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.viewer._view import (
        LOCALHOST as LOCALHOST,
        Stopped as Stopped,
        die_with_parent as die_with_parent,
        raise_stopped as raise_stopped,
        tunnel_command as tunnel_command,
        view as view,
    )
    from ariel.recording.viewer._watch import (
        Watcher as Watcher,
        watch as watch,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "LOCALHOST": "ariel.recording.viewer._view",
    "Stopped": "ariel.recording.viewer._view",
    "Watcher": "ariel.recording.viewer._watch",
    "die_with_parent": "ariel.recording.viewer._view",
    "raise_stopped": "ariel.recording.viewer._view",
    "tunnel_command": "ariel.recording.viewer._view",
    "view": "ariel.recording.viewer._view",
    "watch": "ariel.recording.viewer._watch",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
