"""The command-line reference, written from `ariel.cli.build_parser()` at every build so that
it cannot drift from what ``ariel <command> --help`` says."""

from __future__ import annotations

import argparse
import os

INTRO = """# Command-line reference

Every `ariel` command and option, generated from the command line's own parser when the site
is built (so it says exactly what `ariel <command> --help` says). Bad input to any command is
one line naming what is wrong and what is allowed, with exit code 2.
"""


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _argument(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    names = ", ".join(f"`{name}`" for name in action.option_strings)
    if action.nargs == 0:
        return names
    metavar = action.metavar or action.dest.upper()
    if isinstance(metavar, tuple):
        metavar = " ".join(metavar)
    return f"{names} `{metavar}`"


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.ArgumentParser, str]]:
    """(name, parser, one-line help from the command list) of each sub-command."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help or "" for choice in action._choices_actions}
            found.extend((name, sub, helps.get(name, "")) for name, sub in action.choices.items())
    return found


def _section(
    parser: argparse.ArgumentParser, command: str, level: int, out: list[str], summary: str = ""
) -> None:
    out += [f"{'#' * level} `{command}`", ""]
    text = parser.description or (summary[:1].upper() + summary[1:] + "." if summary else "")
    if text:
        out += [text.strip(), ""]
    out += ["```text", parser.format_usage().strip(), "```", ""]
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        if action.help == argparse.SUPPRESS:
            continue
        helptext = formatter._expand_help(action) if action.help else ""
        rows.append(f"| {_argument(action)} | {_cell(helptext)} |")
    if rows:
        out += ["| Argument | Meaning |", "| --- | --- |", *rows, ""]
    if parser.epilog:
        out += [parser.epilog.strip(), ""]
    for name, sub, summary in _subcommands(parser):
        _section(sub, f"{command} {name}", min(level + 1, 4), out, summary)


def markdown() -> str:
    """The page: the top-level options, then one section per command (and sub-command)."""
    from ariel.cli import build_parser

    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps usage lines to the terminal's width
    try:
        out = [INTRO]
        _section(build_parser(), "ariel", 2, out)
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(out)
