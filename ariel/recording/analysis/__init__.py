"""Analysis of finished runs: `ariel report` (`make_report`), `ariel compare` (`compare`:
statistics, figures, compare.html) and `ariel gallery` (`make_gallery`: bodies side by side).

Cheap to import: names are loaded from their modules on first use (`ariel.utils.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # what ARIEL's other packages import from here (not the API)
    from ariel.recording.analysis._compare import (
        CompareError as CompareError,
        Comparison as Comparison,
        compare as compare,
        shown_path as shown_path,
    )
    from ariel.recording.analysis._gallery import (
        Gallery as Gallery,
        GalleryBody as GalleryBody,
        GalleryError as GalleryError,
        make_gallery as make_gallery,
        report_gallery as report_gallery,
    )
    from ariel.recording.analysis._report import (
        Report as Report,
        make_report as make_report,
        print_report as print_report,
    )

# name -> module that defines it: for ARIEL's other packages, not part of the API
_INTERNAL: dict[str, str] = {
    "CompareError": "ariel.recording.analysis._compare",
    "Comparison": "ariel.recording.analysis._compare",
    "Gallery": "ariel.recording.analysis._gallery",
    "GalleryBody": "ariel.recording.analysis._gallery",
    "GalleryError": "ariel.recording.analysis._gallery",
    "Report": "ariel.recording.analysis._report",
    "compare": "ariel.recording.analysis._compare",
    "make_gallery": "ariel.recording.analysis._gallery",
    "make_report": "ariel.recording.analysis._report",
    "print_report": "ariel.recording.analysis._report",
    "report_gallery": "ariel.recording.analysis._gallery",
    "shown_path": "ariel.recording.analysis._compare",
}

__getattr__, __dir__ = lazy_face(__name__, _INTERNAL)
