"""Names from a folder, escaped for where they are written.

A campaign id, a condition name, a run id, a path or a config value comes from a folder that
may come from anywhere, and reaches text a person reads: Markdown, HTML, CSV, a figure, the
terminal. Each medium gets its own escape, so that a name stays a name there: it cannot start
a new line (a newline in a campaign id must not put a command on a line of its own), be
markup (``<script>``, rich's ``[/bold]``, matplotlib's ``$...$``), a spreadsheet formula
(``=HYPERLINK(...)``) or a terminal control sequence (``ESC[2J``).
"""

from __future__ import annotations

import html
import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "csv_safe",
    "figure_label",
    "html_text",
    "markdown_cell",
    "markdown_code",
    "markdown_text",
    "one_line",
    "short_ascii",
    "terminal_text",
]


def one_line(text: object) -> str:
    """``text`` with every character that is not printable (line breaks, tabs, ESC and the
    other control characters, bidirectional overrides, ...) written as its Python escape
    (``\\n``, ``\\x1b``, ``\\u202e``): one line, shown as it is."""
    text = str(text)
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def short_ascii(value: object, limit: int = 60) -> str:
    """A value read from a folder, for a one-line error: ``ascii(value)`` (no control or
    non-ASCII characters), cut to ``limit`` characters."""
    text = ascii(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."


def terminal_text(text: object) -> str:
    """For the terminal (`print`): `one_line`, so no control sequence reaches it. (Text for
    rich goes through ``rich.text.Text``, which reads no markup.)"""
    return one_line(text)


_MARKDOWN = str.maketrans(
    {
        "&": "&amp;",  # no character reference
        ">": "&gt;",
        "\\": "\\\\",
        "`": "\\`",  # no code span
    }
)
#: A ``<`` that could open a tag, a comment or an autolink (anything but ``< `` can).
_TAG_OPEN = re.compile(r"<(?! )")


def markdown_text(text: object) -> str:
    """For Markdown text (a heading, a list item): one line; no raw HTML (``&``, ``>`` and
    every ``<`` that could open a tag escaped as entities: ``p < 0.05`` stays as it is), no
    inline link or image (``](`` escaped: both need it; ``[95 % CI]`` alone is text) and no
    code span."""
    escaped = _TAG_OPEN.sub("&lt;", one_line(text).translate(_MARKDOWN))
    return escaped.replace("](", "\\](")


def markdown_cell(text: object) -> str:
    """For a Markdown table cell: `markdown_text`, and ``|`` does not end the cell."""
    return markdown_text(text).replace("|", "\\|")


def markdown_code(text: object) -> str:
    """A Markdown code span of ``text`` (one line; fenced by more backticks than it holds)."""
    text = one_line(text)
    longest, run = 0, 0
    for c in text:
        run = run + 1 if c == "`" else 0
        longest = max(longest, run)
    fence = "`" * (longest + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def html_text(text: object) -> str:
    """For HTML text and attribute values: one line, ``& < > " '`` escaped."""
    return html.escape(one_line(text))


def figure_label(text: object) -> str:
    """For matplotlib text (a legend entry, a tick label, a title): one line, and ``$`` is a
    dollar sign, not the start of mathtext (``$\\frac{$`` would fail to draw)."""
    return one_line(text).replace("$", r"\$")


#: What a spreadsheet reads as the start of a formula (OWASP's "CSV injection").
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def _cell(value: object) -> object:
    if not isinstance(value, str):
        return value
    # `cat runs.csv`: no ESC from a folder's name reaches a terminal; a line break or a tab
    # stays data (a tab-led cell is quoted as a formula below)
    if not value.isprintable():
        value = "".join(c if c.isprintable() or c in "\n\t" else one_line(c) for c in value)
    if value.startswith(FORMULA_STARTS) and not _plain(value):
        return "'" + value
    return value


def _plain(text: str) -> bool:
    """Whether ``text`` is a sign alone (a table's "no value": ``-``) or a number written as
    text (``-0.5``): what no spreadsheet evaluates, kept as it is for pandas readers."""
    if text in ("-", "+"):
        return True
    try:
        float(text)
    except ValueError:
        return False
    return text == text.strip()  # " -1" and "-1\n" are not what float() makes them


def csv_safe(frame: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``frame`` whose text cells that a spreadsheet would read as a formula start
    with ``'`` (numbers are left alone: ``-0.5`` stays a number), control characters other
    than a line break or a tab (data) written as their escapes (`one_line`)."""
    # Every store module imports this one, and only a CSV of a DataFrame needs pandas:
    # lazy: pandas is slow to import (~0.5 s), which would slow every `load_run`
    from pandas.api.types import is_object_dtype, is_string_dtype

    safe = frame.copy()
    for column in safe.columns:
        if is_object_dtype(safe[column]) or is_string_dtype(safe[column]):
            safe[column] = safe[column].map(_cell)
    return safe
