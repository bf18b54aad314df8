"""``ariel runs [DIR] --prune [--yes]``: delete the run folders that failed or were interrupted
before their first generation finished (`ariel.recording.store._prune` decides which), after a y/N
question on stdin that ``--yes`` skips."""

from __future__ import annotations

import sys
from pathlib import Path

from ariel.recording import store
from ariel.recording.store import one_line

__all__ = ["prune_runs"]


def prune_runs(folder: Path, *, yes: bool) -> int:
    """List the prunable runs under ``folder``, ask, delete them; exit status (2: one or
    more could not be deleted, each said in one line on stderr)."""
    found, links = store.prunable_runs(folder)
    for path, why in links:
        print(f"left alone: {one_line(path)}: {why}")
    if not found:
        print(
            f"nothing to prune under {one_line(folder)}: no run that failed or was "
            "interrupted before its first generation finished"
        )
        return 0
    print(
        f"{len(found)} run folder(s) under {one_line(folder)} failed or were interrupted "
        "before their first generation finished:"
    )
    for run in found:
        print(f"  {one_line(Path(run['path']).name)}  ({run['status']})")
    if not yes:
        try:
            answer = input(f"delete {'it' if len(found) == 1 else 'them'}? [y/N] ")
        except (EOFError, RuntimeError):  # no answer (at the end of stdin, or none: `<&-`): no
            answer = ""
        if sys.stdin is None or not sys.stdin.isatty():  # a piped answer is not echoed
            print()  # end the question's line
        if answer.strip().lower() not in ("y", "yes"):
            print("nothing deleted")
            return 0
    failed = 0
    for run in found:
        try:
            store.prune_run(folder, run["path"])
        except store.PruneError as exc:
            print(f"ariel: error: {one_line(exc)}", file=sys.stderr)
            failed += 1
        else:
            print(f"deleted {one_line(run['path'])}")
    return 2 if failed else 0
