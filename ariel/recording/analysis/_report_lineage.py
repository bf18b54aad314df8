"""The report's lineage figure, ``lineage.png``: the ancestry of the final population (the
bodies in it after the last finished generation's selection, and all their ancestors) as a
tree over generations, from the run's lineage in the ALife phylogeny standard
(`ariel.recording.lineage`).

x is the generation: each body is a dot where it was made (its ``origin_time``), coloured by
its fitness (bright: better), with a faint line while it stays in the population. One line per
parent -> child edge, from the parent in the generation before the child's to the child (a
crossover's second parent dotted). Rows follow the tree (a child's first parent), a parent
between its descendants, as in a phylogeny: a straight run of dots is a chain of descent. The
best body of the final population is a star, and its ancestry, back to its founders, is drawn
in red. Thumbnails of the founders of that ancestry (left of the tree) and of the best body
(right of it), each tied to its dot, show what the bodies looked like: the gallery's, cached in
``RUN/gallery/thumbnails/`` (`body_thumbnails`); with rendering off or without OpenGL the
figure is drawn without them and one note says why. Left out for a brain-only run (one fixed
body).

Matplotlib and PIL are imported at the top: `make_report` imports this module only when it
draws.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.lines import Line2D
from matplotlib.offsetbox import AnnotationBbox, OffsetImage, TextArea, VPacker
from PIL import Image

from ariel.errors import DamagedRunError
from ariel.recording.analysis._gallery import body_thumbnails
from ariel.recording.analysis._report_figures import UNDRAWABLE, cannot_draw, figure_lines
from ariel.recording.store import (
    Run,
    figure_label,
    fitness_label,
    fitted,
    integer_ticks,
    one_line,
    parse_ancestor_list,
)

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ariel.recording.analysis._report import Report

__all__ = ["LINEAGE_PNG", "ancestry_layout", "lineage_figure"]

LINEAGE_PNG = "lineage.png"
_CHAIN = "#d62728"  # the best body's ancestry
_EDGE = "0.55"
_THUMBNAIL_INCHES = 1.1  # a thumbnail's side at most (less where many founders must fit)
_CARD_INCHES = 0.4  # a thumbnail's caption and frame, and the gap to the next
_MOST_FOUNDERS = 8  # founders with a thumbnail at most (the lowest ids)


def _closure(alive: list[int], parents: dict[int, list[int]]) -> set[int]:
    """``alive`` and every ancestor of theirs (each parent a taxon of the frame)."""
    found, stack = set(alive), list(alive)
    while stack:
        for parent in parents.get(stack.pop(), []):
            if parent in parents and parent not in found:
                found.add(parent)
                stack.append(parent)
    return found


def ancestry_layout(shown: set[int], parents: dict[int, list[int]]) -> dict[int, int]:
    """A row (0, 1, ...: y) per body of ``shown``: the tree of each body's first parent in
    ``shown``, walked depth first from the founders, each body's row right above its
    children's, older children (lower ids) first. A chain of descent reads as a staircase."""
    children: dict[int, list[int]] = {i: [] for i in shown}
    roots: list[int] = []
    for node in sorted(shown):
        first = next((p for p in parents.get(node, []) if p in children), None)
        (children[first] if first is not None else roots).append(node)
    rows: dict[int, int] = {}
    stack = list(reversed(roots))
    while stack:
        node = stack.pop()
        rows[node] = len(rows)
        stack.extend(reversed(children[node]))
    return rows


def _row_pitch(drawn: Figure, rows: int) -> float:
    """Points between two rows of the tree (the axes take the figure's height less about 1.8
    inches of title, axis and legend). Dots, lines and the margins are sized by it: with
    hundreds of bodies (a row a point or two apart) dots of their usual size and black rims
    made one solid bar, and the best body's star was clipped at the top."""
    return max(0.1, (drawn.get_figheight() - 1.8) * 72 / (rows + 1.6))


def _dot(size: float, pitch: float) -> float:
    """A marker area (points squared) of at most ``size``, about as wide as 1.5 rows."""
    return min(size, max(2.5, 1.5 * pitch) ** 2)  # neighbours may touch, not hide each other


def _best(frame: pd.DataFrame, alive: list[int], maximise: bool) -> int | None:
    """The final population's body of the best finite fitness (the lowest id on a tie)."""
    fitness = dict(zip(frame["id"].astype(int), frame["fitness"].astype(float)))
    scored = [i for i in alive if math.isfinite(fitness[i])]
    if not scored:
        return None
    return min(scored, key=lambda i: (-fitness[i] if maximise else fitness[i], i))


def lineage_figure(
    report: Report,
    maximise: bool,
    *,
    figure: Callable[[float, float], Figure],
    save: Callable[[Figure, Path, Report], None],
    render: bool = True,
) -> None:
    """Write ``lineage.png`` (the module's docstring) with ``figure(width, height)`` and
    ``save(figure, path, report)``; a note instead for a brain-only run, or a lineage that
    cannot be read. ``render`` False: without thumbnails (no OpenGL needed)."""
    run = report.run
    if run.brain_only:
        report.notes.append(f"{LINEAGE_PNG}: left out (brain-only run: one fixed body)")
        return
    try:
        frame = run.lineage()
    except DamagedRunError as exc:  # a changed bodies table: the rest of the report stands
        report.notes.append(f"{LINEAGE_PNG}: left out ({exc})")
        return
    alive = sorted(int(i) for i in frame.loc[frame["destruction_time"].isna(), "id"])
    if not alive:
        report.notes.append(f"{LINEAGE_PNG}: left out (no body in the final population)")
        return
    parents = {
        int(i): parse_ancestor_list(text) for i, text in zip(frame["id"], frame["ancestor_list"])
    }
    shown = _closure(alive, parents)
    rows = ancestry_layout(shown, parents)
    best = _best(frame, alive, maximise)
    pictures = _pictures(report, frame, best, parents, render)
    cards = sum(caption == "founder" for _, caption, _ in pictures.values())
    tall = 2.4 + (_THUMBNAIL_INCHES + _CARD_INCHES) * cards  # room for the founders' column
    drawn = figure(11.0, min(12.0, max(5.0, 2.6 + 0.1 * len(rows), tall)))
    _draw(drawn, frame, rows, alive, parents, maximise, best, run)
    if pictures:
        try:  # it lays the figure out, which draws it
            _place_pictures(
                drawn, drawn.axes[0], pictures, rows, _spans(frame, run.generations_done - 1)
            )
        except UNDRAWABLE as exc:
            report.notes.append(cannot_draw(LINEAGE_PNG, exc))
            return
    save(drawn, report.folder / LINEAGE_PNG, report)


def _spans(frame: pd.DataFrame, last: int) -> dict[int, tuple[int, int]]:
    """id -> (the generation it was made in, the last it stayed in the population after;
    ``last`` for the final population)."""
    ends = frame["destruction_time"].astype("Float64").fillna(last + 1).astype("int64") - 1
    return {
        int(i): (int(origin), max(int(origin), int(end)))
        for i, origin, end in zip(frame["id"], frame["origin_time"], ends)
    }


def _draw(
    drawn: Figure,
    frame: pd.DataFrame,
    rows: dict[int, int],
    alive: list[int],
    parents: dict[int, list[int]],
    maximise: bool,
    best: int | None,
    run: Run,
) -> None:
    last = run.generations_done - 1
    spans = _spans(frame, last)
    chain = {best, *_ancestors(best, parents)} if best is not None else set()
    axes = drawn.add_subplot()
    pitch = _row_pitch(drawn, len(rows))
    thin = 1.0 if pitch >= 4 else 0.5  # crowded rows: thinner, fainter lines
    lives, edges, crossed, red = [], [], [], []
    for node, y in rows.items():
        origin, final = spans[node]
        if final > origin:
            lives.append([(origin, y), (final, y)])
        for k, parent in enumerate(p for p in parents[node] if p in rows):
            start = min(max(origin - 1, spans[parent][0]), spans[parent][1])
            segment = [(start, rows[parent]), (origin, y)]
            (edges if k == 0 else crossed).append(segment)
            if node in chain and parent in chain:
                red += [[(spans[parent][0], rows[parent]), (start, rows[parent])], segment]
    axes.add_collection(LineCollection(lives, colors="0.8", linewidths=thin, zorder=1))
    faint = {"colors": _EDGE, "alpha": thin, "zorder": 2}
    axes.add_collection(LineCollection(edges, linewidths=0.9 * thin, **faint))
    axes.add_collection(LineCollection(crossed, linewidths=0.8 * thin, linestyles=":", **faint))
    axes.add_collection(LineCollection(red, colors=_CHAIN, linewidths=2.4, zorder=3))
    _nodes(drawn, axes, frame, rows, alive, maximise, best, run)
    shown = [  # (whether the figure has it, its legend entry)
        (edges, Line2D([], [], color=_EDGE, lw=0.9, label="parent -> child")),
        (crossed, Line2D([], [], color=_EDGE, lw=0.8, ls=":", label="second parent")),
        (lives, Line2D([], [], color="0.8", lw=1.0, label="in the population")),
        (alive, Line2D([], [], marker="o", ls="", mfc="w", mec="k", label="final population")),
        (red, Line2D([], [], color=_CHAIN, lw=2.4, label="best body's ancestry")),
        (chain, Line2D([], [], marker="*", ls="", ms=13, mfc="w", mec=_CHAIN, label="best body")),
    ]
    handles = [handle for present, handle in shown if present]
    drawn.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=8)
    axes.set_xlim(-0.6, last + 0.6)
    margin = max(0.8, 10 / pitch)  # rows: room for half the best body's star
    axes.set_ylim(max(rows.values()) + margin, -margin)  # the first row on top
    axes.set_xlabel("generation")
    integer_ticks(axes.xaxis)
    axes.set_yticks([])
    axes.set_ylabel("bodies: the final population and its ancestors")
    axes.grid(alpha=0.3, axis="x")
    _title(drawn, axes, frame, alive, parents, best, run, last)


def _ancestors(node: int, parents: dict[int, list[int]]) -> set[int]:
    return _closure([node], parents) - {node}


def _nodes(
    drawn: Figure,
    axes: Axes,
    frame: pd.DataFrame,
    rows: dict[int, int],
    alive: list[int],
    maximise: bool,
    best: int | None,
    run: Run,
) -> None:
    """The bodies as dots coloured by fitness (bright: better); a failed one grey."""
    fitness = dict(zip(frame["id"].astype(int), frame["fitness"].astype(float)))
    origin = dict(zip(frame["id"].astype(int), frame["origin_time"].astype(int)))
    ids = list(rows)
    x = np.array([origin[i] for i in ids], dtype=float)
    y = np.array([rows[i] for i in ids])
    f = np.array([fitness[i] for i in ids])
    ok = np.isfinite(f)
    final = np.isin(ids, alive)
    cmap = "viridis" if maximise else "viridis_r"
    norm = Normalize(*(np.nanmin(f[ok]), np.nanmax(f[ok])) if ok.any() else (0, 1))
    pitch = _row_pitch(drawn, len(rows))
    axes.scatter(x[~ok], y[~ok], marker="x", color="0.5", s=_dot(16, pitch), zorder=4)
    rim = 1.0 if pitch >= 6 else 0.3  # crowded: a black rim would hide the colour
    for mask, size, edge in ((~final & ok, 20, "none"), (final & ok, 34, "black")):
        points = axes.scatter(
            x[mask],
            y[mask],
            c=f[mask],
            cmap=cmap,
            norm=norm,
            s=_dot(size, pitch),
            edgecolors=edge,
            linewidths=rim,
            zorder=5,
        )
    if best is not None:
        axes.scatter(
            [origin[best]],
            [rows[best]],
            marker="*",
            s=260,
            c=[fitness[best]],
            cmap=cmap,
            norm=norm,
            edgecolors=_CHAIN,
            linewidths=1.6,
            zorder=6,
        )
    fitness_fn = str(run.config.get("task", {}).get("fitness", "fitness"))
    drawn.colorbar(points, ax=axes, label=figure_label(fitness_label(fitness_fn, maximise)))


def _title(
    drawn: Figure,
    axes: Axes,
    frame: pd.DataFrame,
    alive: list[int],
    parents: dict[int, list[int]],
    best: int | None,
    run: Run,
    last: int,
) -> None:
    founders = {i for i in _closure(alive, parents) if not parents[i]}
    run_id = one_line(run.info.get("run_id") or run.path.name)
    text = (
        f"{run_id}: ancestry of the population after generation {last} ({len(alive)} bodies, "
        f"from {len(founders)} founder{'s' * (len(founders) != 1)})"
    )
    if best is not None:
        names = dict(zip(frame["id"].astype(int), frame["body_id"]))
        fitness = float(frame.loc[frame["id"] == best, "fitness"].iloc[0])
        chain = _ancestors(best, parents)
        roots = ", ".join(sorted(names[i] for i in chain if not parents[i]))
        text += f"\nbest body {names[best]} (fitness {fitness:.4g}): " + (
            f"{len(chain)} ancestor{'s' * (len(chain) != 1)}, back to {roots}"
            if chain
            else "a founder (no ancestors)"
        )
    text = figure_lines(text)  # a run id is any text
    axes.set_title(fitted(text, drawn.get_figwidth() * 0.8, 11), fontsize=11)


# --------------------------------------------------------------------------------------------
# Thumbnails
# --------------------------------------------------------------------------------------------


def _pictures(
    report: Report,
    frame: pd.DataFrame,
    best: int | None,
    parents: dict[int, list[int]],
    render: bool,
) -> dict[int, tuple[str, str, np.ndarray]]:
    """id -> (its body id, its caption, its thumbnail as RGB pixels) of the founders of the
    best body's ancestry and of the best body; none, with one note, where none can be drawn."""
    if best is None:
        return {}
    if not render:
        report.notes.append(f"{LINEAGE_PNG}: thumbnails left out (rendering off)")
        return {}
    names = dict(zip(frame["id"].astype(int), frame["body_id"].astype(str)))
    founders = [i for i in sorted(_ancestors(best, parents)) if not parents[i]]
    if len(founders) > _MOST_FOUNDERS:
        report.notes.append(
            f"{LINEAGE_PNG}: thumbnails of {_MOST_FOUNDERS} of the best body's "
            f"{len(founders)} founders"
        )
    wanted = {i: "founder" for i in founders[:_MOST_FOUNDERS]}
    wanted[best] = "best"
    spare = report.folder / "thumbnails" if report.out is not None else None  # as the gallery's
    found, notes = body_thumbnails(report.run, [names[i] for i in wanted], spare=spare)
    pictures = {}
    for node, caption in wanted.items():
        path = found.get(names[node])
        if path is None:
            continue  # the gallery's notes say why
        try:
            with Image.open(path) as image:
                pictures[node] = (names[node], caption, np.asarray(image.convert("RGB")))
        except (OSError, ValueError) as exc:  # a cached file that is no image after all
            notes.append(f"{names[node]}: no thumbnail ({exc})")
    if notes:
        report.notes.append(f"{LINEAGE_PNG}: " + "; ".join(notes))  # drawn without those
    return pictures


def _place_pictures(
    drawn: Figure,
    axes: Axes,
    pictures: dict[int, tuple[str, str, np.ndarray]],
    rows: dict[int, int],
    spans: dict[int, tuple[int, int]],
) -> None:
    """Each thumbnail beside the tree, tied to its dot by a red line: the founders' left of
    it, the best body's right of it, each at its body's row (founders moved apart as needed).
    The x axis is widened to make the room; its ticks stay on the generations."""
    drawn.draw_without_rendering()  # the constrained layout: the axes' size in inches
    box = axes.get_position()
    width, height = box.width * drawn.get_figwidth(), box.height * drawn.get_figheight()
    best = [n for n, (_, caption, _) in pictures.items() if caption == "best"]  # or none
    founders = sorted((n for n in pictures if n not in best), key=lambda n: rows[n])
    side = min(_THUMBNAIL_INCHES, height / max(1, len(founders)) - _CARD_INCHES)
    room = side + 0.35  # inches beside the tree for a column of thumbnails
    low, high = axes.get_xlim()
    left, right = room if founders else 0.0, room if best else 0.0
    span = (high - low) / (1.0 - (left + right) / width)  # data units across, widened
    axes.set_xlim(low - left * span / width, high + right * span / width)
    last = max(end for _, end in spans.values())
    axes.set_xticks(
        [t for t in axes.xaxis.get_major_locator().tick_values(0, last) if 0 <= t <= last]
    )
    top, bottom = axes.get_ylim()[1], axes.get_ylim()[0]  # the first row on top
    rows_per_inch = (bottom - top) / height
    tall = (side + _CARD_INCHES) * rows_per_inch  # a thumbnail and its caption, in rows
    places = _spread([rows[n] for n in founders], tall, top, bottom)
    at = {n: (low - left * span / width / 2, y) for n, y in zip(founders, places)}
    for node in best:
        (y,) = _spread([rows[node]], tall, top, bottom)
        at[node] = (high + right * span / width / 2, y)
    for node, (x, y) in at.items():
        body_id, caption, pixels = pictures[node]
        image = OffsetImage(pixels, zoom=side * 72 / pixels.shape[0])  # sized in points
        label = TextArea(f"{caption} {body_id}", textprops={"fontsize": 7, "color": _CHAIN})
        packed = VPacker(children=[image, label], align="center", pad=0, sep=1)
        tie = {"arrowstyle": "-", "color": _CHAIN, "lw": 1.0, "shrinkA": 0, "shrinkB": 0}
        axes.annotate("", (spans[node][0], rows[node]), (x, y), arrowprops=tie, zorder=3.5)
        card = AnnotationBbox(  # over every tie: a tie ends under its own card
            packed,
            (x, y),
            bboxprops={"edgecolor": _CHAIN, "linewidth": 1.0, "boxstyle": "round,pad=0.15"},
            annotation_clip=False,
            zorder=8,
        )
        card.set_in_layout(False)
        axes.add_artist(card)


def _spread(wanted: list[float], tall: float, top: float, bottom: float) -> list[float]:
    """Centres near ``wanted`` (ascending) at least ``tall`` apart, inside ``top``..``bottom``."""
    places: list[float] = []
    for y in wanted:
        places.append(max(y, top + tall / 2, places[-1] + tall if places else -math.inf))
    overflow = (places[-1] + tall / 2 - bottom) if places else 0.0
    return [y - max(0.0, overflow) for y in places]
