"""``ariel run`` and ``ariel resume``: one run in its folder (`ariel.runs`), with the live view
beside it when asked for. Bad input or a folder that cannot be written is one line and exit code
2; Ctrl-C says how to resume; a finished run prints its summary and the commands to look at it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ariel import runs
from ariel.cli._common import fail_with
from ariel.cli._live import LiveView
from ariel.cli._options import add_executor_options, add_set_option
from ariel.errors import ArielError, ConfigError
from ariel.recording.store import RunFolder, terminal_text, version_differences
from ariel.utils import ariel_command, load_run_command, report_interrupted, shell_path
from ariel.utils.interrupts import stop_on_signals

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers
    from ariel.runs import RunResult

__all__ = ["GENERATIONS_SHOWN", "add_resume_command", "add_run_command"]

#: What the printed ``python -c`` line shows of a run: a few columns, none hidden behind ``...``.
GENERATIONS_SHOWN = (
    'r.generations[["generation", "evaluations", "best_fitness", "mean_fitness", '
    '"median_fitness"]].to_string(index=False)'
)


def add_run_command(sub: SubParsers) -> None:
    """Add ``ariel run`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "run",
        help="run an experiment (default: experiments/coevolve_flat.toml)",
        description="Run an experiment: a TOML file (default: experiments/coevolve_flat.toml) "
        "with --set overrides. Every configuration key, its default and meaning: "
        "docs/evolution.md, 'Configuration keys'; `ariel config show [FILE] [--set ...]` prints "
        "the resolved experiment, every key with its value.",
    )
    p.add_argument("config", nargs="?", help="experiment TOML file")
    add_set_option(p, "override a config value, e.g. --set brain.popsize=16 (repeatable)")
    p.add_argument("--out", metavar="DIR", help="the run folder (default: data/runs/<run-id>)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run folder")
    add_executor_options(p)
    p.set_defaults(func=_cmd_run)


def add_resume_command(sub: SubParsers) -> None:
    """Add ``ariel resume`` to the sub-command parsers ``sub``."""
    p = sub.add_parser("resume", help="continue a killed or interrupted run")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    add_executor_options(p)
    p.set_defaults(func=_cmd_resume)


def _how_to_look(path: Path, best: bool = True) -> str:
    """The commands to look at a finished run, each working when pasted into a new shell here
    (the environment's ``ariel`` and python named by path: `ariel.utils._commands`); without
    a ``best`` evaluation (every one failed), none to replay it."""
    ariel = ariel_command()
    quoted = shell_path(path)
    recorded = (path / "run.rrd").is_file() or (path / "recordings").is_dir()
    commands = [
        (f"{ariel} report {quoted}", f"summary table and figures in {quoted}/report"),
        # record.rerun = false: nothing to view
        *([(f"{ariel} view {quoted}", "Rerun viewer (--web on a headless node)")] * recorded),
        *([(f"{ariel} replay {quoted} best", "re-simulate the best evaluation")] * best),
        (f"{ariel} runs {shell_path(path.parent)}", "every run there: status, best"),
    ]
    tables = ["evaluations", "bodies", "trajectories"]
    tables += [name for name in ("archive", "novelty") if (path / name).is_dir()]  # QD runs
    width = max(len(command) for command, _ in commands)
    lines = [f"  {command:<{width}}  # {comment}" for command, comment in commands]
    return "\n".join(
        [
            "look at the results:",
            *lines,
            f"  {load_run_command(path, what=GENERATIONS_SHOWN)}",
            f"  (tables: {quoted}/{', '.join(tables)}; one Parquet file per generation)",
        ]
    )


def _below_here(path: Path) -> Path:
    """``path`` relative to the current folder where it lies below it, as other commands
    print it (``data/runs/RUN``); else as it is."""
    try:
        return path.relative_to(Path.cwd())
    except ValueError:
        return path


def _print_result(result: RunResult) -> None:
    r = result
    best = (
        f"best fitness {r.best_fitness:.6g} (body {r.best_body_id}, evaluation {r.best_eval_id})"
        if r.best_eval_id
        else "no evaluation succeeded (the evaluations table's status and error say why)"
    )
    print(f"{r.status}: {r.run_id}: {best}, {r.evaluations} evaluations in {r.wall_seconds:.1f} s")
    shown = _below_here(Path(r.run_dir))  # absolute in the result, relative where it can be
    print(terminal_text(f"run folder: {shown}"))  # any characters, ESC too
    print(_how_to_look(shown, best=bool(r.best_eval_id)))


def _run_guarded(start: Callable[[], RunResult], path_hint: str | None) -> int:
    """Run ``start()``; bad input, a run folder in use or that cannot be written (disk full)
    -> one line and exit 2; Ctrl-C -> how to resume: the folder the interrupt names (its
    ``run_dir``, `ariel.runs`), else ``path_hint``, else none (nothing was written yet)."""
    try:
        with stop_on_signals():
            result = start()
    except (ArielError, FileExistsError) as exc:  # FileExistsError: --out exists, no --overwrite
        return fail_with(exc)
    except KeyboardInterrupt as exc:
        return report_interrupted(exc, getattr(exc, "run_dir", None) or path_hint, "resume")
    _print_result(result)
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    live = LiveView(args)  # --live: the watcher on the folder, beside the run

    def start() -> RunResult:
        return runs.run_experiment(
            args.config,
            out=live.run_folder(args.out, args.config, args.set),
            overwrite=args.overwrite,
            executor=args.executor,
            workers=args.workers,
            address=args.address,
            progress=not args.quiet,
            overrides=args.set,
        )

    # the run's folder: from the interrupt, once it exists
    return live.finish(_run_guarded(live.guard(start), None))


def _cmd_resume(args: argparse.Namespace) -> int:
    live = LiveView(args)
    _note_software_change(args.run_dir)

    def start() -> RunResult:
        live.start(args.run_dir)
        try:
            return runs.resume_experiment(
                args.run_dir,
                executor=args.executor,
                workers=args.workers,
                address=args.address,
                progress=not args.quiet,
            )
        except ValueError as exc:
            if isinstance(exc, ArielError):
                raise
            raise ConfigError(str(exc)) from None

    return live.finish(_run_guarded(live.guard(start), args.run_dir))


def _note_software_change(run_dir: str) -> None:
    """A note on stderr where the run goes on with other versions of what decides its numbers
    (another MuJoCo: the generations it adds are not those an uninterrupted run would have
    made; run.json's ``segments`` say which software made which). Only for a run the resume
    takes (`resumable`): any problem with the folder is the resume's one line to say."""
    try:
        info, _, _ = runs.resumable(RunFolder(run_dir))
    except (ArielError, OSError, ValueError):
        return
    differences = version_differences(info)
    changed = ", ".join(f"{name} {then} -> {now}" for name, (then, now) in differences.items())
    if changed:
        print(
            terminal_text(
                f"note: {run_dir} was last written with other software ({changed}): the "
                "generations added now may differ from an uninterrupted run's; run.json's "
                "segments record which software made which generations"
            ),
            file=sys.stderr,
        )
