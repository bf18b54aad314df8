"""``ariel verify RUN_DIR``: a run folder checked against its manifests (`ariel.recording.store`),
like ``git fsck``: each damaged file named; exit 0 sound, 1 damaged, 2 not a run folder.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ariel.cli._common import fail
from ariel.errors import NotARunError
from ariel.recording import store
from ariel.recording.store import terminal_text

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["EXIT_DAMAGED", "add_verify_command"]

EXIT_DAMAGED = 1


def add_verify_command(sub: SubParsers) -> None:
    """Add ``ariel verify`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "verify",
        help="check a run folder against its manifest (exit 1 when a file is damaged)",
        description="Check every finished generation's tables against the run's manifest "
        "(size and SHA-256), like `git fsck`: prints each damaged file; exit 0 when the folder "
        "is sound, 1 when damaged, 2 when it is not a run folder.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.set_defaults(func=_cmd_verify)


def _cmd_verify(args: argparse.Namespace) -> int:
    try:
        result = store.verify_run(args.run_dir)
    except NotARunError as exc:
        return fail(str(exc))  # `fail` escapes it for the terminal
    for problem in result.problems:
        print(f"damaged: {terminal_text(problem)}")
    if result.unlisted:
        print(f"damaged: ... and {result.unlisted} more problem(s), not listed")
    for note in result.notes:
        print(f"note: {terminal_text(note)}")
    how = (
        "size and SHA-256 of every table"
        if result.checked
        else "presence and readability of the tables only: a run made before manifests"
    )
    if not result.checked and result.manifested:  # it said "only" of SHA-256-checked tables
        how = (
            f"a run made before manifests: size and SHA-256 of the {result.manifested} "
            "generation(s) with a manifest, presence and readability of the rest"
        )
    damage = len(result.problems) + result.unlisted
    verdict = f"{damage} damaged file(s)" if damage else "ok"
    checked = (
        "run.json refused, no table read (they are found through it)"
        if result.run_json_refused
        else f"{result.generations} finished generation(s), {result.files} file(s), "
        f"{result.bytes / 1e6:.1f} MB checked ({how})"
    )
    # The folder's name as given: no control sequence reaches the terminal.
    print(f"{verdict}: {terminal_text(args.run_dir)}: {checked}")
    return EXIT_DAMAGED if result.problems else 0
