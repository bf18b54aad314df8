"""Tables printed with rich: `ariel campaign status` and `ariel compare`'s tables.

Imported by those commands when they print (rich takes ~0.2 s to import, and every `ariel`
command imports the modules that define the commands). Names from the folders are shown as
text: one line, no control sequence, no rich markup (`terminal_text`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.table import Table
from rich.text import Text

from ariel.recording.store import terminal_text

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["print_campaign_status", "print_frame"]


def shown(value: object) -> Text:
    """``value`` as rich text from a folder: no rich markup, no control sequence."""
    return Text(terminal_text(value))


def print_campaign_status(rows: Iterable[dict[str, Any]], title: str) -> None:
    """`ariel campaign status`: one row per run of the campaign (`runs.campaign_status`)."""
    table = Table(title=shown(title))
    for name, justify in (
        ("condition", "left"),
        ("seed", "right"),
        ("status", "left"),
        ("generations", "right"),
        ("evaluations", "right"),
        ("best", "right"),
    ):
        # folded, not cut: "variant_A" and "variant_B" of one long name read the same cut
        table.add_column(name, justify=justify, overflow="fold")  # type: ignore[arg-type]
    for row in rows:
        best = row["best_fitness"]
        table.add_row(
            shown(row["condition"]),
            shown(row["seed"]),
            shown(row["status"]),
            shown(f"{row['generations_done']}/{row['generations']}"),
            shown(row["evaluations"]),
            f"{best:.6g}" if math.isfinite(best) else "-",
        )
    Console(width=max(100, Console().width)).print(table)


def print_frame(frame: pd.DataFrame, title: str) -> None:
    """A table of text (a `Comparison` table), as wide as it needs; a cell too wide for its
    column wraps, never cut short (cut, two conditions named alike read the same: "sigma0…")."""
    table = Table(title=Text(terminal_text(title)))
    for heading in frame.columns:
        table.add_column(Text(terminal_text(heading)), overflow="fold")
    for row in frame.itertuples(index=False):
        table.add_row(*(Text(terminal_text(cell)) for cell in row))
    Console(width=max(160, Console().width)).print(table)
