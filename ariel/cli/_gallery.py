"""``ariel gallery RUN|CAMPAIGN``: the bodies of a run (or the best of each run of a campaign)
side by side, a PNG contact sheet and a self-contained HTML page (`ariel.recording.make_gallery`).

Like every command, it reaches `ariel.recording.analysis` through its lazy face (`ariel.cli`):
mujoco is imported after the GL backend is chosen. Bad input (a folder that is not a run,
``--of archive`` of a run without an archive) is one line and exit code 2, through
`ariel.cli.main`. Where nothing can be drawn (no OpenGL) the gallery is still written,
without pictures, one line says why, and the exit code is 0, as `ariel report` does.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ariel.cli._common import headless_unless_display
from ariel.cli._types import positive_int
from ariel.recording import analysis
from ariel.recording.store import terminal_text

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_gallery_command"]

#: What ``--of`` can show (`ariel.recording.analysis._gallery_select.OF`, without importing it).
OF = ("final", "elites", "archive", "lineage-of-best")


def add_gallery_command(sub: SubParsers) -> None:
    """Add ``ariel gallery`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "gallery",
        help="the bodies of a run side by side: a PNG contact sheet and an HTML page "
        "(RUN/gallery/)",
        description="Draw each body of a run (headless, the report's three-quarter view, "
        "cached in RUN/gallery/thumbnails/) and write OF.png (a contact sheet: body id, "
        "fitness, two key descriptors) and OF.html (the pictures embedded, each body's "
        "descriptors and the `ariel view` command that opens it) to RUN/gallery/. A campaign: "
        "the best body of each run's final population, in CAMPAIGN/gallery/. At most "
        "200 bodies are shown: of more, the best by fitness (a lineage: the best body and its "
        "nearest ancestors).",
    )
    p.add_argument("folder", metavar="RUN|CAMPAIGN", help="a run or campaign folder")
    p.add_argument(
        "--of",
        choices=OF,
        default="final",
        help="final: the population after the last generation (default); elites: a "
        "MAP-Elites run's archive; archive: the same elites at their cells over the two "
        "measures (an atlas); lineage-of-best: the best body and its ancestors",
    )
    p.add_argument(
        "--out", metavar="DIR", help="where OF.png and OF.html go (default: FOLDER/gallery)"
    )
    p.add_argument(
        "--workers",
        type=positive_int,
        metavar="N",
        help="processes drawing the thumbnails (default: one per CPU)",
    )
    p.set_defaults(func=_cmd_gallery)


def _cmd_gallery(args: argparse.Namespace) -> int:
    # before mujoco is imported: it draws off-screen (EGL)
    headless_unless_display("MUJOCO_GL=disable to write the gallery without pictures")
    gallery = analysis.make_gallery(
        args.folder, of=args.of, out=args.out, workers=args.workers, progress=True
    )
    drawn = f"thumbnails: {gallery.drawn} drawn, {gallery.reused} reused from before"
    print(terminal_text(f"{gallery.title}; {drawn}"))
    for note in gallery.notes:  # e.g. why the thumbnails are missing: one line each
        print(terminal_text(note))
    for path in (gallery.png, gallery.html):
        print(terminal_text(f"wrote {path}"))
    return 0
