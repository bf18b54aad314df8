"""The written forms of a comparison: its tables as text (the same for the command, the
notebook, Markdown and HTML), ``stats.md``, ``README.md`` (what was compared, the warnings,
the tables) and one self-contained HTML page (figures embedded as base64 PNG data, no file
beside it needed) to mail to a colleague.

Names from the folders (campaign id, conditions, paths, config values) are escaped for each
medium (`_escape`), and every file is written whole and never through a link
(`_files.atomic_write`)."""

from __future__ import annotations

import base64
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ariel.recording.analysis._compare_design import MEASURES, QD_COLUMNS
from ariel.recording.analysis._compare_lineage import LINEAGE_MEASURES, measures
from ariel.recording.analysis._compare_stats import ALPHA, NOT_DETECTABLE, RowDict
from ariel.recording.store import (
    atomic_write,
    html_text,
    markdown_cell,
    markdown_code,
    markdown_text,
)

if TYPE_CHECKING:
    from ariel.recording.analysis._compare import Comparison

__all__ = [
    "STATS_COLUMNS",
    "format_stats",
    "omnibus_frame",
    "stats_frame",
    "summary_frame",
    "write_html",
    "write_markdown",
    "write_readme",
]

#: The headings of the pairwise table (the command, the notebook, Markdown and HTML); a
#: paired comparison adds `PAIRED_COLUMN` before ``p (Holm)``.
STATS_COLUMNS = (
    "measure",
    "A",
    "B",
    "median A (mean ± sd)",
    "median B (mean ± sd)",
    "A - B [95 % CI]",
    "test",
    "p (Holm)",
    "A12 (n)",
    "effect",
    "better",
)
PAIRED_COLUMN = "A better (pairs)"


def _number(value: object) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def _median_mean_sd(median: float, mean: float, sd: float) -> str:
    return f"{_number(median)} ({_number(mean)} ± {_number(sd)})"


def _a12_with_n(row: RowDict) -> str:
    value = row["a12"]
    shown = "-" if math.isnan(value) else f"{value:.2f}"
    return f"{shown} (n={row['n_a']} vs {row['n_b']})"


def _paired_wins(row: RowDict) -> str:
    pairs, share = row.get("n_pairs"), row.get("paired_wins", math.nan)
    if pairs is None or not pairs or math.isnan(share):
        return "-"
    return f"{share * pairs:g} of {pairs:g}"


def _effect(row: RowDict, paired: bool) -> str:
    """The effect's size; in a paired design with the number it sizes (A's share of the
    signed ranks), which A12 is not."""
    share = row.get("effect_size", math.nan)
    if not paired or row["effect"] == NOT_DETECTABLE or not isinstance(share, float):
        return row["effect"]
    return row["effect"] if math.isnan(share) else f"{row['effect']} (ranks {share:.2f})"


def _test(row: RowDict) -> str:
    pairs = row.get("n_pairs")
    return f"{row['test']}, {pairs} pairs" if pairs is not None else row["test"]


def format_stats(stats: pd.DataFrame, *, paired: bool = False) -> list[list[str]]:
    """The pairwise table as rows of text (`STATS_COLUMNS`; ``paired``: with `PAIRED_COLUMN`)."""
    rows = []
    for row in stats.to_dict("records"):
        cells = [
            row["measure"],
            row["a"],
            row["b"],
            _median_mean_sd(row["median_a"], row["mean_a"], row["sd_a"]),
            _median_mean_sd(row["median_b"], row["mean_b"], row["sd_b"]),
            f"{_number(row['difference'])} [{_number(row['ci_low'])}, {_number(row['ci_high'])}]",
            _test(row),
            _number(row["p_holm"]),
            _a12_with_n(row),
            _effect(row, paired),
            row["better"],
        ]
        if paired:
            cells.insert(STATS_COLUMNS.index("p (Holm)"), _paired_wins(row))
        rows.append(cells)
    return rows


def _stats_head(paired: bool) -> list[str]:
    head: list[str] = list(STATS_COLUMNS)
    if paired:
        head.insert(head.index("p (Holm)"), PAIRED_COLUMN)
    return head


def stats_frame(comparison: Comparison) -> pd.DataFrame:
    """The pairwise table as text, one row per measure and pair (what the command prints)."""
    paired = comparison.tests.paired
    return pd.DataFrame(format_stats(comparison.stats, paired=paired), columns=_stats_head(paired))


def _measure_rows(records: list[RowDict], measure: str, column: str) -> list[tuple[str, list[str]]]:
    """A measure's rows of the summary: its median, and its mean ± sd, per condition."""
    return [
        (f"{measure}: median", [_number(r[f"{column}_median"]) for r in records]),
        (
            f"{measure}: mean ± sd",
            [f"{_number(r[f'{column}_mean'])} ± {_number(r[f'{column}_sd'])}" for r in records],
        ),
    ]


def _summary_rows(summary: pd.DataFrame) -> list[tuple[str, list[str]]]:
    records = summary.to_dict("records")
    rows = [("runs", [str(r["runs"]) for r in records])]
    for measure, column in MEASURES.items():
        rows += _measure_rows(records, measure, column)
    for column in QD_COLUMNS:
        if f"{column}_median" in summary:
            rows.append((f"{column}: median", [_number(r[f"{column}_median"]) for r in records]))
    for measure, column in LINEAGE_MEASURES.items():
        if f"{column}_median" in summary:
            rows += _measure_rows(records, measure, column)
    return rows


def summary_frame(comparison: Comparison) -> pd.DataFrame:
    """Per condition (a column each): runs, median and mean ± sd of each measure, the
    median of the QD columns where the runs have them, and median and mean ± sd of each
    lineage measure where a run has a lineage."""
    names = comparison.summary["condition"].tolist()
    rows = [[label, *cells] for label, cells in _summary_rows(comparison.summary)]
    return pd.DataFrame(rows, columns=["", *names])


OMNIBUS_COLUMNS = ("measure", "test", "conditions", "n", "statistic", "p", "smallest p possible")


def omnibus_frame(comparison: Comparison) -> pd.DataFrame:
    """The omnibus test per measure (more than two conditions; else no rows)."""
    rows = [
        [
            row["measure"],
            row["test"],
            str(row["k"]),
            f"{row['n']} {'seeds' if row['test'] == 'Friedman' else 'runs'}",
            _number(row["statistic"]),
            _number(row["p_value"]),
            _number(row["min_p"]),
        ]
        for row in comparison.omnibus.to_dict("records")
    ]
    return pd.DataFrame(rows, columns=list(OMNIBUS_COLUMNS))


def _note(comparison: Comparison, escape: Callable[[object], str] = str) -> str:
    """What the tables mean; ``escape``: the medium's escape of the fitness function's name
    (from the runs' configs; the rest is ours)."""
    direction = "higher" if comparison.maximise else "lower"
    n = f"{comparison.budget:,}"
    return (
        f"Fitness: {escape(comparison.fitness_fn)} ({direction} is better). Every run is "
        f"compared at {n} evaluations: final best = its best fitness after them; AUC = the mean "
        f"of its best fitness so far over evaluations 1..{n} (the area under the best-so-far "
        "curve / N; before a run's first finished evaluation, the worst fitness of the runs "
        f"compared; in the fitness's unit, {direction} is better too). A12 = P(a run of A "
        "beats a run of B), ties half; 0.5 = no effect; n: runs per condition. Tests: "
        f"{comparison.tests.describe()}. better: the condition the test finds better where "
        f"p (Holm) < {ALPHA:g}. An effect is labelled (small, medium, large) only where the "
        f"test could reach p (Holm) < {ALPHA:g} with these n"
        + (_PAIRED_NOTE if comparison.tests.paired else ". CIs: 95 % percentile bootstrap.")
        + (_LINEAGE_NOTE.format(n=n) if _has_lineage(comparison) else "")
    )


_PAIRED_NOTE = (
    "; in this paired design it sizes the Wilcoxon test's own effect, A's share of the "
    "signed ranks (ranks: 0.5 = no lean, 1 = A better on every seed that differs), with "
    "A12's limits. A - B and its CI (95 % percentile bootstrap, resampling seeds) are on the "
    "seeds both conditions have."
)
_LINEAGE_NOTE = (
    " Lineage (co-evolution runs), after the last generation within the {n} evaluations: "
    "surviving lineages = the founders (bodies of a random genotype) with a descendant in "
    "the population; best depth = parent steps from that population's best body back to a "
    "founder; distinct bodies = the different morphologies (robot graphs) the run made up "
    "to then. Neither direction is better: for these, A12 = P(a run of A has the higher "
    "value), and better names the higher condition (higher: A)."
)


def _has_lineage(comparison: Comparison) -> bool:
    return comparison.runs is not None and bool(measures(comparison.runs))


# --------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------


def _write_text(path: Path, text: str) -> Path:
    # Whole, and never through a link (``compare/stats.md -> ~/.bashrc`` is replaced).
    atomic_write(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))
    return path


def _markdown_table(frame: pd.DataFrame) -> list[str]:
    head = [markdown_cell(c) for c in frame.columns]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += [
        "| " + " | ".join(markdown_cell(c) for c in row) + " |" for row in frame.itertuples(False)
    ]
    return [*lines, ""]


def _markdown_tables(comparison: Comparison) -> list[str]:
    lines = ["## Per condition", "", *_markdown_table(comparison.summary_table())]
    lines += ["## Pairs of conditions", "", *_markdown_table(comparison.table())]
    if len(comparison.omnibus):
        lines += ["## All conditions", "", *_markdown_table(comparison.omnibus_table())]
    return lines


def write_markdown(comparison: Comparison, path: Path) -> Path:
    """``stats.md``: the note and the tables."""
    lines = [
        f"# {markdown_text(comparison.title)}",
        "",
        _note(comparison, markdown_text),
        "",
        *_markdown_tables(comparison),
    ]
    return _write_text(path, "\n".join(lines))


_SECTIONS = {
    "best_so_far": "Best fitness so far against evaluations",
    "final_best": "Final best fitness per condition",
    "morphology": "Morphology over evaluations",
    "lineages": "Lineages over evaluations",
}


def write_readme(comparison: Comparison, path: Path) -> Path:
    """``README.md``: what was compared, the warnings, the tables and the figures."""
    lines = [f"# {markdown_text(comparison.title)}: comparison", "", "## What was compared", ""]
    lines += [f"- **{label}**: {markdown_text(text)}" for label, text in comparison.about]
    if comparison.notes:
        notes = [f"- {markdown_text(note)}" for note in comparison.notes]
        lines += ["", "## Warnings", "", *notes]
    lines += ["", _note(comparison, markdown_text), "", *_markdown_tables(comparison)]
    for name, figure in comparison.figures.items():
        lines += [f"## {_SECTIONS.get(name, name)}", "", f"![{name}]({figure.name})", ""]
    if comparison.settings:
        lines += ["## Settings every run shares", ""]
        lines += [
            f"- {markdown_code(key)} = {markdown_code(value)}"
            for key, value in comparison.settings.items()
        ]
        lines.append("")
    lines += ["Each run's values: `runs.csv`; the tables as numbers: `stats.csv`, `summary.csv`."]
    return _write_text(path, "\n".join(lines) + "\n")


# --------------------------------------------------------------------------------------------
# HTML
# --------------------------------------------------------------------------------------------


def _table(head: list[str], rows: list[list[str]]) -> str:
    cells = "".join(f"<th>{html_text(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html_text(c)}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><thead><tr>{cells}</tr></thead><tbody>{body}</tbody></table>"


def _frame_table(frame: pd.DataFrame) -> str:
    return _table(
        [str(c) for c in frame.columns], [[str(c) for c in r] for r in frame.itertuples(False)]
    )


def _image(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{html_text(alt)}" src="data:image/png;base64,{data}">'


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, td:nth-child(2) { text-align: left; }
table.about td { text-align: left; }
img { max-width: 100%; display: block; margin: 1em 0; }
p.note { color: #555; font-size: 0.9em; }
ul.warnings { background: #fff6e0; border-left: 4px solid #e0a000; padding: 0.6em 2em; }
"""


def _about(comparison: Comparison) -> list[str]:
    parts = [
        "<h2>What was compared</h2>",
        '<table class="about"><tbody>'
        + "".join(
            f"<tr><th>{html_text(label)}</th><td>{html_text(text)}</td></tr>"
            for label, text in comparison.about
        )
        + "</tbody></table>",
    ]
    if comparison.settings:
        rows = [[key, value] for key, value in comparison.settings.items()]
        parts += [
            "<details><summary>Settings every run shares</summary>",
            _table(["key", "value"], rows),
            "</details>",
        ]
    if comparison.notes:
        items = "".join(f"<li>{html_text(note)}</li>" for note in comparison.notes)
        parts += ["<h2>Warnings</h2>", f'<ul class="warnings">{items}</ul>']
    return parts


def write_html(comparison: Comparison, path: Path) -> Path:
    """One page: what was compared, the warnings, the note, the tables, the figures
    (embedded) and the runs."""
    parts = [
        "<!doctype html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html_text(comparison.title)}: comparison</title>",
        f"<style>{_STYLE}</style></head><body>",
        f"<h1>{html_text(comparison.title)}</h1>",
        *_about(comparison),
        f'<p class="note">{html_text(_note(comparison))}</p>',
        "<h2>Per condition</h2>",
        _frame_table(comparison.summary_table()),
        "<h2>Pairs of conditions</h2>",
        _frame_table(comparison.table()),
    ]
    if len(comparison.omnibus):
        parts += ["<h2>All conditions</h2>", _frame_table(comparison.omnibus_table())]
    for name, figure in comparison.figures.items():
        parts += [f"<h2>{html_text(_SECTIONS.get(name, name))}</h2>", _image(figure, name)]
    runs = [
        [
            r["condition"],
            str(r["seed"]),
            f"{r['evaluations']:,}",
            _number(r["final_best"]),
            _number(r["auc"]),
        ]
        for r in comparison.runs.to_dict("records")
    ]
    parts += [
        "<h2>Runs</h2>",
        _table(["condition", "seed", "evaluations", "final best", "AUC"], runs),
        "</body></html>",
    ]
    return _write_text(path, "\n".join(parts) + "\n")
