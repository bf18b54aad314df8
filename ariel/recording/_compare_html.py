"""The written forms of a comparison: the statistics as Markdown, and one self-contained HTML
page (figures embedded as base64 PNG data, no file beside it needed) to mail to a colleague."""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path
from typing import Any

from ariel.recording._compare_stats import ALPHA

__all__ = ["STATS_COLUMNS", "format_stats", "write_html", "write_markdown"]

#: Column -> heading of the statistics table (Markdown, HTML, the printed table).
STATS_COLUMNS = {
    "a": "A",
    "b": "B",
    "n_a": "n A",
    "n_b": "n B",
    "median_a": "median A",
    "median_b": "median B",
    "difference": "A - B",
    "ci": "95 % CI",
    "p_holm": "p (Holm)",
    "a12": "A12",
    "effect": "effect",
    "better": "better",
}


def _number(value: Any) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def format_stats(stats: Any) -> list[list[str]]:
    """The statistics table as rows of text (the columns of `STATS_COLUMNS`)."""
    rows = []
    for row in stats.to_dict("records"):
        row["ci"] = f"[{_number(row['ci_low'])}, {_number(row['ci_high'])}]"
        rows.append([_number(row[key]) for key in STATS_COLUMNS])
    return rows


def _note(comparison: Any) -> str:
    direction = "higher" if comparison.maximise else "lower"
    return (
        f"Fitness: {comparison.fitness_fn} ({direction} is better). Final best = the best "
        "finished evaluation of a run. A12 = P(a run of A beats a run of B), ties half; 0.5 = "
        f"no effect. p: two-sided Mann-Whitney U, Holm-corrected over all pairs; better: the "
        f"better condition where p (Holm) < {ALPHA:g}. CIs: 95 % percentile bootstrap."
    )


def write_markdown(comparison: Any, path: Path) -> Path:
    head = list(STATS_COLUMNS.values())
    lines = [
        f"# {comparison.title}",
        "",
        _note(comparison),
        "",
        "| " + " | ".join(head) + " |",
        "|" + "|".join("---" for _ in head) + "|",
    ]
    lines += ["| " + " | ".join(row) + " |" for row in format_stats(comparison.stats)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _table(head: list[str], rows: list[list[str]]) -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><thead><tr>{cells}</tr></thead><tbody>{body}</tbody></table>"


def _image(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, td:nth-child(2) { text-align: left; }
img { max-width: 100%; display: block; margin: 1em 0; }
p.note { color: #555; font-size: 0.9em; }
"""

_SECTIONS = {
    "best_so_far": "Best fitness so far against evaluations",
    "final_best": "Final best fitness per condition",
    "morphology": "Morphology over evaluations",
}


def write_html(comparison: Any, path: Path) -> Path:
    """One page: the note, the figures (embedded), the statistics and the runs."""
    parts = [
        "<!doctype html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(comparison.title)}: comparison</title>",
        f"<style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(comparison.title)}</h1>",
        f'<p class="note">{html.escape(_note(comparison))}</p>',
        "<h2>Pairwise statistics</h2>",
        _table(list(STATS_COLUMNS.values()), format_stats(comparison.stats)),
    ]
    for name, figure in comparison.figures.items():
        parts += [f"<h2>{html.escape(_SECTIONS.get(name, name))}</h2>", _image(figure, name)]
    runs = [
        [r["condition"], str(r["seed"]), str(r["evaluations"]), _number(r["final_best"])]
        for r in comparison.runs.to_dict("records")
    ]
    parts += [
        "<h2>Runs</h2>",
        _table(["condition", "seed", "evaluations", "final best"], runs),
        "</body></html>",
    ]
    path.write_text("\n".join(parts) + "\n", encoding="utf-8")
    return path
