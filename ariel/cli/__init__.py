"""The ``ariel`` command.

One module per command (``ariel.cli._<command>``): its sub-parser and what it runs. Every call
builds the whole parser, so ``ariel --help`` imports every command module; they reach the
packages that do the work (`ariel.runs`, `ariel.recording` and its parts, `ariel.evolution`)
through those packages' lazy faces (``from ariel import runs``, then ``runs.run_experiment``),
which load a name's module on its first use. So ``ariel --help`` stays instant, a command loads
only what it runs, and a command that renders chooses its GL backend before anything imports
mujoco.

Bad input (an unknown plugin, a bad config key or value, an existing output folder, ...) is
one line on stderr and exit code 2, before anything is written: every error the workbench
raises on purpose is an `ariel.errors.ArielError`, caught here as one class.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import warnings
from collections.abc import Sequence

from ariel import __version__
from ariel.cli._campaign import add_campaign_commands
from ariel.cli._common import (
    DEFAULT_RUNS as DEFAULT_RUNS,
    EXIT_USAGE as EXIT_USAGE,
    Parser,
    fail,
    fail_with,
    path_error,
)
from ariel.cli._config import add_config_commands
from ariel.cli._export import add_export_command
from ariel.cli._gallery import add_gallery_command
from ariel.cli._plugins import add_plugins_command
from ariel.cli._quickstart import add_quickstart_command, cmd_quickstart
from ariel.cli._replay import add_replay_command
from ariel.cli._report import add_report_command
from ariel.cli._run import (
    GENERATIONS_SHOWN as GENERATIONS_SHOWN,
    _how_to_look as _how_to_look,  # the tests check it
    add_resume_command,
    add_run_command,
)
from ariel.cli._runs import add_runs_command
from ariel.cli._streams import (
    cwd_problem,
    lost_output_line,
    open_files_problem,
    standard_output,
)
from ariel.cli._verify import EXIT_DAMAGED as EXIT_DAMAGED, add_verify_command
from ariel.cli._view import add_view_command
from ariel.cli._watch import add_watch_command
from ariel.errors import ArielError
from ariel.utils import gl_backend_error, report_interrupted
from ariel.utils.interrupts import stop_on_signals

#: Each command's (or group of commands') sub-parser, in the order ``ariel --help`` lists them.
COMMANDS = (
    add_run_command,
    add_resume_command,
    add_runs_command,
    add_replay_command,
    add_export_command,
    add_report_command,
    add_verify_command,
    add_plugins_command,
    add_view_command,
    add_campaign_commands,  # campaign, compare
    add_config_commands,
    add_watch_command,
    add_gallery_command,
    add_quickstart_command,
)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="ariel", description="ARIEL workbench: evolve modular robots in MuJoCo.")
    parser.add_argument("--version", action="version", version=f"ariel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    for add_command in COMMANDS:
        add_command(sub)
    _describe(sub)
    return parser


def _describe(sub: argparse._SubParsersAction) -> None:
    """A command without a description paragraph gets its one-line help as one (``ariel runs
    --help`` showed only its usage and options), and so do its own subcommands."""
    for action in sub._choices_actions:
        command = sub.choices[action.dest]
        if not command.description and action.help:
            text = str(action.help)
            command.description = text[0].upper() + text[1:] + "."
        for inner in command._actions:
            if isinstance(inner, argparse._SubParsersAction):
                _describe(inner)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    words = list(sys.argv[1:] if argv is None else argv)
    args, unknown = parser.parse_known_args(words)
    if getattr(args, "func", None) is cmd_quickstart:
        args.rest = unknown  # the quick-start script's own options, in their order
    else:
        command = _command_parser(parser, args)  # its usage error names it and its --help
        if unknown:
            command.error(f"unrecognized arguments: {' '.join(unknown)}")
        empty = _empty_argument(words)
        if empty is not None:
            command.error(empty)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    _expand_home(args)
    problem = cwd_problem() or open_files_problem()
    if problem is not None:
        return fail(problem)
    with standard_output() as output:
        code = _run_command(args)
    if output.lost is not None:
        return fail(lost_output_line(output.lost))
    return code


#: The arguments that name a file or folder (``--label``'s are the RUN_DIR of NAME=RUN_DIR).
_PATH_ARGUMENTS = (
    "config",
    "file",
    "folder",
    "run_dir",
    "campaign_dir",
    "paths",
    "out",
    "save",
    "rrd",
    "video",
    "screenshot",
    "lineage",
)


def _expand_home(args: argparse.Namespace) -> None:
    """A leading ``~`` of a path argument is the home folder, as the Python API reads it: a
    quoted one (``--out "~/x"``) reached some commands as is (a folder named ``~`` made here)
    and others expanded."""

    def home(value: object) -> object:
        return os.path.expanduser(value) if isinstance(value, str) else value

    for name in _PATH_ARGUMENTS:
        if hasattr(args, name):
            value = getattr(args, name)
            setattr(
                args, name, [home(v) for v in value] if isinstance(value, list) else home(value)
            )
    if isinstance(getattr(args, "label", None), list):
        args.label = [(name, home(folder)) for name, folder in args.label]


def _command_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Parser:
    """The parser of the (sub-)command ``args`` chose: ``ariel campaign run``'s, not ``ariel``'s."""
    current = parser
    while True:
        subs = [a for a in current._actions if isinstance(a, argparse._SubParsersAction)]
        chosen = getattr(args, subs[0].dest, None) if subs else None
        if chosen not in (subs[0].choices if subs else {}):
            return current  # type: ignore[return-value]  # every parser here is a Parser
        current = subs[0].choices[chosen]


def _empty_argument(words: list[str]) -> str | None:
    """What an empty argument ('') is, or None: a path given as '' is the current folder to
    the file system (`runs ''` listed it, `gallery --out ''` wrote into it), and a value given
    as '' is a typo (an unset shell variable: ``--out "$DIR"``)."""
    for i, word in enumerate(words):
        flag, equals, value = word.partition("=")
        if word == "" or (word.startswith("--") and equals and not value):
            before = words[i - 1] if word == "" and i and words[i - 1].startswith("-") else None
            named = flag if word else before
            what = f"{named}: an empty value" if named else "an empty argument ('')"
            return f"{what}; give a path or value (an unset shell variable?)"
    return None


def _run_command(args: argparse.Namespace) -> int:
    """The command ``args`` chose; what it raises on purpose as one line (and exit code)."""
    try:
        # Ctrl-C, SIGTERM and SIGHUP stop every command as an exception: its files written so
        # far stay whole and its temporaries are removed (`atomic_write`), in one line.
        with stop_on_signals(), warnings.catch_warnings():
            _quiet_numerics()
            return int(args.func(args))
    except BrokenPipeError:  # `ariel runs | head -3`: the reader has what it wanted
        return _reader_gone()
    except SystemExit as exc:  # rich's tables end a broken pipe in SystemExit(1), not 141
        if exc.code == 1 and isinstance(exc.__context__, BrokenPipeError):
            return _reader_gone()
        raise
    except KeyboardInterrupt as exc:  # a command that has nothing to continue (report, ...)
        if getattr(exc, "signum", None) == signal.SIGPIPE:  # its reader went away (`Output`)
            return _reader_gone()
        return report_interrupted(exc, None)
    except ArielError as exc:  # bad input, a broken plugin, a run folder in use: one line
        return fail_with(exc)
    except OSError as exc:  # a path no file system takes: a name over 255 bytes, a link loop
        message = path_error(exc)
        if message is None:
            raise
        return fail(message)
    except Exception as exc:  # `import mujoco` failing in its OpenGL backend (MUJOCO_GL): one line
        error = gl_backend_error(exc)
        if error is None:
            raise
        return fail_with(error)


def _reader_gone() -> int:
    """Stop quietly, as a command killed by SIGPIPE does (exit code 141): the rest of the
    output goes nowhere, including what Python would flush at exit (which would say
    "Exception ignored ... BrokenPipeError")."""
    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return 128 + signal.SIGPIPE


def _quiet_numerics() -> None:
    """numpy's and matplotlib's "overflow encountered" warnings off: they come only from values
    no run writes (a crafted fitness of 1e308), each two lines on stderr, where the command's
    own note already says what it left out and why."""
    warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"(numpy|matplotlib)\.")
