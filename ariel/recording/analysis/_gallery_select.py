"""Which bodies a gallery shows (`make_gallery`'s ``of``), and where the archive's atlas puts
them.

- ``final``: the population after the last finished generation's selection
  (`population_after_selection`), best first.
- ``elites``: a MAP-Elites run's archive after its last finished generation, best first.
- ``archive``: the same elites, each at its cell in a grid over the archive's first two
  measures (`Atlas`: the first across, the second up, as the report and the viewer draw it).
- ``lineage-of-best``: the run's best body and its ancestors (`lineage`, `ancestors`), oldest
  first.
- a campaign: the best body of each run's final population, in campaign.json's order.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.errors import ArielError, DamagedRunError
from ariel.evolution import DEFAULT_RANGES
from ariel.recording.store import Run, ancestors, archive_cell_count, check_body_id, lineage
from ariel.utils import ariel_line, shell_path, shell_quote

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.store import Campaign, JsonObject

__all__ = [
    "ATLAS_BINS",
    "MOST_SHOWN",
    "OF",
    "Atlas",
    "GalleryError",
    "Pick",
    "archive_atlas",
    "campaign_picks",
    "key_descriptors",
    "open_command",
    "picks",
]

#: What a gallery can show.
OF = ("final", "elites", "archive", "lineage-of-best")
#: The labels' two descriptors where the run has no MAP-Elites measures.
KEY_DESCRIPTORS = ("num_modules", "num_hinges")
#: Bins per measure of an atlas of an archive that is not a grid (a CVT archive).
ATLAS_BINS = 8


class GalleryError(ArielError, ValueError):
    """A gallery that cannot be made (a run without an archive for ``--of archive``): one line."""


@dataclass(frozen=True)
class Pick:
    """A body chosen for a gallery: its run, its bodies-table row (the last), a caption."""

    run: Run
    body: dict[str, Any]
    caption: str = ""
    fitness: float = math.nan


@dataclass(frozen=True)
class Atlas:
    """Where `archive` puts each elite: ``rows`` x ``columns`` cells over two measures, from
    the first to the last row (and column) that holds an elite: the first measure across
    (columns, left to right), the second up (rows, drawn from the bottom up), as the report's
    heatmap and the Rerun viewer draw the archive.

    Attributes:
        measures: the archive's first two measures, in its order: the one across the
            columns, then the one up the rows.
        rows: cells up (bins of the second measure, those from the lowest to the highest
            that hold an elite); row 0 is the lowest.
        columns: cells across (bins of the first measure, likewise); column 0 is the left.
        row_edges: the second measure's bin edges, ``rows + 1`` of them.
        column_edges: the first measure's bin edges, ``columns + 1`` of them.
        cells: the archive's cells (all its measures); ``filled`` of them hold an elite.
        filled: the archive's elites.
        positions: body id -> its (row, column); one elite per position (the best, where
            more measures or a CVT archive put several in one).
        binned: whether the elites were placed by their measures, `ATLAS_BINS` per measure
            (an archive that is not a grid: a CVT's); else by their grid cell.
    """

    measures: tuple[str, str]
    rows: int
    columns: int
    row_edges: tuple[float, ...]
    column_edges: tuple[float, ...]
    cells: int
    filled: int
    positions: dict[str, tuple[int, int]]
    binned: bool = False


def _ordered(frame: pd.DataFrame, maximise: bool) -> pd.DataFrame:
    return frame.sort_values(["fitness", "body_id"], ascending=[not maximise, True])


def _last_rows(run: Run) -> pd.DataFrame:
    return run.bodies.drop_duplicates("body_id", keep="last").set_index("body_id", drop=False)


def _final(run: Run) -> list[Pick]:
    population = run.population
    if not len(population):
        return []
    last = population[population["generation"] == population["generation"].max()]
    return [
        Pick(run, row, fitness=float(row["fitness"]))
        for row in _ordered(last, run.maximise).to_dict("records")
    ]


def _last_archive(run: Run) -> pd.DataFrame:
    """The archive after the last finished generation: empty for a MAP-Elites (or novelty)
    run before its first (as ``final`` shows no population then); `GalleryError` for a run
    that keeps no archive."""
    archive = run.archive
    if not len(archive) and run.generations_done < 1 and _keeps_archive(run):
        return archive  # no elites yet: the gallery says "no finished generation yet"
    if not len(archive):
        raise GalleryError(
            f"run {str(run.path)!r} has no MAP-Elites archive: --of elites and --of archive "
            "show a MAP-Elites run's elites (--of final shows any run's population)"
        )
    return archive[archive["generation"] == archive["generation"].max()]


def _keeps_archive(run: Run) -> bool:
    """Whether run.json describes an archive (a MAP-Elites or novelty run), elites or not."""
    return _recorded_description(run) is not None


def _recorded_description(run: Run) -> object:
    """``run.archive_description``; None where run.json does not describe an archive.
    Damage (what no ariel writes) is raised: one line, as from every reader."""
    try:
        return getattr(run, "archive_description", None)
    except DamagedRunError:
        raise
    except (LookupError, ValueError, TypeError):  # a run.json that does not describe it
        return None


def _elites(run: Run) -> list[Pick]:
    last = _last_archive(run)
    if not len(last):
        return []
    bodies = _last_rows(run)
    archive = _ordered(last, run.maximise)
    return [
        Pick(run, bodies.loc[body_id].to_dict(), fitness=float(fitness))
        for body_id, fitness in zip(archive["body_id"], archive["fitness"], strict=True)
        if body_id in bodies.index
    ]


def _lineage_of_best(run: Run) -> list[Pick]:
    frame = lineage(run)
    scored = frame.loc[frame["fitness"].map(math.isfinite)]
    if not len(scored):
        return []
    best = _ordered(scored, run.maximise).iloc[0]
    chain = {int(best["id"]), *ancestors(frame, int(best["id"]))}
    shown = frame.loc[frame["id"].isin(list(chain))].sort_values(["origin_time", "id"])
    bodies = _last_rows(run)
    return [
        Pick(
            run,
            bodies.loc[body_id].to_dict(),
            caption="best" if body_id == best["body_id"] else f"born {int(born)}",
            fitness=float(fitness),
        )
        for body_id, born, fitness in zip(
            shown["body_id"], shown["origin_time"], shown["fitness"], strict=True
        )
    ]


def _checked(chosen: list[Pick]) -> list[Pick]:
    """``chosen``, whose body ids are body ids (``b000012``); `DamagedRunError`, one line
    naming the run folder, for one that is not (a crafted table's: no such text is drawn)."""
    for pick in chosen:
        check_body_id(pick.body.get("body_id"), pick.run.path)
    return chosen


def picks(run: Run, of: str) -> list[Pick]:
    """The bodies ``of`` shows of ``run``, in order (see the module docstring); a body id
    that is not one is `DamagedRunError`, one line."""
    if of == "final":
        return _checked(_final(run))
    if of in ("elites", "archive"):
        return _checked(_elites(run))
    return _checked(_lineage_of_best(run))


#: The most bodies one gallery shows: 200 thumbnails in rows of 6 make a sheet of about 1,600
#: x 11,000 pixels (18 Mpx, Pillow opens up to 89 Mpx) and a page of a few MB. A bigger
#: population (or archive) shows its best 200 by fitness, a longer lineage the best body and
#: its nearest ancestors; the title, the subtitle and a note say so.
MOST_SHOWN = 200


def _fitness_rank(pick: Pick, maximise: bool) -> tuple[bool, float]:
    finite = math.isfinite(pick.fitness)
    return (not finite, (-pick.fitness if maximise else pick.fitness) if finite else 0.0)


def _capped(chosen: list[Pick], of: str, maximise: bool) -> list[Pick]:
    """At most `MOST_SHOWN` of ``chosen``, in their order: the best by fitness (a lineage: the
    last, the best body and its nearest ancestors)."""
    if len(chosen) <= MOST_SHOWN:
        return chosen
    if of == "lineage-of-best":  # oldest first: the best body is the last
        return chosen[-MOST_SHOWN:]
    ranked = sorted(range(len(chosen)), key=lambda k: _fitness_rank(chosen[k], maximise))
    return [chosen[k] for k in sorted(ranked[:MOST_SHOWN])]


def _cap_text(shown: int, total: int) -> str:
    """The subtitle's and the note's words for a capped gallery ("" for one that is not)."""
    if shown >= total:
        return ""
    return f"the best {shown} of {total} shown (a gallery shows at most {MOST_SHOWN})"


def campaign_picks(campaign: Campaign) -> list[Pick]:
    """The best body of each run's final population, captioned ``condition, seed N``; a body
    id that is not one is `DamagedRunError`, one line."""
    chosen = []
    for (condition, seed), run in campaign.runs.items():
        final = _final(run)
        if final:
            chosen.append(Pick(run, final[0].body, f"{condition}, seed {seed}", final[0].fitness))
    return _checked(chosen)


def key_descriptors(run: Run) -> tuple[str, str]:
    """The two descriptors a label shows: a MAP-Elites run's first two measures (that are
    columns of the bodies table), else `KEY_DESCRIPTORS`."""
    measures = [m for m in _axes(run)[0] if m in run.bodies.columns] if len(run.archive) else []
    chosen = list(dict.fromkeys([*measures, *KEY_DESCRIPTORS]))
    return chosen[0], chosen[1]


def _described(run: Run) -> JsonObject:
    """The archive's description: ``run.archive_description`` (``kind``, ``measures``,
    ``ranges``, a grid's ``bins`` or a CVT's ``cells``), else the map_elites options."""
    description = _recorded_description(run)
    if isinstance(description, Mapping) and description.get("measures"):
        return dict(description)
    options = run.config.get("body", {}).get("optimizer_options", {}) or {}
    measures = options.get("measures") or ["num_limbs", "joints_ratio"]
    return {"kind": "grid", "measures": measures, "ranges": options.get("ranges")}


def _axes(run: Run) -> tuple[list[str], list[Any] | None, str]:
    """The archive's measures, their ranges (or None) and its kind (``grid``, ``cvt``)."""
    description = _described(run)
    ranges = description.get("ranges")
    measures = [str(m) for m in description["measures"]]
    return measures, list(ranges) if ranges else None, str(description.get("kind") or "grid")


def _cells(run: Run, grid: list[int]) -> int:
    """How many cells the archive has: its description's, else the product of ``grid``."""
    description = _described(run)
    try:
        return int(archive_cell_count(description))
    except (KeyError, TypeError, ValueError):  # described from the options: the table's grid
        return int(np.prod(grid))


def _range(
    measure: str, index: int, ranges: list[Any] | None, values: np.ndarray
) -> tuple[float, float]:
    """``[low, high]`` of a measure: the archive's, else its default, else the values'."""
    if ranges and index < len(ranges):
        low, high = (float(v) for v in ranges[index])
    elif measure in DEFAULT_RANGES:
        low, high = DEFAULT_RANGES[measure]
    else:
        finite = values[np.isfinite(values)]
        low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    return (low, high) if high > low else (low, low + 1.0)


def _binned(values: np.ndarray, low: float, high: float, bins: int) -> np.ndarray:
    scaled = np.floor((values - low) / (high - low) * bins)
    return np.clip(np.nan_to_num(scaled, nan=0.0), 0, bins - 1).astype(int)


def archive_atlas(run: Run, maximise: bool) -> Atlas | None:
    """Where each elite of ``run``'s last archive goes (None: fewer than two measures, or
    no finished generation yet)."""
    last = _last_archive(run)
    if not len(last):  # no finished generation yet: no elites to place
        return None
    measures, ranges, kind = _axes(run)
    archive = _ordered(last, maximise)  # best first: it keeps its position
    grid = [int(n) for n in archive["grid"].iloc[0]]
    if len(measures) < 2 or any(len(m) < 2 for m in archive["measures"]):
        return None
    values = np.array([list(m)[:2] for m in archive["measures"]], dtype=float)
    bounds = [_range(measures[k], k, ranges, values[:, k]) for k in (0, 1)]
    binned = kind != "grid" or len(grid) < 2
    if not binned:  # the cell index, row-major over the measures
        shape = (grid[0], grid[1])
        bins = [np.unravel_index(int(c), grid)[:2] for c in archive["cell"]]
    else:  # a CVT archive: the elites binned by their measures
        shape = (ATLAS_BINS, ATLAS_BINS)
        bins = list(zip(*(_binned(values[:, k], *bounds[k], ATLAS_BINS) for k in (0, 1))))
    positions: dict[str, tuple[int, int]] = {}
    taken: set[tuple[int, int]] = set()
    for body_id, (first, second) in zip(archive["body_id"], bins, strict=True):
        position = (int(second), int(first))  # (row, column): the first measure across
        if position not in taken:  # the best elite of the position: it came first
            taken.add(position)
            positions[str(body_id)] = position
    edges = [np.linspace(*bounds[k], shape[k] + 1) for k in (0, 1)]
    atlas = _cropped(
        positions, [edges[1], edges[0]], (measures[0], measures[1]), _cells(run, grid), len(archive)
    )
    return replace(atlas, binned=binned)


def _cropped(
    positions: dict[str, tuple[int, int]],
    edges: list[np.ndarray],
    measures: tuple[str, str],
    cells: int,
    filled: int,
) -> Atlas:
    """The atlas of the rows and columns from the first to the last that hold an elite
    (``edges``: the rows' bin edges, then the columns')."""
    rows = [row for row, _ in positions.values()] or [0]
    columns = [column for _, column in positions.values()] or [0]
    low, left = min(rows), min(columns)
    return Atlas(
        measures=measures,
        rows=max(rows) - low + 1,
        columns=max(columns) - left + 1,
        row_edges=tuple(float(e) for e in edges[0][low : max(rows) + 2]),
        column_edges=tuple(float(e) for e in edges[1][left : max(columns) + 2]),
        cells=cells,
        filled=filled,
        positions={body: (row - low, column - left) for body, (row, column) in positions.items()},
    )


def open_command(run: Run, eval_id: str, records: Path | None) -> tuple[str, bool]:
    """The command that opens the body's evaluation, and whether it names the run from the
    folder that holds ``records`` (else it runs anywhere). A page inside a run or campaign
    folder (``records``) travels with it: ``ariel`` and the run's path from there, no path of
    this machine (docs/records.md)."""
    recorded = (run.path / "run.rrd").is_file() or (run.path / "recordings").is_dir()
    verb = "view" if recorded else "replay"
    if records is not None:
        with contextlib.suppress(ValueError):
            inside = Path(os.path.realpath(run.path)).relative_to(records.parent)
            words = ["ariel", verb, shell_path(inside), shell_quote(eval_id)]
            return " ".join(words), True
    return ariel_line(verb, run.path, eval_id), False
