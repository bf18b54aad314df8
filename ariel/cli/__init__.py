"""The ``ariel`` command.

Each sub-command imports what it needs only when it runs, so ``ariel --help`` stays instant.
Bad input (an unknown plugin, a bad config key or value, an existing output folder, ...) is
one line on stderr and exit code 2, before anything is written: every error the workbench
raises on purpose is an `ariel.errors.ArielError`, caught here as one class.
"""

from __future__ import annotations

import argparse
import math
import re
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from ariel import __version__
from ariel.cli._options import add_executor_options as _add_executor_options, add_web_viewer_options
from ariel.cli._types import integer_at_least, positive_int
from ariel.errors import ArielError, ConfigError

EXIT_USAGE = 2
#: Where `ariel run` puts run folders and `ariel runs` looks by default.
DEFAULT_RUNS = "data/runs"


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the message and where to get help)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _fail(message: str) -> int:
    print(f"ariel: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def _fail_with(exc: BaseException) -> int:
    return _fail(str(exc) or type(exc).__name__)


#: What the printed ``python -c`` line shows of a run: a few columns, none hidden behind ``...``.
GENERATIONS_SHOWN = (
    'r.generations[["generation", "evaluations", "best_fitness", "mean_fitness", '
    '"median_fitness"]].to_string(index=False)'
)


def _how_to_look(path: Path) -> str:
    """The commands to look at a finished run, each working when pasted into a new shell here
    (the environment's ``ariel`` and python named by path: `ariel.utils._commands`)."""
    from ariel.utils import ariel_command, load_run_command

    ariel = ariel_command()
    quoted = shlex.quote(str(path))
    recorded = (path / "run.rrd").is_file() or (path / "recordings").is_dir()
    commands = [
        (f"{ariel} report {quoted}", f"summary table and figures in {quoted}/report"),
        # record.rerun = false: nothing to view
        *([(f"{ariel} view {quoted}", "Rerun viewer (--web on a headless node)")] * recorded),
        (f"{ariel} replay {quoted} best", "re-simulate the best evaluation"),
        (f"{ariel} runs {shlex.quote(str(path.parent))}", "every run there: status, best"),
    ]
    width = max(len(command) for command, _ in commands)
    lines = [f"  {command:<{width}}  # {comment}" for command, comment in commands]
    return "\n".join(
        [
            "look at the results:",
            *lines,
            f"  {load_run_command(path, what=GENERATIONS_SHOWN)}",
            f"  (tables: {quoted}/evaluations, bodies, trajectories; one Parquet file per "
            "generation)",
        ]
    )


def _print_result(result: object) -> None:
    r = result  # RunResult
    print(
        f"{r.status}: {r.run_id}: best fitness {r.best_fitness:.6g} "  # type: ignore[attr-defined]
        f"(body {r.best_body_id}, evaluation {r.best_eval_id or '-'}), "  # type: ignore[attr-defined]
        f"{r.evaluations} evaluations in {r.wall_seconds:.1f} s"  # type: ignore[attr-defined]
    )
    print(f"run folder: {r.run_dir}")  # type: ignore[attr-defined]
    print(_how_to_look(Path(r.run_dir)))  # type: ignore[attr-defined]


def _run_guarded(start: object, path_hint: str | None) -> int:
    """Run ``start()``; bad input, a run folder in use or that cannot be written (disk full)
    -> one line and exit 2; Ctrl-C -> how to resume: the folder the interrupt names (its
    ``run_dir``, `ariel.runs`), else ``path_hint``, else none (nothing was written yet)."""
    from ariel.utils.interrupts import stop_on_signals

    try:
        with stop_on_signals():
            result = start()  # type: ignore[operator]
    except (ArielError, FileExistsError) as exc:  # FileExistsError: --out exists, no --overwrite
        return _fail_with(exc)
    except KeyboardInterrupt as exc:
        from ariel.utils import report_interrupted

        return report_interrupted(exc, getattr(exc, "run_dir", None) or path_hint, "resume")
    _print_result(result)
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from ariel.cli._live import LiveView
    from ariel.runs import run_experiment

    live = LiveView(args)  # --live: the watcher on the folder, beside the run

    def start() -> object:
        return run_experiment(
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
    from ariel.cli._live import LiveView
    from ariel.runs import resume_experiment

    live = LiveView(args)

    def start() -> object:
        live.start(args.run_dir)
        try:
            return resume_experiment(
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


def _cmd_runs(args: argparse.Namespace) -> int:
    from ariel.recording import list_runs

    folder = Path(args.folder if args.folder is not None else DEFAULT_RUNS)
    if args.folder is not None and not folder.is_dir():  # a typo must not read as "no runs"
        problem = "is not a folder" if folder.exists() else "does not exist"
        return _fail(f"{str(folder)!r} {problem}")
    if args.yes and not args.prune:
        return _fail("--yes goes with --prune (it answers the question before deleting)")
    if args.prune:
        from ariel.cli._prune import prune_runs

        return prune_runs(folder, yes=args.yes)
    from ariel.recording.store import terminal_text

    runs = list_runs(folder)
    if not runs:
        print(f"no runs under {terminal_text(folder)}")
        return 0
    for r in runs:  # names from run.json files: no control sequence reaches the terminal
        r["run_id"], r["status"] = terminal_text(r["run_id"]), terminal_text(r["status"] or "?")
    width = max(len(r["run_id"]) for r in runs)
    status_width = max(11, *(len(r["status"]) for r in runs))
    print(
        f"{'run':<{width}}  {'status':<{status_width}} {'generations':>11} {'evaluations':>11}"
        "  best"
    )
    for r in runs:
        best = r["best_fitness"]
        shown = f"{best:.6g}" if isinstance(best, float) and math.isfinite(best) else "-"
        gens = f"{r['generations_done']}/{r['generations']}"
        print(
            f"{r['run_id']:<{width}}  {r['status']:<{status_width}} {gens:>11} "
            f"{r['evaluations']:>11}  {shown}"
        )
    return 0


class _IntermixedParser(_Parser):
    """Options and positionals in any order: argparse (Python 3.11, 3.12) binds an optional
    positional (``EVAL_ID``) too early, and ``ariel view RUN --web EVAL_ID`` would fail."""

    _inner = False

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        if self._inner:  # parse_known_intermixed_args calls back here
            return super().parse_known_args(args, namespace)
        self._inner = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        finally:
            self._inner = False


def _png_path(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() != ".png":
        raise argparse.ArgumentTypeError(f"must be a .png file, not {text!r}")
    if not path.parent.is_dir():
        raise argparse.ArgumentTypeError(f"folder {str(path.parent)!r} does not exist")
    return path


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)x(\d+)", text)
    width, height = (int(g) for g in match.groups()) if match else (0, 0)
    if not (320 <= width <= 7680 and 240 <= height <= 4320):
        raise argparse.ArgumentTypeError(
            f"must be WIDTHxHEIGHT, 320x240 to 7680x4320 pixels, not {text!r}"
        )
    return width, height


def _cmd_view(args: argparse.Namespace) -> int:
    from ariel.recording.viewer import view

    return view(
        args.run_dir,
        best=args.best,
        generation=args.generation,
        eval_id=args.eval_id,
        web=args.web,
        port=args.port,
        grpc_port=args.grpc_port,
        screenshot=args.screenshot,
        size=args.size,
    )


def _cmd_plugins(args: argparse.Namespace) -> int:
    from ariel.plugins import REGISTRIES

    if not args.check:
        for kind, registry in REGISTRIES.items():
            print(f"{kind}: {', '.join(registry.names())}")
        return 0
    from ariel.plugins import check_all

    failures = 0
    for kind, name, problem in check_all():
        print(f"{'FAIL' if problem else 'ok  '} {kind} {name}{': ' + problem if problem else ''}")
        failures += problem is not None
    print(f"{failures} plugin(s) failed their checks" if failures else "all plugins pass")
    return 1 if failures else 0


def _cmd_quickstart(args: argparse.Namespace) -> int:
    import runpy

    script = Path(__file__).resolve().parents[2] / "experiments" / "quickstart.py"
    if not script.exists():
        return _fail(f"{script} not found (run from a source checkout)")
    script_globals = runpy.run_path(str(script), run_name="ariel_quickstart")  # defines main()
    saved = sys.argv
    sys.argv = ["ariel quickstart", *args.rest]  # the script's usage line names this command
    try:
        return int(script_globals["main"](list(args.rest)) or 0)
    finally:
        sys.argv = saved


def _headless_unless_display(without: str) -> None:
    """Render off-screen (EGL) where no window can open. Only for commands that render, and
    before mujoco is imported: a command that draws nothing must not load a GL library (EGL
    missing would fail its ``import mujoco``). ``without``: how to run without rendering."""
    from ariel.utils import ensure_headless_gl, has_display

    if not has_display():
        ensure_headless_gl(without=without)


def _cmd_replay(args: argparse.Namespace) -> int:
    from ariel.utils import has_display

    if args.viewer and not has_display():
        return _fail(
            "--viewer needs a display (DISPLAY is not set); write a video with --video FILE "
            "or a Rerun recording with --rrd FILE instead"
        )
    if args.video:  # replay() imports mujoco to re-simulate: the backend is chosen first
        _headless_unless_display("run without --video")
    from ariel.recording.resim import replay

    replayed = replay(args.run_dir, args.eval_id)
    row = replayed.row
    print(
        f"evaluation {replayed.eval_id} (generation {int(row['generation'])}, body "
        f"{row['body_id']}) of run {replayed.run.info.get('run_id', args.run_dir)}"
    )
    print(f"stored fitness:   {replayed.stored_fitness!r} ({replayed.stored_status})")
    print(f"replayed fitness: {replayed.fitness!r} ({replayed.status})")
    if not replayed.exact:  # MuJoCo Warp (float32) on either side: close, never claimed equal
        print(f"backend: stored {replayed.stored_backend}, replayed {replayed.backend}")
        print(f"difference: {replayed.difference:+.3g} (MuJoCo Warp is not bitwise repeatable)")
    elif replayed.identical:
        print("identical: yes, bit for bit")
    else:
        print("identical: NO")
        for name, (then, now) in replayed.version_differences.items():
            print(f"  {name}: the run used {then}, this replay {now}")
    try:
        if args.rrd or args.video or args.viewer:
            dense = replayed.full_rate()
            print(
                f"full rate (every physics step, {len(dense.time)} frames): fitness "
                f"{float(dense.fitness)!r}"
            )
        if args.rrd:
            print(f"wrote {replayed.write_rrd(args.rrd)}")
        if args.video:
            print(f"wrote {replayed.write_video(args.video)}")
        if args.viewer:
            replayed.view()
    except (ValueError, RuntimeError, ImportError) as exc:
        return _fail(str(exc).splitlines()[0])
    except OSError as exc:  # --rrd / --video onto a full disk, a read-only file system, ...
        from ariel.recording.store import cannot_write

        return _fail(cannot_write(exc))
    close = not replayed.exact and replayed.status == replayed.stored_status
    return 0 if replayed.identical or close else 1


def _cmd_report(args: argparse.Namespace) -> int:
    if not args.no_render:  # loading the run imports mujoco (body descriptors) before it renders
        _headless_unless_display("run with --no-render")
    from ariel.recording.analysis import make_report, print_report

    report = make_report(args.run_dir, render=not args.no_render)
    print_report(report)
    return 0


EXIT_DAMAGED = 1


def _cmd_verify(args: argparse.Namespace) -> int:
    from ariel.recording import NotARunError
    from ariel.recording.store import verify_run

    try:
        result = verify_run(args.run_dir)
    except NotARunError as exc:
        return _fail(str(exc))
    from ariel.recording.store import terminal_text

    for problem in result.problems:
        print(f"damaged: {terminal_text(problem)}")
    for note in result.notes:
        print(f"note: {terminal_text(note)}")
    how = (
        "size and SHA-256 of every table"
        if result.checked
        else "presence and readability of the tables only: a run made before manifests"
    )
    verdict = f"{len(result.problems)} damaged file(s)" if result.problems else "ok"
    print(
        f"{verdict}: {args.run_dir}: {result.generations} finished generation(s), "
        f"{result.files} file(s), {result.bytes / 1e6:.1f} MB checked ({how})"
    )
    return EXIT_DAMAGED if result.problems else 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="ariel", description="ARIEL workbench: evolve modular robots in MuJoCo.")
    parser.add_argument("--version", action="version", version=f"ariel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser(
        "run",
        help="run an experiment (default: experiments/coevolve_flat.toml)",
        description="Run an experiment: a TOML file (default: experiments/coevolve_flat.toml) "
        "with --set overrides. Every configuration key, its default and meaning: "
        "docs/evolution.md, 'Configuration keys'; `ariel config show [FILE] [--set ...]` prints "
        "the resolved experiment, every key with its value.",
    )
    p.add_argument("config", nargs="?", help="experiment TOML file")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a config value, e.g. --set brain.popsize=16 (repeatable)",
    )
    p.add_argument("--out", metavar="DIR", help="the run folder (default: data/runs/<run-id>)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run folder")
    _add_executor_options(p)
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("resume", help="continue a killed or interrupted run")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    _add_executor_options(p)
    p.set_defaults(func=_cmd_resume)

    p = sub.add_parser("runs", help="list the runs in a folder: status, generations, best")
    p.add_argument(
        "folder",
        nargs="?",
        metavar="DIR",
        help=f"a folder of run folders (default: {DEFAULT_RUNS})",
    )
    p.add_argument(
        "--prune",
        action="store_true",
        help="delete the runs that failed or were interrupted before their first generation "
        "finished (lists them and asks first; never a finished generation or a symbolic link)",
    )
    p.add_argument("--yes", action="store_true", help="with --prune: delete without asking")
    p.set_defaults(func=_cmd_runs)

    p = sub.add_parser(
        "replay",
        help="re-simulate one evaluation of a run and check its stored fitness bit for bit",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument("eval_id", metavar="EVAL_ID", help="e.g. b000012-i003-c005, or 'best'")
    p.add_argument("--rrd", metavar="FILE", help="write a full-rate Rerun recording")
    p.add_argument("--video", metavar="FILE", help="write an MP4 (camera tracking the robot)")
    p.add_argument("--viewer", action="store_true", help="play it in the MuJoCo viewer")
    p.set_defaults(func=_cmd_replay)

    from ariel.cli._export import add_export_command

    add_export_command(sub)

    p = sub.add_parser(
        "report", help="per-generation table and figures of a run (PNGs in RUN_DIR/report/)"
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument(
        "--no-render", action="store_true", help="leave out the rendered image of the best body"
    )
    p.set_defaults(func=_cmd_report)

    p = sub.add_parser(
        "verify",
        help="check a run folder against its manifest (exit 1 when a file is damaged)",
        description="Check every finished generation's tables against the run's manifest "
        "(size and SHA-256), like `git fsck`: prints each damaged file; exit 0 when the folder "
        "is sound, 1 when damaged, 2 when it is not a run folder.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("plugins", help="list the registered plugins of every kind")
    p.add_argument(
        "--check", action="store_true", help="run the plugin checkers on every registered plugin"
    )
    p.set_defaults(func=_cmd_plugins)

    p = sub.add_parser(
        "view",
        help="open a run's Rerun recordings in the viewer (--web: serve it for an SSH tunnel)",
        description="Open Rerun recordings of a run with its blueprint: by default run.rrd and "
        "the best evaluation's recording.",
    )
    p.__class__ = _IntermixedParser  # EVAL_ID may follow the options
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument("eval_id", nargs="?", metavar="EVAL_ID", help="one evaluation")
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--best", type=positive_int, metavar="K", help="the K best evaluations of the run"
    )
    which.add_argument(
        "--generation",
        type=integer_at_least(0),
        metavar="G",
        help="every evaluation of generation G (its evaluations.rrd)",
    )
    add_web_viewer_options(p, "the gRPC proxy the web viewer reads the recordings from")
    p.add_argument(
        "--screenshot",
        type=_png_path,
        metavar="FILE.png",
        help="instead of serving: draw the web viewer in a headless Chromium, save it, stop",
    )
    p.add_argument(
        "--size",
        type=_size,
        default=(1600, 900),
        metavar="WxH",
        help="screenshot size in pixels (default 1600x900)",
    )
    p.set_defaults(func=_cmd_view)

    from ariel.cli._campaign import add_campaign_commands
    from ariel.cli._config import add_config_commands
    from ariel.cli._gallery import add_gallery_command
    from ariel.cli._watch import add_watch_command

    add_campaign_commands(sub, _add_executor_options)
    add_config_commands(sub)
    add_watch_command(sub)
    add_gallery_command(sub)

    # Every option (--seed, --duration, --out, ..., --help) is the script's: main() hands them on.
    p = sub.add_parser(
        "quickstart",
        help="run the quick-start tutorial flow (experiments/quickstart.py; its options: "
        "ariel quickstart --help)",
        add_help=False,
    )
    p.set_defaults(func=_cmd_quickstart, rest=[])
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if getattr(args, "func", None) is _cmd_quickstart:
        args.rest = unknown  # the quick-start script's own options, in their order
    elif unknown:
        parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args))
    except ArielError as exc:  # bad input, a broken plugin, a run folder in use: one line
        return _fail_with(exc)
    except Exception as exc:  # `import mujoco` failing in its OpenGL backend (MUJOCO_GL): one line
        from ariel.utils import gl_backend_error

        error = gl_backend_error(exc)
        if error is None:
            raise
        return _fail_with(error)
