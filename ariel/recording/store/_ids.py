"""The shapes of the ids a run folder holds, checked where an id leaves the folder.

A body id is ``b<body number>`` (``b000052``, `BODY_ID`), an evaluation id
``b<body number>-i<iteration>-c<candidate>`` (``b000052-i005-c002``, `EVAL_ID`,
`ariel.evolution._bodies`): ASCII digits only (``\\d`` would take ``b٠٠٠٠٠٣`` for body 3), 6 to
`MOST_DIGITS` of them for a body (a run makes millions of bodies at most), 3 to `MOST_DIGITS`
for an iteration and a candidate: a longer number (a crafted id of 4,301 digits, which
``int()`` refuses) is refused in one line like any other crafted id. A run id is
``<experiment name>-<date>-<time>-s<seed>``
(``coevolve_flat-20261126-101500-s1``), the name of the folder ``ariel run --out`` made, or
``<campaign id>-<condition>-s<seed>``: letters, digits, spaces and ``. _ - + @ = , : ~ ( ) [ ]
{ } # % ! '`` (an apostrophe: ``--out "it's"``; no id is ever put into code), not starting with
a space, at most 600 characters (a campaign id, the name of its folder, is at most 255; a
condition at most 245). A campaign id is made of the same characters,
at most 255 of them. Nothing else (no double quote, backslash, slash, newline or other control
character) can be one; a folder holding another is crafted, and refused in one line
(`DamagedRunError`) when its run.json or campaign.json is read, before the id is shown or
written anywhere.
"""

from __future__ import annotations

import re
from pathlib import Path

from ariel.errors import ConfigError, DamagedRunError

__all__ = [
    "BODY_ID",
    "CAMPAIGN_ID",
    "EVAL_ID",
    "MOST_DIGITS",
    "RUN_ID",
    "RUN_ID_RULE",
    "check_body_id",
    "check_eval_id",
    "check_new_id",
    "check_run_id",
]

#: The most digits of a number in a body or evaluation id.
MOST_DIGITS = 12
#: A body id; its number is group 1.
BODY_ID = re.compile(rf"b([0-9]{{6,{MOST_DIGITS}}})")
EVAL_ID = re.compile(rf"{BODY_ID.pattern}-i[0-9]{{3,{MOST_DIGITS}}}-c[0-9]{{3,{MOST_DIGITS}}}")
_RUN_ID_CHARS = r"\w.+@=,:~()\[\]{}#%!'-"
RUN_ID = re.compile(rf"[{_RUN_ID_CHARS}][ {_RUN_ID_CHARS}]{{0,599}}")
CAMPAIGN_ID = re.compile(rf"[{_RUN_ID_CHARS}][ {_RUN_ID_CHARS}]{{0,254}}")
#: What a run or campaign id may hold, for a one-line error.
RUN_ID_RULE = "letters, digits, spaces and . _ - + @ = , : ~ ( ) [ ] { } # % ! '"
_SHOWN = 60


def _shown(value: object) -> str:
    """``value`` as one line: its repr (escapes control characters), cut to `_SHOWN`."""
    text = repr(value)
    return text if len(text) <= _SHOWN else f"{text[: _SHOWN - 20]}...({len(str(value))} chars)"


def _checked(value: object, where: str | Path, pattern: re.Pattern[str], what: str) -> str:
    """``value`` where ``pattern`` matches all of it; else `DamagedRunError` naming ``where``
    and what ids of ``what`` ("body", "evaluation") look like."""
    if isinstance(value, str) and pattern.fullmatch(value):
        return value
    article, example = ("a", "b000012") if what == "body" else ("an", "b000012-i003-c005")
    raise DamagedRunError(
        f"{str(where)!r} holds {article} {what} id that is not one: {_shown(value)} ({what} "
        f"ids look like {example}); the folder was changed by hand or crafted: refused"
    )


def check_eval_id(value: object, where: str | Path) -> str:
    """``value`` where it is an evaluation id (`EVAL_ID`); else `DamagedRunError` naming
    ``where`` (the run or export folder)."""
    return _checked(value, where, EVAL_ID, "evaluation")


def check_body_id(value: object, where: str | Path) -> str:
    """``value`` where it is a body id (`BODY_ID`); else `DamagedRunError` naming ``where``."""
    return _checked(value, where, BODY_ID, "body")


def check_run_id(value: object, where: str | Path) -> str:
    """``value`` where it is a run id (`RUN_ID`); else `DamagedRunError` naming ``where``."""
    if isinstance(value, str) and RUN_ID.fullmatch(value):
        return value
    raise DamagedRunError(
        f"{str(where)!r} holds a run id that is not one: {_shown(value)} (run ids look like "
        "coevolve_flat-20261126-101500-s1); the folder was changed by hand or crafted: refused"
    )


def check_new_id(value: str, *, campaign: bool = False) -> str:
    """A new run's (``campaign``: campaign's) id, e.g. the name of the folder ``--out`` names:
    `ConfigError` in one line where it is not one (`RUN_ID`, `CAMPAIGN_ID`), before anything
    is written: the folder could not be read back (its id is checked on every read)."""
    pattern, most, what = (CAMPAIGN_ID, 255, "campaign") if campaign else (RUN_ID, 600, "run")
    if pattern.fullmatch(value):
        return value
    raise ConfigError(
        f"{what} id {_shown(value)} (the name of the {what} folder) cannot be one{_why(value)}: "
        f"a {what} id is {RUN_ID_RULE}, not starting with a space, at most {most} characters; "
        "choose another --out"
    )


def _why(value: str) -> str:
    """`` (it holds 'x', U+0301)``: the first character no id may hold (an accent written as
    a combining mark looks like a letter), or "" when it is the length or a leading space."""
    bad = next((c for c in value if not re.fullmatch(rf"[ {_RUN_ID_CHARS}]", c)), None)
    return "" if bad is None else f" (it holds {bad!r}, U+{ord(bad):04X})"
