"""ARIEL's utilities: upstream's modules (renderers, runners, tracker, video_recorder,
morphological_descriptor) and the helpers ARIEL's packages share

Cheap to import: names are loaded from their modules on first use (`lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.utils._arguments import (
        count_argument as count_argument,
        flag_argument as flag_argument,
        number_argument as number_argument,
        path_argument as path_argument,
        paths_argument as paths_argument,
        strings_argument as strings_argument,
        whole_numbers as whole_numbers,
    )
    from ariel.utils._commands import (
        ariel_command as ariel_command,
        ariel_line as ariel_line,
        load_run_command as load_run_command,
        python_command as python_command,
        report_interrupted as report_interrupted,
        shell_path as shell_path,
        shell_quote as shell_quote,
    )
    from ariel.utils._file_kind import (
        file_kind as file_kind,
    )
    from ariel.utils._gl import (
        ensure_headless_gl as ensure_headless_gl,
        gl_backend_error as gl_backend_error,
        has_display as has_display,
        mujoco_module as mujoco_module,
        no_display_why as no_display_why,
    )
    from ariel.utils._json import (
        nests_deeper_than as nests_deeper_than,
        replace_non_finite as replace_non_finite,
    )
    from ariel.utils._keywords import (
        accept_aliases as accept_aliases,
        unknown_option as unknown_option,
    )
    from ariel.utils._new_folder import (
        free_path as free_path,
        gone_if_empty as gone_if_empty,
        new_folder as new_folder,
    )
    from ariel.utils._notebook import (
        in_notebook_kernel as in_notebook_kernel,
        is_terminal as is_terminal,
    )
    from ariel.utils._open_files import (
        MIN_OPEN_FILES as MIN_OPEN_FILES,
        open_files_short as open_files_short,
    )
    from ariel.utils._seeding import (
        global_generator as global_generator,
    )
    from ariel.utils._shared_setting import (
        SharedSetting as SharedSetting,
    )
    from ariel.utils.interrupts import (
        raise_pending as raise_pending,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "accept_aliases": "ariel.utils._keywords",
    "ariel_command": "ariel.utils._commands",
    "ariel_line": "ariel.utils._commands",
    "count_argument": "ariel.utils._arguments",
    "ensure_headless_gl": "ariel.utils._gl",
    "file_kind": "ariel.utils._file_kind",
    "flag_argument": "ariel.utils._arguments",
    "free_path": "ariel.utils._new_folder",
    "gl_backend_error": "ariel.utils._gl",
    "global_generator": "ariel.utils._seeding",
    "gone_if_empty": "ariel.utils._new_folder",
    "has_display": "ariel.utils._gl",
    "in_notebook_kernel": "ariel.utils._notebook",
    "is_terminal": "ariel.utils._notebook",
    "load_run_command": "ariel.utils._commands",
    "MIN_OPEN_FILES": "ariel.utils._open_files",
    "mujoco_module": "ariel.utils._gl",
    "nests_deeper_than": "ariel.utils._json",
    "new_folder": "ariel.utils._new_folder",
    "no_display_why": "ariel.utils._gl",
    "number_argument": "ariel.utils._arguments",
    "open_files_short": "ariel.utils._open_files",
    "path_argument": "ariel.utils._arguments",
    "paths_argument": "ariel.utils._arguments",
    "python_command": "ariel.utils._commands",
    "raise_pending": "ariel.utils.interrupts",
    "replace_non_finite": "ariel.utils._json",
    "report_interrupted": "ariel.utils._commands",
    "SharedSetting": "ariel.utils._shared_setting",
    "shell_path": "ariel.utils._commands",
    "shell_quote": "ariel.utils._commands",
    "strings_argument": "ariel.utils._arguments",
    "unknown_option": "ariel.utils._keywords",
    "whole_numbers": "ariel.utils._arguments",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
