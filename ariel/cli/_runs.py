"""``ariel runs [DIR]``: the runs in a folder, one line each (status, generations, evaluations,
best fitness; ``?`` where a run.json does not say); a campaign folder: its runs (under
``runs/condition=<name>/``). ``--prune`` deletes those that never finished a generation
(`ariel.cli._prune`).
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

from ariel import recording
from ariel.cli._common import DEFAULT_RUNS, fail
from ariel.cli._prune import prune_runs
from ariel.recording.store import UNREADABLE, is_campaign, read_campaign_info, terminal_text
from ariel.utils import ariel_line, shell_path

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers
    from ariel.recording.store import RunSummary

__all__ = ["add_runs_command"]


def add_runs_command(sub: SubParsers) -> None:
    """Add ``ariel runs`` to the sub-command parsers ``sub``."""
    p = sub.add_parser("runs", help="list the runs in a folder: status, generations, best")
    p.add_argument(
        "folder",
        nargs="?",
        metavar="DIR",
        help=f"a folder of run folders, or a campaign folder (default: {DEFAULT_RUNS})",
    )
    p.add_argument(
        "--prune",
        action="store_true",
        help="delete the runs that failed or were interrupted before their first generation "
        "finished (lists them and asks first; never a finished generation or a symbolic link)",
    )
    p.add_argument("--yes", action="store_true", help="with --prune: delete without asking")
    p.set_defaults(func=_cmd_runs)


def _cmd_runs(args: argparse.Namespace) -> int:
    folder = Path(args.folder if args.folder is not None else DEFAULT_RUNS)
    if args.folder is not None and not folder.is_dir():  # a typo must not read as "no runs"
        problem = "is not a folder" if folder.exists() else "does not exist"
        return fail(f"{str(folder)!r} {problem}")
    if args.yes and not args.prune:
        return fail("--yes goes with --prune (it answers the question before deleting)")
    if args.prune:
        return prune_runs(folder, yes=args.yes)
    campaign = is_campaign(folder)
    if not campaign and folder.absolute().name == "runs" and is_campaign(folder / ".."):
        folder, campaign = folder / "..", True  # CAMPAIGN/runs (also `.` inside it)
    if not campaign and (folder / "run.json").is_file():  # "no runs under RUN" misled
        return fail(
            f"{str(folder)!r} is a run folder; list the folder that holds it: "
            f"{ariel_line('runs', _parent(folder))}"
        )
    if campaign:
        read_campaign_info(folder)  # a campaign.json refused elsewhere is refused here: one line
    if campaign:
        runs = _campaign_runs(folder)
    elif folder.absolute().name.startswith("condition="):  # one condition of a campaign
        runs = _condition_runs(folder)
    else:
        runs = recording.list_runs(folder)
    inside = "" if campaign else _campaigns_inside(folder)
    if not runs:
        if args.folder is None and not folder.is_dir():  # run from another folder than usual
            where = f"{Path.cwd().name or Path.cwd()}"
            print(
                f"no runs: {DEFAULT_RUNS} does not exist here ({terminal_text(where)}); give the "
                f"folder of your runs ({ariel_line('runs', 'DIR')})"
            )
            return 0
        print(f"no runs under {terminal_text(folder)}{'; it' if inside else ''}{inside}")
        return 0
    for r in runs:  # names from run.json files: no control sequence reaches the terminal
        r["run_id"], r["status"] = _shown_name(r, campaign), terminal_text(r["status"] or "?")
    width = max(len(r["run_id"]) for r in runs)
    status_width = max(11, *(len(r["status"]) for r in runs))
    print(
        f"{'run':<{width}}  {'status':<{status_width}} {'generations':>11} {'evaluations':>11}"
        "  best"
    )
    for r in runs:
        best = r["best_fitness"]
        shown = f"{best:.6g}" if isinstance(best, float) and math.isfinite(best) else "-"
        known = r["status"] != UNREADABLE  # its counts are placeholders: say so
        total = r["generations"] if r["generations"] is not None else "?"
        gens = f"{r['generations_done']}/{total}" if known else "?"
        evaluations = r["evaluations"] if known else "?"
        print(
            f"{r['run_id']:<{width}}  {r['status']:<{status_width}} {gens:>11} "
            f"{evaluations:>11}  {shown}"
        )
    if inside:  # beside the runs: not listed above, but not to be missed
        print(f"{terminal_text(folder)} also{inside}")
    return 0


def _campaigns_inside(folder: Path) -> str:
    """``" holds N campaign folders ..."`` naming those directly in ``folder`` (a campaign's
    runs are under its own folder, which ``ariel runs CAMPAIGN`` lists), or ``""``."""
    if not folder.is_dir():
        return ""
    found = sorted(p for p in folder.iterdir() if p.is_dir() and is_campaign(p))
    if not found:
        return ""
    names = ", ".join(terminal_text(p.name) for p in found[:3]) + (" ..." if len(found) > 3 else "")
    return (
        f" holds {len(found)} campaign folder{'s' * (len(found) != 1)} ({names}): list a "
        f"campaign's runs with: {terminal_text(ariel_line('runs', found[0]))}"
    )


def _shown_name(run: RunSummary, campaign: bool) -> str:
    """The run's id, and its folder's name where that is another (a copied or renamed folder:
    the name to type in the next command). A campaign's runs (folders all ``seed=N``) by
    their folders from here, the names the next command takes."""
    name = Path(run["path"]).name
    if campaign:  # quoted where the shell needs it (a space), as the other hints are
        return terminal_text(shell_path(os.path.relpath(run["path"])))
    if name == run["run_id"]:
        return terminal_text(run["run_id"])
    return f"{terminal_text(name)} (run id {terminal_text(run['run_id'])})"


def _parent(folder: Path) -> Path:
    """The folder holding ``folder``: ``..`` for ``.`` and ``..`` (pathlib takes ``.`` for
    its own parent)."""
    return folder.parent if folder.name not in ("", "..") else folder / ".."


def _campaign_runs(folder: Path) -> list[RunSummary]:
    """The runs of the campaign in ``folder``: each ``runs/condition=<name>/`` folder's (a
    symbolic link is not followed: a campaign's runs lie inside it)."""
    runs_dir = folder / "runs"
    if runs_dir.is_symlink() or not runs_dir.is_dir():
        return []
    found = []
    for condition in sorted(runs_dir.iterdir()):
        if condition.is_dir() and not condition.is_symlink():
            found += _condition_runs(condition)
    return found


def _condition_runs(condition: Path) -> list[RunSummary]:
    """The runs of one ``condition=<name>/`` folder of a campaign, seeds in numeric order."""
    return sorted(recording.list_runs(condition), key=_seed_order)


def _seed_order(run: RunSummary) -> tuple[int, str]:
    """``seed=2`` before ``seed=10`` (by name, 10 came first)."""
    name = Path(run["path"]).name
    number = name.removeprefix("seed=")
    return (int(number), name) if number.isdigit() else (-1, name)
