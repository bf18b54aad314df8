"""`ariel gallery`: the bodies of a run (or a campaign) side by side, as a PNG contact sheet and
a self-contained HTML page.

What is shown (``of``, `_gallery_select`): the final population, a MAP-Elites run's elites or
its archive as an atlas (each elite at its cell over the two measures, the first across and
the second up), or the best body's lineage; for a campaign, the best body of each run. Each
body is drawn once, headless, from the report's three-quarter camera, and cached in its run
folder (`_gallery_render`); the sheet (`_gallery_sheet`) and the page (`_gallery_html`) go to
``RUN/gallery/`` (a campaign's to ``CAMPAIGN/gallery/``) or to ``out``. Where nothing can be
drawn (no OpenGL), both are written without pictures and a note says why.
"""

from __future__ import annotations

import hashlib
import math
import numbers
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.errors import RunStorageError
from ariel.evaluation import default_workers
from ariel.recording import resim
from ariel.recording.analysis import _gallery_render
from ariel.recording.analysis._gallery_progress import ThumbnailProgress
from ariel.recording.analysis._gallery_render import (
    THUMBNAIL_SIZE,
    ThumbnailJob,
    cached_thumbnail,
    thumbnail_path,
)
from ariel.recording.analysis._gallery_select import (
    KEY_DESCRIPTORS,
    MOST_SHOWN,
    OF,
    Atlas,
    GalleryError,
    Pick,
    _cap_text,
    _capped,
    _last_rows,
    archive_atlas,
    campaign_picks,
    key_descriptors,
    open_command,
    picks,
)
from ariel.recording.analysis._gallery_titles import gallery_subtitle, gallery_title
from ariel.recording.store import (
    STALE_S,
    Run,
    RunLock,
    atomic_write,
    atomic_write_bytes,
    cannot_write,
    is_campaign,
    load_campaign,
    load_run,
    one_line,
    records_folder_of,
    refuse_symlinks,
    remove_temporaries,
)
from ariel.utils import flag_argument, path_argument

if TYPE_CHECKING:
    from ariel.recording.analysis._report import Report

__all__ = [
    "MOST_SHOWN",
    "OF",
    "Gallery",
    "GalleryBody",
    "GalleryError",
    "add_report_gallery",
    "body_thumbnails",
    "make_gallery",
    "report_gallery",
]


@dataclass(frozen=True)
class GalleryBody:
    """A body shown in a gallery.

    Attributes:
        run: its run folder.
        body_id: its id (``b000012``).
        eval_id: its best evaluation, the one ``command`` opens.
        generation: the last finished generation it took part in.
        born: the generation it was born in (None where the bodies table does not say).
        fitness: its fitness (an archive's elite: the archive's).
        descriptors: its morphology descriptors, name -> value (None where unknown).
        caption: what it is here: ``best`` or ``born 3`` in a lineage, ``default, seed 21``
            in a campaign's gallery; else empty.
        command: the command that opens it: ``ariel view RUN EVAL_ID``
            (``ariel replay RUN EVAL_ID`` for a run without Rerun recordings); in a gallery
            inside a run or campaign folder, ``ariel`` and RUN from the folder holding that
            folder, so the page stays right when the folder moves.
        thumbnail: its PNG in the run folder (``gallery/thumbnails/``), or, for a run folder
            that cannot be written, in the gallery's (``DIR/thumbnails/``); None where it
            could not be drawn.
        cell: its (row, column) in the archive's atlas (row 0 the lowest bin of the second
            measure, column 0 the lowest of the first); None in any other gallery.
        from_parent: whether ``command`` names the run from the folder that holds the run
            (or campaign) folder the page is in; else it runs anywhere.
    """

    run: Path
    body_id: str
    eval_id: str
    generation: int
    fitness: float
    descriptors: dict[str, float | None]
    caption: str
    command: str
    thumbnail: Path | None
    cell: tuple[int, int] | None = None
    born: int | None = None
    from_parent: bool = False


@dataclass
class Gallery:
    """What `make_gallery` showed and wrote.

    Attributes:
        source: the run or campaign folder.
        of: what it shows: ``final``, ``elites``, ``archive`` or ``lineage-of-best`` (a
            campaign: ``final``, the best body of each run's final population).
        title: its heading: the run and what is shown.
        subtitle: the line under it: the fitness and what each label shows.
        key_descriptors: the two descriptors on each label.
        bodies: the bodies shown, in order.
        png: the contact sheet written (for ``archive``: the atlas); None before writing.
        html: the page written; None before writing.
        drawn: thumbnails drawn by this call.
        reused: thumbnails found already drawn, in the run folders.
        notes: one line per thing left out, and why (no OpenGL here, a body that cannot be
            built, ...).
        atlas: where ``archive`` puts each elite; None in any other gallery.
    """

    source: Path
    of: str
    title: str
    subtitle: str
    key_descriptors: tuple[str, str]
    bodies: list[GalleryBody] = field(default_factory=list)
    png: Path | None = None
    html: Path | None = None
    drawn: int = 0
    reused: int = 0
    notes: list[str] = field(default_factory=list)
    atlas: Atlas | None = None

    def __repr__(self) -> str:  # one line, as Run's (a notebook cell's last value)
        written = ", ".join(str(p) for p in (self.png, self.html) if p is not None) or "nothing"
        notes = f", {len(self.notes)} notes" if self.notes else ""
        return (
            f"<Gallery of {self.source.name} ({self.of}): {len(self.bodies)} bodies, "
            f"wrote {written}{notes}>"
        )


def _body(
    pick: Pick, thumbnail: Path | None, cell: tuple[int, int] | None, records: Path | None
) -> GalleryBody:

    body = pick.body
    descriptors = {}
    for name in DESCRIPTOR_NAMES:
        value = body.get(name, math.nan)  # missing: NaN, not finite, so None
        try:
            descriptors[name] = float(value) if math.isfinite(float(value)) else None
        except (TypeError, ValueError):  # <NA>: a body without descriptors
            descriptors[name] = None
    command, from_parent = open_command(pick.run, str(body["best_eval_id"]), records)
    return GalleryBody(
        run=Path(pick.run.path),
        body_id=str(body["body_id"]),
        eval_id=str(body["best_eval_id"]),
        generation=int(body["generation"]),
        fitness=pick.fitness,
        descriptors=descriptors,
        caption=pick.caption,
        command=command,
        thumbnail=thumbnail,
        cell=cell,
        born=_born(body.get("born_generation")),
        from_parent=from_parent,
    )


def _born(value: object) -> int | None:
    return int(value) if isinstance(value, numbers.Integral) else None  # <NA>: None


def _thumbnails(
    gallery: Gallery,
    chosen: list[Pick],
    *,
    workers: int | None,
    render: bool,
    progress: bool | None = False,
    spare: Path | None = None,
) -> list[Path | None]:
    """Each pick's thumbnail (None: not drawn), drawing those not drawn before: into its
    run's cache, or, where that cannot be written (a read-only run folder, shared data),
    into ``spare`` (the gallery's own folder's ``thumbnails/``; None: the run's cache)."""
    paths: list[Path | None] = []
    jobs: dict[str, ThumbnailJob] = {}
    for pick in chosen:
        body_id = str(pick.body["body_id"])
        path = thumbnail_path(pick.run.path, body_id)
        refuse_symlinks(path, pick.run.path)  # never read or write through a linked folder
        cached = cached_thumbnail(path)
        if cached is None and spare is not None and not _writable(path):
            path = thumbnail_path(spare / _run_key(pick.run.path), body_id)
            cached = cached_thumbnail(path)
        paths.append(path)
        if cached is None:
            jobs[str(path)] = ThumbnailJob(str(pick.run.path), body_id, str(path))
    gallery.reused = len({str(p) for p in paths} - set(jobs))
    if not jobs:
        return list(paths)
    runs = {str(pick.run.path): pick.run for pick in chosen}
    undrawn: set[str] = set()  # left out: no OpenGL, rendering off, a plugin not here, failed
    for run_path in dict.fromkeys(job.run_path for job in jobs.values()) if render else ():
        missing = resim.missing_plugin(runs[run_path])  # not installed here: its bodies left out
        if missing is not None:
            left = {key for key, job in jobs.items() if job.run_path == run_path}
            gallery.notes.append(f"{len(left)} thumbnail(s) left out: {missing}")
            undrawn |= left
            continue
        # drawing makes each body's encoder and world: options they reject are one line
        resim.check_options(runs[run_path], resim.BODY_PLUGINS)
    jobs = {key: job for key, job in jobs.items() if key not in undrawn}
    problem = (_gallery_render.gl_problem() if render else "rendering off") if jobs else None
    if problem is not None:
        gallery.notes.append(f"{len(jobs)} thumbnail(s) left out: {problem}")
        undrawn |= set(jobs)
    elif jobs:
        workers = min(workers or default_workers(), len(jobs) // _gallery_render.PER_WORKER or 1)
        with ThumbnailProgress(len(jobs), workers=workers, show=progress) as shown:
            drawn = _gallery_render.render_thumbnails(
                list(jobs.values()), workers=workers, runs=runs, on_done=shown.advance
            )
        for path, why in drawn.items():
            if why is not None:
                gallery.notes.append(f"{jobs[path].body_id}: no thumbnail ({why})")
                undrawn.add(path)
        gallery.drawn = sum(why is None for why in drawn.values())
    return [None if str(path) in undrawn else path for path in paths]


def _writable(path: Path) -> bool:
    """Whether ``path`` could be made: its nearest folder that exists lets us write."""
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    return os.access(folder, os.W_OK)


def _run_key(run_path: Path) -> str:
    """A run's own folder under a gallery's spare ``thumbnails/`` (runs may share names)."""
    name = Path(run_path).resolve()
    return f"{name.name[:40]}-{hashlib.sha256(os.fsencode(name)).hexdigest()[:12]}"


def body_thumbnails(
    run: Run,
    body_ids: Sequence[str],
    *,
    render: bool = True,
    workers: int | None = None,
    spare: Path | None = None,
) -> tuple[dict[str, Path], list[str]]:
    """Thumbnails of bodies ``body_ids`` of ``run`` (a `Run`), drawn as the gallery draws
    them and cached with its own (``RUN/gallery/thumbnails/``; one already there is reused),
    or in ``spare`` where the run cannot be written (a report's ``--out DIR/thumbnails``).

    Returns body id -> its PNG, for each body that has one, and the notes: one line per thing
    left out and why (no OpenGL here, ``render`` False, a body that cannot be built)."""
    bodies = _last_rows(run)
    chosen = [
        Pick(run, bodies.loc[i].to_dict()) for i in dict.fromkeys(body_ids) if i in bodies.index
    ]
    scratch = Gallery(Path(run.path), "lineage-of-best", "", "", KEY_DESCRIPTORS)  # its notes
    paths = _thumbnails(scratch, chosen, workers=workers, render=render, spare=spare)
    found = {str(p.body["body_id"]): path for p, path in zip(chosen, paths) if path is not None}
    return found, scratch.notes


#: How long a gallery waits for another writing into its folder (writing takes a moment).
_WAIT_S = 30.0


def _remove_leftovers(folder: Path) -> None:
    """A killed gallery's temporaries in ``folder`` (under its lock none is another's) and
    of its thumbnails (drawn without the lock: the stale ones, `STALE_S`)."""
    list(remove_temporaries(folder, deep=False))
    thumbnails = folder / "thumbnails"
    if thumbnails.is_dir() and not thumbnails.is_symlink():
        list(remove_temporaries(thumbnails, older_than_s=STALE_S))


def _write(gallery: Gallery, folder: Path, root: Path, stem: str) -> None:
    """The sheet and the page, each written whole (`atomic_write`) inside ``root``."""
    # lazy: the page and the sheet import Pillow (PIL), a heavy optional library
    from ariel.recording.analysis._gallery_html import gallery_html
    from ariel.recording.analysis._gallery_sheet import atlas_sheet, contact_sheet  # lazy: PIL

    draw = atlas_sheet if gallery.atlas is not None else contact_sheet
    sheet = draw(gallery, THUMBNAIL_SIZE)
    png, html = folder / f"{stem}.png", folder / f"{stem}.html"
    try:  # the pair from one gallery: two writing into one folder at once left a mix
        refuse_symlinks(png, root)  # before the lock file is made in the folder
        with RunLock(folder, create=True, kind="gallery", wait_s=_WAIT_S):
            _remove_leftovers(folder)
            atomic_write(png, lambda temporary: sheet.save(temporary, format="PNG"), root=root)
            atomic_write_bytes(html, gallery_html(gallery).encode("utf-8"), root=root)
    except OSError as exc:  # disk full, read-only: one line, the run itself is unchanged
        raise RunStorageError(f"{cannot_write(exc)}; the gallery is not finished") from exc
    gallery.png, gallery.html = png, html


def _finish(
    gallery: Gallery, chosen: list[Pick], where: tuple[Path, Path, str], **drawing: Any
) -> Gallery:
    """Draw (or find) the thumbnails, make the bodies, write the sheet and the page to
    ``where`` (the folder, the folder nothing is written outside of, the files' stem)."""
    # A run folder we may not write to (shared, read-only data): its thumbnails are drawn
    # into the gallery's own folder instead, where that is no run's (`--out DIR`).
    records = records_folder_of(where[0])
    spare = where[0] / "thumbnails" if records is None else None
    thumbnails = _thumbnails(gallery, chosen, spare=spare, **drawing)
    positions = gallery.atlas.positions if gallery.atlas is not None else None
    for pick, thumbnail in zip(chosen, thumbnails, strict=True):
        cell = positions[str(pick.body["body_id"])] if positions is not None else None
        gallery.bodies.append(_body(pick, thumbnail, cell, records))
    _write(gallery, *where)
    return gallery


def _run_gallery(run: Run, of: str) -> tuple[Gallery, list[Pick]]:
    resim.check_config(run)  # a section that is no table: one line, before it is read
    chosen = picks(run, of)
    atlas = archive_atlas(run, run.maximise) if of == "archive" else None
    hidden = 0
    if atlas is not None:  # an elite whose place a better one holds is neither drawn nor shown
        placed = [pick for pick in chosen if str(pick.body["body_id"]) in atlas.positions]
        chosen, hidden = placed, len(chosen) - len(placed)
    shown = _capped(chosen, of, run.maximise)
    key = key_descriptors(run)
    title = gallery_title(run, of, shown, atlas, len(chosen))
    capped = _cap_text(len(shown), len(chosen))
    subtitle = gallery_subtitle(run, key, capped, atlas=atlas is not None)
    gallery = Gallery(run.path, of, title, subtitle, key)
    gallery.atlas = atlas
    if of == "archive" and atlas is None and chosen:
        gallery.notes.append("no atlas: the archive has fewer than two measures")
    if hidden:
        gallery.notes.append(f"{hidden} elite(s) share an atlas cell with a better one: not shown")
    if len(shown) < len(chosen):
        gallery.notes.append(f"{len(chosen)} bodies: {_cap_text(len(shown), len(chosen))}")
    return gallery, shown


def _campaign_gallery(path: Path) -> tuple[Gallery, list[Pick]]:
    campaign = load_campaign(path)
    for run in campaign.runs.values():
        resim.check_config(run)
    chosen = campaign_picks(campaign)
    name = one_line(campaign.info.get("campaign_id") or path.name)
    runs = list(campaign.runs.values())
    shown = _capped(chosen, "final", runs[0].maximise) if runs else chosen
    key = key_descriptors(runs[0]) if runs else ("num_modules", "num_hinges")
    capped = _cap_text(len(shown), len(chosen))
    subtitle = gallery_subtitle(runs[0], key, capped) if runs else ""
    title = f"{name}: the best body of {_campaign_what([pick.run for pick in chosen])}"
    gallery = Gallery(path, "final", title, subtitle, key)
    if len(chosen) < len(runs):
        gallery.notes.append(f"{len(runs) - len(chosen)} run(s) without a finished generation")
    for (condition, seed), why in campaign.damaged.items():  # named, never left out unsaid
        gallery.notes.append(f"condition {one_line(condition)} seed {seed}: left out ({why})")
    if capped:
        gallery.notes.append(f"{len(chosen)} runs: {capped}")
    return gallery, shown


def _campaign_what(runs: list[Run]) -> str:
    """Whose best body a campaign's gallery shows: each run's final population, or, where
    runs have not finished (killed, still running), their last finished generation's."""
    unfinished = [run for run in runs if run.info.get("status") != "finished"]
    if not unfinished:
        return f"each run's final population ({len(runs)} runs)"
    done = [run.generations_done for run in unfinished]
    spread = f"{min(done)}" if min(done) == max(done) else f"{min(done)} to {max(done)}"
    planned = {run.config.get("generations") for run in unfinished}
    of = f" of {one_line(planned.pop())}" if len(planned) == 1 else ""
    return (
        f"each run's population after its last finished generation ({len(runs)} runs, "
        f"{len(unfinished)} not finished: {spread}{of} generations done)"
    )


def make_gallery(
    path: str | Path,
    *,
    of: str = "final",
    out: str | Path | None = None,
    workers: int | None = None,
    render: bool = True,
    progress: bool | None = None,
) -> Gallery:
    """Draw the bodies of a run (or a campaign) side by side: a PNG and an HTML page.

    Each body gets a thumbnail (its start pose from the report's three-quarter camera, 256
    x 256 pixels), drawn headless once and cached in its run folder
    (``gallery/thumbnails/``). The PNG is a contact sheet, each thumbnail labelled with the
    body's id, fitness and two key descriptors (a MAP-Elites run: its measures); the HTML
    page embeds the thumbnails and gives each body's descriptors and the ``ariel view``
    command that opens it. Without OpenGL both are written without pictures, and
    `Gallery.notes` says why.

    Args:
        path: A run folder, or a campaign folder: then the best body of each run's final
            population, one thumbnail per run, captioned with its condition and seed.
        of: What a run's gallery shows: ``"final"`` (the population after the last finished
            generation's selection, best first), ``"elites"`` (a MAP-Elites run's archive,
            best first), ``"archive"`` (the same elites, each at its cell in a grid of the
            archive's two measures: the atlas) or ``"lineage-of-best"`` (the run's best body
            and its ancestors, oldest first). A campaign's gallery takes ``"final"`` only.
        out: The folder for ``OF.png`` and ``OF.html`` (made where missing); None: the
            run's (or campaign's) ``gallery/`` folder. Thumbnails stay in the run folders.
        workers: Processes that draw the thumbnails at most (None: one per CPU). Fewer than
            8 thumbnails per process are drawn in this one: a process takes a second or two
            to start.
        render: False draws no thumbnail (those already drawn are still shown).
        progress: Whether to show how many thumbnails are drawn while they are (on stdout:
            a bar on a terminal, else a line at every tenth of many); None: only where
            someone watches (a terminal, a notebook).

    At most `MOST_SHOWN` bodies are shown (the sheet stays an image viewers open): of more,
    the best by fitness (a lineage: the best body and its nearest ancestors); the title,
    the subtitle and `Gallery.notes` say so.

    Returns:
        What was shown and written: the bodies (with their thumbnails), the PNG and HTML
        paths, how many thumbnails were drawn and reused, and a note per thing left out.

    Raises:
        GalleryError: For an unknown ``of``, ``elites`` or ``archive`` of a run without a
            MAP-Elites archive, or another ``of`` than ``final`` for a campaign.
        NotARunError: For a folder that is neither a run nor a campaign
            (`DamagedRunError`: one whose tables were changed, whose config has a section
            that is no table, or, where bodies are drawn, whose body encoder or world rejects
            the options its config records).
        UnsafePathError: When a folder on the way to a file written is a symbolic link
            (`GalleryError` when ``out`` itself is one).
        RunStorageError: When the PNG or the page cannot be written (disk full, read-only).
        TypeError: For an argument of the wrong type (``render="no"``: True or False).

    Example:
        ```python
        from ariel.recording import list_runs, make_gallery

        gallery = make_gallery(list_runs()[-1]["path"], of="lineage-of-best")
        print(gallery.png, gallery.html, [body.body_id for body in gallery.bodies])
        print(gallery.notes)  # e.g. why the thumbnails are missing
        ```
    """
    path = path_argument("path", path, function="make_gallery")
    out = None if out is None else path_argument("out", out, function="make_gallery")
    flag_argument("render", render, function="make_gallery")
    flag_argument("progress", progress, none=True, function="make_gallery")
    if of not in OF:
        raise GalleryError(f"a gallery shows one of {', '.join(OF)}, not {of!r}")
    if out is not None and out.is_symlink():  # as `ariel compare --out` refuses one
        raise GalleryError(
            f"refusing to write the gallery into {str(out)!r}: it is a symbolic link (to "
            f"{os.readlink(out)!r}); name the folder itself"
        )
    source = path
    if is_campaign(source):
        if of != "final":
            raise GalleryError(
                f"a campaign's gallery shows the best body of each run (--of final), not {of}; "
                "for a run's elites, archive or lineage name the run's folder"
            )
        gallery, chosen = _campaign_gallery(source)
    else:
        gallery, chosen = _run_gallery(load_run(source), of)
    where = (out or source / "gallery", out or source, of)  # folder, root, of
    return _finish(gallery, chosen, where, workers=workers, render=render, progress=progress)


def report_gallery(
    run: Run,
    folder: str | Path,
    *,
    render: bool = True,
    workers: int | None = None,
    progress: bool | None = None,
) -> Gallery:
    """The final population's gallery of ``run``, for `ariel report` to embed.

    Writes ``folder/gallery.png`` (the contact sheet) and ``folder/gallery.html``, as
    `make_gallery` writes ``final.png`` and ``final.html``; the thumbnails are cached in the
    run folder as `make_gallery` caches them.

    Args:
        run: The loaded run (`Run`).
        folder: The folder of the two files: the run's ``RUN/report`` (nothing is written
            through a symbolic link between the two), or a report's ``out`` folder outside the
            run (its thumbnails then cached there too where the run cannot be written).
        render: False draws no thumbnail (those already drawn are still shown).
        workers: Processes that draw the thumbnails at most (None: one per CPU).
        progress: As `make_gallery`'s (None: only where someone watches).

    Returns:
        The gallery: ``png`` for the report's written files, ``notes`` (one line per thing
        left out, e.g. why there are no pictures) for its notes.
    """
    gallery, chosen = _run_gallery(run, "final")
    inside = Path(folder).is_relative_to(run.path)
    where = (Path(folder), Path(run.path) if inside else Path(folder), "gallery")
    return _finish(gallery, chosen, where, workers=workers, render=render, progress=progress)


def add_report_gallery(report: Report, render: bool) -> None:
    """`make_report`'s gallery of the final population (``gallery.png``, ``gallery.html``):
    added to ``report`` (a `Report`)'s written files, with its notes; left out with a note for
    a brain-only run (one body) and with rendering off."""
    if report.run.brain_only:
        report.notes.append("gallery.png: left out (a brain-only run has one body)")
    elif not render:
        report.notes.append("gallery.png, gallery.html: left out (rendering off)")
    else:
        gallery = report_gallery(report.run, report.folder)
        for path in (gallery.png, gallery.html):
            if path is not None:
                report.wrote(path)
        report.notes += gallery.notes
