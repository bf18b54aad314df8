"""Where `compare` writes and what: the output folder checked before anything is written
(`prepare_folder`: no link, nothing a comparison did not write), a new folder's name
(`new_folder`), and the figures, CSV tables, ``stats.md``, ``README.md`` and ``compare.html``
written into it (`_write`), an earlier comparison's other files removed.
"""

from __future__ import annotations

import datetime
import os
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ariel import utils
from ariel.recording.analysis import _compare_lineage as lineages, _compare_plots as plots
from ariel.recording.analysis._compare_design import CompareError
from ariel.recording.analysis._compare_html import write_html, write_markdown, write_readme
from ariel.recording.analysis._compare_measures import _best_curves, _samples
from ariel.recording.analysis._compare_runs import RunCurve
from ariel.recording.store import (
    LOCK_NAME,
    RunLock,
    UnsafePathError,
    atomic_write,
    csv_safe,
    figure_label,
    fitness_label,
    records_folder_of,
    remove_temporaries,
    written_path,
)

if TYPE_CHECKING:
    from ariel.recording.analysis._compare import Comparison

__all__ = ["FILES", "new_folder", "prepare_folder", "shown_path"]

#: Every file a comparison may write into its folder.
FILES = (
    "best_so_far.png",
    "final_best.png",
    "morphology.png",
    "lineages.png",
    "stats.csv",
    "summary.csv",
    "omnibus.csv",
    "runs.csv",
    "stats.md",
    "README.md",
    "compare.html",
)


def _is_ours(path: Path) -> bool:
    """A file a comparison writes (or the temporary of one a killed comparison left, or the
    lock of one writing)."""
    name = written_path(path)
    return path.name in (*FILES, LOCK_NAME) or (name is not None and name.name in FILES)


def _check_parents(out: Path) -> None:
    """Refuse (`CompareError`) an ``out`` that cannot be made because the nearest of its
    parents that is there is no folder: a file (``--out notes.txt/cmp``) or a link to
    nothing (``--out dangling/cmp``)."""
    for parent in out.parents:
        if not os.path.lexists(parent):
            continue
        if parent.is_dir():  # a link to a folder included: the path the user named
            return
        if parent.is_symlink():
            raise CompareError(
                f"cannot make {str(out)!r}: {str(parent)!r} is a symbolic link to "
                f"{os.readlink(parent)!r}, which does not exist; name a folder with --out DIR"
            )
        raise CompareError(
            f"cannot make {str(out)!r}: {str(parent)!r} is a file, not a folder; name a "
            "folder with --out DIR"
        )


def prepare_folder(out: Path) -> bool:
    """Check that ``out`` can take a comparison; True where it holds an earlier one (to be
    replaced). A link is refused (`UnsafePathError`: nothing is written through it), and so
    are a file, a folder holding anything a comparison did not write and a folder that
    cannot be made (a parent that is a file or a link to nothing), and a place inside a run
    folder, which only the run's own commands write (`CompareError`; a campaign's
    ``compare/`` is its comparison's place)."""
    records = records_folder_of(out)
    if records is not None and os.path.lexists(records / "run.json"):
        raise CompareError(
            f"{str(out)!r} is inside the run folder {str(records)!r}, whose records are never "
            "written among: name a folder outside it with --out DIR"
        )
    if out.is_symlink():
        missing = "" if out.exists() else ", which does not exist"
        raise UnsafePathError(
            f"refusing to write the comparison into {str(out)!r}: it is a symbolic link (to "
            f"{os.readlink(out)!r}{missing}); remove the link or name another folder with "
            "--out DIR"
        )
    if not out.exists():
        _check_parents(out)
        return False
    if not out.is_dir():
        what = "a file, not a folder" if out.is_file() else "not a folder"
        raise CompareError(f"{str(out)!r} is {what}: name a folder with --out DIR")
    entries = sorted(out.iterdir())
    foreign = [p.name for p in entries if not _is_ours(p) or (p.is_dir() and not p.is_symlink())]
    if foreign:
        raise CompareError(
            f"{str(out)!r} holds files a comparison does not write ({foreign[0]!r}"
            f"{f' and {len(foreign) - 1} more' if len(foreign) > 1 else ''}): name a new folder "
            "with --out DIR"
        )
    return bool(entries)


def _write(comparison: Comparison, grouped: dict[str, list[RunCurve]], out: Path) -> None:
    """The figures, tables and pages of ``comparison`` into ``out`` (`prepare_folder`); an
    earlier comparison's files that this one does not write are removed."""
    prepare_folder(out)
    # One comparison at a time in a folder: two writing at once left a mix of both.
    with RunLock(out, create=True, kind="comparison"):
        # Under the lock no other comparison writes here: a temporary is a killed one's.
        list(remove_temporaries(out, deep=False))
        comparison.replaced = any(p.name != LOCK_NAME for p in out.iterdir())
        _write_files(comparison, grouped, out)


def _write_files(comparison: Comparison, grouped: dict[str, list[RunCurve]], out: Path) -> None:

    def csv(frame: pd.DataFrame, name: str) -> None:
        atomic_write(out / name, lambda temporary: csv_safe(frame).to_csv(temporary, index=False))

    ylabel = figure_label(  # the runs' config's name: any text
        fitness_label(comparison.fitness_fn, comparison.maximise, what="best fitness")
    )
    finals = {name: s.values for name, s in _samples(comparison.runs, "final_best").items()}
    best = _best_curves(grouped, comparison.maximise, comparison.budget)
    comparison.figures = {
        "best_so_far": plots.best_so_far_figure(best, out / "best_so_far.png", ylabel=ylabel),
        "final_best": plots.final_best_figure(finals, out / "final_best.png", ylabel=ylabel),
    }
    morphology = plots.morphology_series(grouped)
    if morphology:
        comparison.figures["morphology"] = plots.morphology_figure(
            morphology, out / "morphology.png"
        )
    comparison.figures.update(lineages.figure(grouped, comparison.budget, out))
    csv(comparison.stats, "stats.csv")
    csv(comparison.summary, "summary.csv")
    if len(comparison.omnibus):
        csv(pd.DataFrame(comparison.omnibus), "omnibus.csv")
    csv(comparison.runs, "runs.csv")
    write_markdown(comparison, out / "stats.md")
    comparison.readme = write_readme(comparison, out / "README.md")
    comparison.html = write_html(comparison, out / "compare.html")
    written = {p.name for p in comparison.figures.values()} | {
        "stats.csv",
        "summary.csv",
        "runs.csv",
        "stats.md",
        "README.md",
        "compare.html",
        *(["omnibus.csv"] if len(comparison.omnibus) else []),
    }
    for name in set(FILES) - written:  # an earlier comparison's, not this one's
        (out / name).unlink(missing_ok=True)  # a link is removed, not followed


def new_folder(parent: Path, prefix: str) -> Path:
    """``parent/<prefix>-<date>-<time>`` (``-2``, ``-3``, ... added where that exists), made
    now and by this call only (`ariel.utils.new_folder`: two comparisons started in one second
    named one folder, and the second stopped as in use). ``parent`` ``.`` gives a relative
    path."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path(os.path.normpath(utils.new_folder(parent, f"{prefix}-{stamp}")))


def shown_path(path: str | Path) -> str:
    """``path`` relative to the current directory where it lies in it, else as it is."""
    try:
        relative = Path(os.path.abspath(path)).relative_to(Path.cwd())
    except ValueError:
        return str(path)
    return str(relative) if str(relative) != "." else "."
