"""``ariel campaign run | resume | status`` and ``ariel compare``: parsing and one-line errors.

Like every command, these reach `ariel.runs` and `ariel.recording.analysis` through their lazy
faces (`ariel.cli`): nothing of them is imported until a command runs.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from ariel import runs
from ariel.cli._common import fail
from ariel.cli._live import LiveView
from ariel.cli._options import add_executor_options, add_set_option
from ariel.cli._types import positive_int
from ariel.errors import (
    ConfigError,
    DuplicatePluginError,
    NotARunError,
    PluginLoadError,
    RunInUseError,
    RunStorageError,
)
from ariel.recording import analysis
from ariel.recording.store import load_campaign, terminal_text
from ariel.utils import (
    ariel_command,
    ariel_line,
    load_run_command,
    report_interrupted,
    shell_path,
)
from ariel.utils.interrupts import stop_on_signals

if TYPE_CHECKING:
    import pandas as pd

    from ariel.cli._common import SubParsers
    from ariel.runs import CampaignResult

__all__ = ["add_campaign_commands"]

T = TypeVar("T")


def _guarded(start: Callable[[], T], show: Callable[[T], None], hint: str | None) -> int:
    """``start()``; bad input, a folder in use or that cannot be written -> one line, exit 2;
    Ctrl-C -> how to resume: the folder the interrupt names (its ``campaign_dir``,
    `ariel.runs`), else ``hint``, else none (nothing was written yet)."""
    try:
        with stop_on_signals():
            result = start()
    except (
        ConfigError,
        FileExistsError,
        NotARunError,
        DuplicatePluginError,
        PluginLoadError,
        RunInUseError,
        RunStorageError,
        ValueError,
    ) as exc:
        return fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    except KeyboardInterrupt as exc:
        folder = getattr(exc, "campaign_dir", None) or hint
        return report_interrupted(exc, folder, "campaign", "resume")
    show(result)
    return 0


def _show_campaign(result: CampaignResult) -> None:
    quoted = shell_path(result.path)
    finished = sum(r.status == "finished" for r in result.runs)
    skipped = f" ({result.skipped} finished before, skipped)" if result.skipped else ""
    name = terminal_text(result.campaign_id)
    if not result.runs:  # stopped after its last run: only its own records were written
        print(
            f"{result.status}: campaign {name}: its {result.skipped} runs had finished; "
            "its recording and status are written now"
        )
    else:
        print(
            f"{result.status}: campaign {name}: {finished} of {len(result.runs)} runs "
            f"finished{skipped} in {result.wall_seconds:.1f} s; workers busy "
            f"{result.busy_share:.0%} of the time ({result.workers} "
            f"worker{'' if result.workers == 1 else 's'})"
        )
    print(f"campaign folder: {terminal_text(result.path)}")
    ariel = ariel_command()
    # the last generation's best fitness, condition x seed
    shown = (
        'r.generations.groupby(["condition", "seed"])["best_fitness"].last().unstack().to_string()'
    )
    print(
        "look at the results:\n"
        f"  {ariel} campaign status {quoted}   # condition x seed: status, generations, best\n"
        f"  {ariel} compare {quoted}           # statistics and figures in {quoted}/compare\n"
        f"  {ariel} view {quoted}              # every run's best-so-far curve (Rerun)\n"
        f"  {load_run_command(result.path, loader='load_campaign', what=shown)}"
    )


def _cmd_campaign_run(args: argparse.Namespace) -> int:
    if args.dry_run:
        return _guarded(lambda: _plan(args), lambda lines: print("\n".join(lines)), None)
    live = LiveView(args, "campaign.json")  # --live: the watcher on the folder, beside it

    def start() -> CampaignResult:
        return runs.run_campaign(
            args.file,
            out=live.campaign_folder(args.out, args.file, args.set),
            executor=args.executor,
            workers=args.workers,
            address=args.address,
            progress=not args.quiet,
            overrides=args.set,
        )

    # the folder: from the interrupt, once made
    return live.finish(_guarded(live.guard(start), _show_campaign, None))


def _plan(args: argparse.Namespace) -> list[str]:
    """`--dry-run`: the campaign's conditions x seeds x evaluations and a timed estimate."""

    def timing() -> None:
        if not args.quiet:
            print("timing a few evaluations of each condition here ...", file=sys.stderr)

    plan = runs.campaign_plan(
        args.file, tuple(args.set), executor=args.executor, workers=args.workers, on_timing=timing
    )
    return [terminal_text(line) for line in runs.plan_text(plan)]


def _cmd_campaign_resume(args: argparse.Namespace) -> int:
    live = LiveView(args, "campaign.json")

    def start() -> CampaignResult:
        live.start(args.campaign_dir)
        return runs.resume_campaign(
            args.campaign_dir,
            executor=args.executor,
            workers=args.workers,
            address=args.address,
            progress=not args.quiet,
        )

    resumed: list[CampaignResult] = []

    def show(result: CampaignResult) -> None:
        resumed.append(result)
        _show_campaign(result)

    code = live.finish(_guarded(live.guard(start), show, args.campaign_dir))
    if code == 0 and resumed and resumed[0].damaged:
        for line in resumed[0].damaged:  # the others went on: say which did not, and why
            print(f"ariel: error: {terminal_text(line)}", file=sys.stderr)
        return EXIT_SKIPPED
    return code


#: `ariel campaign resume`'s exit status when some runs went on and others could not.
EXIT_SKIPPED = 1


def _cmd_campaign_status(args: argparse.Namespace) -> int:
    try:
        campaign = load_campaign(args.campaign_dir)
        rows = campaign.status()
    except NotARunError as exc:
        return fail(str(exc))  # `fail` escapes it for the terminal
    # lazy: rich takes ~0.2 s to import, and every `ariel` command imports this module
    from ariel.cli._tables import print_campaign_status

    print_campaign_status(rows, f"campaign {args.campaign_dir}")
    own = campaign.info.get("status")
    if campaign.records_pending(rows):  # stopped after its last run
        print(
            "every run finished, but not the campaign's own records (campaign.json says "
            f"{terminal_text(str(own))!r}): write campaign.rrd and its status with: "
            f"{ariel_line('campaign', 'resume', args.campaign_dir)}"
        )
    return 0


def _print_frame(frame: pd.DataFrame, title: str) -> None:
    """A table of text (a `Comparison` table) with rich, as wide as it needs. Names from the
    folders are shown as text: one line, no control sequence, no rich markup."""
    # lazy: rich takes ~0.2 s to import, and every `ariel` command imports this module
    from ariel.cli._tables import print_frame

    print_frame(frame, title)


#: The most pairs (rows) and conditions (columns) `ariel compare` prints; the files hold all.
PAIR_ROWS_SHOWN = 40
CONDITIONS_SHOWN = 12


def _print_capped(frame: pd.DataFrame, title: str, *, rows: int, columns: int, file: str) -> None:
    """``frame``, its first ``rows`` rows and ``columns`` columns (after the label column)
    where it has more, saying so and which file has it all: 200 conditions are 19,900 pairs."""
    more = []
    if len(frame) > rows:
        more.append(f"the first {rows} of {len(frame):,} rows")
        frame = frame.head(rows)
    if frame.shape[1] > columns + 1:
        more.append(f"the first {columns} of {frame.shape[1] - 1:,} conditions")
        frame = frame.iloc[:, : columns + 1]
    _print_frame(frame, f"{title} ({', '.join(more)}; all in {file})" if more else title)


def _label(text: str) -> tuple[str, str]:
    """``--label NAME=RUN_DIR`` -> (NAME, RUN_DIR); the name is checked by `compare`."""
    name, equals, folder = text.partition("=")
    if not equals or not name or not folder:
        raise argparse.ArgumentTypeError(f"expected NAME=RUN_DIR, not {text!r}")
    return name, folder


def _cmd_compare(args: argparse.Namespace) -> int:
    shown, shown_path = terminal_text, analysis.shown_path
    labels: dict[str, str] = {}
    for name, folder in args.label:
        if labels.setdefault(folder, name) != name:
            return fail(shown(f"{folder!r} has two labels, {labels[folder]!r} and {name!r}"))

    def announce(line: str) -> None:
        print(f"note: {shown(line)}", file=sys.stderr, flush=True)

    try:
        with stop_on_signals():  # Ctrl-C, SIGTERM: one line (the new folder may be partial)
            comparison = analysis.compare(
                args.paths,
                out=args.out,
                at_evaluations=args.at_evaluations,
                labels=labels or None,
                announce=announce,
            )
    except KeyboardInterrupt as exc:
        return report_interrupted(exc, None)
    except (analysis.CompareError, NotARunError) as exc:
        return fail(shown(exc))
    except OSError as exc:  # a folder that cannot be read or written: no permission, disk full
        return fail(shown(f"cannot compare: {exc}"))
    direction = "higher" if comparison.maximise else "lower"
    about = f"{comparison.title}: {comparison.fitness_fn}, {direction} is better"
    print(
        f"compared at {comparison.budget:,} evaluations per run; tests: "
        f"{comparison.tests.describe()}"
    )
    capped = {"rows": PAIR_ROWS_SHOWN, "columns": CONDITIONS_SHOWN}
    _print_capped(
        comparison.summary_table(), f"{about}: per condition", **capped, file="summary.csv"
    )
    _print_capped(comparison.table(), f"{about}: pairs of conditions", **capped, file="stats.md")
    if len(comparison.omnibus):
        _print_frame(comparison.omnibus_table(), f"{about}: all conditions")
    for note in comparison.notes:
        print(f"warning: {shown(note)}")
    counts = comparison.runs.groupby("condition", sort=False).size()
    listed = [f"{shown(name)} {n}" for name, n in counts.items()]
    more = len(listed) - CONDITIONS_SHOWN
    print(
        "runs: " + ", ".join(listed[:CONDITIONS_SHOWN]) + (f", ... {more} more" if more > 0 else "")
    )
    out = shown(shown_path(comparison.out))
    replaced = ", replacing the comparison that was there" if comparison.replaced else ""
    print(
        f"wrote {out}/{replaced} (open {shell_path(shown_path(comparison.html))}; what was "
        f"compared: {shell_path(shown_path(comparison.readme))})"
    )
    return 0


def add_campaign_commands(sub: SubParsers) -> None:
    """Add ``campaign`` (with run, resume, status) and ``compare`` to the sub-parsers."""
    campaign = sub.add_parser(
        "campaign", help="conditions x seeds as one command: run, resume, status"
    )
    actions = campaign.add_subparsers(dest="action", metavar="ACTION", required=True)
    _add_campaign_run(actions)
    _add_campaign_resume_and_status(actions)
    _add_compare(sub)


def _add_campaign_run(actions: SubParsers) -> None:
    """``ariel campaign run``."""
    p = actions.add_parser("run", help="run every condition x seed of a campaign file")
    p.add_argument("file", metavar="FILE", help="campaign TOML file")
    add_set_option(
        p,
        "override a value in every run, over the file's campaign-wide set but not a "
        "condition's own, e.g. --set generations=4 (repeatable)",
    )
    p.add_argument("--out", metavar="DIR", help="campaign folder (default: data/campaigns/<id>)")
    p.add_argument(
        "--dry-run",
        action="store_true",
        help="write nothing: print conditions x seeds x evaluations and an estimate of the "
        "time, from a few evaluations timed here",
    )
    add_executor_options(p)
    p.set_defaults(func=_cmd_campaign_run)


def _add_campaign_resume_and_status(actions: SubParsers) -> None:
    """``ariel campaign resume`` and ``ariel campaign status``."""
    p = actions.add_parser("resume", help="continue the unfinished runs of a campaign")
    p.add_argument("campaign_dir", metavar="DIR", help="a campaign folder")
    add_executor_options(p)
    p.set_defaults(func=_cmd_campaign_resume)

    p = actions.add_parser("status", help="condition x seed: status, generations, best")
    p.add_argument("campaign_dir", metavar="DIR", help="a campaign folder")
    p.set_defaults(func=_cmd_campaign_status)


def _add_compare(sub: SubParsers) -> None:
    """``ariel compare``."""
    p = sub.add_parser(
        "compare",
        help="compare a campaign's conditions (or run folders) with statistics and figures",
    )
    p.add_argument(
        "paths",
        nargs="+",
        type=Path,
        metavar="DIR",
        help="a campaign folder (several of one campaign file, run on different seeds, are "
        "pooled), or run folders",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="output folder (default: CAMPAIGN_DIR/compare for a campaign, a new "
        "./compare-<date>-<time> for pooled campaigns and run folders; an earlier "
        "comparison there is replaced)",
    )
    p.add_argument(
        "--at-evaluations",
        type=positive_int,
        metavar="N",
        help="compare every run after its first N evaluations (default: as many as the "
        "shortest run made)",
    )
    p.add_argument(
        "--label",
        action="append",
        default=[],
        type=_label,
        metavar="NAME=RUN_DIR",
        help="name the condition of a run folder given (repeatable; runs with one NAME form one "
        "condition; label every run folder or none; NAME: up to 64 letters, digits, _ . -); "
        "default: named by the config values that differ",
    )
    p.set_defaults(func=_cmd_compare)
