"""`ariel gallery` (`make_gallery`): a run's bodies as a PNG contact sheet and an HTML page,
their thumbnails drawn once and cached in the run folder, written where OpenGL is missing too.

One tiny MAP-Elites run for the module (it has a final population, an archive and a lineage);
a test that changes the folder works on a copy.
"""

from __future__ import annotations

import base64
import shutil
from pathlib import Path

import numpy as np
import pytest
from _helpers import exit_code, one_error_line, tiny_run_toml
from PIL import Image

import ariel
from ariel.recording import load_run, make_gallery, population_after_selection
from ariel.recording.analysis import _gallery_render, _gallery_sheet
from ariel.recording.analysis._gallery_select import OF, GalleryError
from ariel.recording.store import ancestors, lineage

DATA_URI = 'src="data:image/png;base64,'


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("gallery")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("gallery", 5, generations=3))
    out = folder / "run"
    ariel.run_experiment(config, out=out, progress=False, overrides=['body.optimizer="map_elites"'])
    return out


@pytest.fixture
def fresh(run_dir: Path, tmp_path: Path) -> Path:
    """A copy of the run without its gallery: nothing drawn yet."""
    return Path(
        shutil.copytree(run_dir, tmp_path / "run", ignore=shutil.ignore_patterns("gallery"))
    )


@pytest.fixture(scope="module")
def gl_available() -> None:
    reason = _gallery_render.gl_problem()
    if reason is not None:
        pytest.skip(reason)


@pytest.fixture
def no_gl(monkeypatch: pytest.MonkeyPatch) -> None:
    """OpenGL unavailable, as `create_renderer` reports it (see analysis/test_report.py)."""
    import ariel.utils.renderers

    def no_gl(*args, **kwargs):
        raise RuntimeError("no OpenGL backend available for headless rendering (test)")

    monkeypatch.setattr(ariel.utils.renderers, "create_renderer", no_gl)


def _pictures(gallery) -> int:
    """Thumbnails embedded in the page and tiles of the sheet that show a picture (each
    checked: not the grey tile of a body without one)."""
    html = gallery.html.read_text(encoding="utf-8")
    with Image.open(gallery.png) as image:
        sheet = np.asarray(image.convert("RGB"))
    size, label = _gallery_render.THUMBNAIL_SIZE, 3 * _gallery_sheet.LINE + 6
    columns, _ = _gallery_sheet.sheet_grid(len(gallery.bodies))
    top = _gallery_sheet.MARGIN + 28 + _gallery_sheet.LINE + _gallery_sheet.GAP
    for k in range(len(gallery.bodies)):
        x = _gallery_sheet.MARGIN + (k % columns) * (size + _gallery_sheet.GAP)
        y = top + (k // columns) * (size + label + _gallery_sheet.GAP)
        tile = sheet[y : y + size, x : x + size]
        assert tile.std() > 5 and (tile != _gallery_sheet.EMPTY).any(axis=-1).mean() > 0.5
    return html.count(DATA_URI)


def _best(run) -> str:
    bodies = run.bodies.drop_duplicates("body_id", keep="last")
    bodies = bodies[np.isfinite(bodies["fitness"])]
    return str(bodies.sort_values("fitness", ascending=not run.maximise)["body_id"].iloc[0])


@pytest.mark.usefixtures("gl_available")
def test_final_and_lineage_of_best_show_their_bodies(run_dir: Path) -> None:
    run = load_run(run_dir)
    population = population_after_selection(run.bodies)
    last = population[population["generation"] == run.generations_done - 1]
    final = make_gallery(run_dir)
    assert final.png == run_dir / "gallery" / "final.png"
    ids = [body.body_id for body in final.bodies]
    assert sorted(ids) == sorted(last["body_id"]) and final.notes == []
    fitness = [body.fitness for body in final.bodies]
    assert fitness == sorted(fitness, reverse=run.maximise)  # best first
    assert _pictures(final) == len(ids)

    frame = lineage(run)
    best = int(frame.loc[frame["body_id"] == _best(run), "id"].iloc[0])
    chain = set(frame.loc[frame["id"].isin([best, *ancestors(frame, best)]), "body_id"])
    family = make_gallery(run_dir, of="lineage-of-best")
    assert {body.body_id for body in family.bodies} == chain
    assert family.bodies[-1].caption == "best"  # oldest first, the best last
    assert _pictures(family) == len(chain)
    html = family.html.read_text(encoding="utf-8")
    for body in family.bodies:  # each with the command that opens it, from run_dir's parent
        assert '<code title="paste into a shell in the folder that holds this run' in html
        assert f">ariel replay {run_dir.name} {body.eval_id}</code>" in html
    assert str(run_dir) not in html  # no path of this machine: the page moves with the run
    # the page says so in view, not in a hover title alone (pasted at the repository's root,
    # the commands failed)
    assert "paste it into a shell in the folder that holds the run (or campaign) folder" in html
    # Each card its body's birth (every card said the sheet's generation alone).
    born = run.bodies.drop_duplicates("body_id").set_index("body_id")["born_generation"]
    for body in family.bodies:
        assert body.born == born[body.body_id]
        when = f"born in generation {body.born}, as after generation {body.generation}"
        assert when in html
    assert len({body.born for body in family.bodies}) > 1


@pytest.mark.usefixtures("gl_available")
def test_thumbnails_are_drawn_once(fresh: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first = make_gallery(fresh, workers=1)
    assert first.drawn == len(first.bodies) > 0 and first.reused == 0
    drawn = {body.thumbnail: body.thumbnail.stat().st_mtime_ns for body in first.bodies}
    assert all(path.parent == fresh / "gallery" / "thumbnails" for path in drawn)

    def no_drawing(*args, **kwargs):
        raise AssertionError("a cached thumbnail was drawn again")

    monkeypatch.setattr(_gallery_render, "render_thumbnails", no_drawing)
    again = make_gallery(fresh, workers=1)
    assert again.drawn == 0 and again.reused == len(drawn)
    assert {b.thumbnail: b.thumbnail.stat().st_mtime_ns for b in again.bodies} == drawn


@pytest.mark.usefixtures("gl_available")
def test_a_pool_draws_many(fresh: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_gallery_render, "PER_WORKER", 1)  # 2 workers even for a few
    gallery = make_gallery(fresh, of="elites", workers=2)
    assert gallery.drawn == len(gallery.bodies) >= 2 and gallery.notes == []


@pytest.mark.usefixtures("gl_available")
def test_the_archive_is_an_atlas_of_the_cells(run_dir: Path) -> None:
    run = load_run(run_dir)
    archive = run.archive[run.archive["generation"] == run.archive["generation"].max()]
    gallery = make_gallery(run_dir, of="archive")
    atlas = gallery.atlas
    assert tuple(archive["grid"].iloc[0]) == (8, 8)  # the defaults: 8 bins per measure
    assert atlas.measures == ("num_limbs", "joints_ratio") and atlas.filled == len(archive)
    assert atlas.cells == 64 and atlas.column_edges[-1] - atlas.column_edges[0] == atlas.columns
    cells = [np.unravel_index(c, (8, 8)) for c in archive["cell"]]  # (num_limbs, joints_ratio)
    left, low = min(limbs for limbs, _ in cells), min(ratio for _, ratio in cells)
    # num_limbs across, joints_ratio up: the columns and rows from the first to the last that
    # hold an elite
    assert atlas.columns == max(limbs for limbs, _ in cells) - left + 1
    assert atlas.rows == max(ratio for _, ratio in cells) - low + 1
    expected = {b: (r - low, c - left) for b, (c, r) in zip(archive["body_id"], cells)}
    assert {body.body_id: body.cell for body in gallery.bodies} == expected
    assert gallery.html.read_text(encoding="utf-8").count(DATA_URI) == len(expected)
    # an atlas's tiles are labelled with id and fitness; its axes are the measures
    assert gallery.subtitle.endswith("each label: body id, fitness")
    with Image.open(gallery.png) as image:  # each cell holds a picture of 100 pixels at least
        assert image.width > atlas.columns * 100 and image.height > atlas.rows * 100


@pytest.mark.usefixtures("gl_available")
def test_the_command_writes_them(
    fresh: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = ["gallery", str(fresh), "--of", "lineage-of-best", "--out", str(out), "--workers", "1"]
    assert exit_code(argv) == 0
    assert sorted(p.name for p in out.iterdir()) == ["lineage-of-best.html", "lineage-of-best.png"]
    assert not (fresh / "gallery" / "lineage-of-best.png").exists()  # only the thumbnails there
    assert list((fresh / "gallery" / "thumbnails").glob("*.png"))
    printed = capsys.readouterr().out
    assert f"wrote {out / 'lineage-of-best.png'}" in printed and "thumbnails: " in printed


@pytest.mark.usefixtures("no_gl")
def test_without_opengl_one_line_says_why_and_the_rest_is_written(
    fresh: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(["gallery", str(fresh)]) == 0
    lines = capsys.readouterr().out.splitlines()
    why = [line for line in lines if "OpenGL" in line]
    assert len(why) == 1 and "left out: no OpenGL backend available" in why[0], lines
    html = (fresh / "gallery" / "final.html").read_text(encoding="utf-8")
    assert html.count(DATA_URI) == 0 and "no thumbnail" in html
    assert (fresh / "gallery" / "final.png").read_bytes().startswith(b"\x89PNG")
    assert not list((fresh / "gallery" / "thumbnails").glob("*"))


@pytest.mark.usefixtures("no_gl")
def test_a_planted_link_is_neither_read_nor_followed(fresh: Path, tmp_path: Path) -> None:
    secret = tmp_path / "secret.png"
    secret.write_bytes(b"\x89PNG\r\n\x1a\nsecret")
    body = make_gallery(fresh, render=False).bodies[0]
    thumbnail = _gallery_render.thumbnail_path(fresh, body.body_id)
    thumbnail.parent.mkdir(parents=True, exist_ok=True)
    thumbnail.symlink_to(secret)
    gallery = make_gallery(fresh)
    assert gallery.reused == 0 and gallery.bodies[0].thumbnail is None
    assert base64.b64encode(secret.read_bytes()).decode() not in gallery.html.read_text()
    shutil.rmtree(fresh / "gallery")
    (fresh / "gallery").symlink_to(tmp_path, target_is_directory=True)
    with pytest.raises(ariel.errors.UnsafePathError, match="symbolic link"):
        make_gallery(fresh)


def test_a_bad_of_is_one_line(run_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(["gallery", str(run_dir), "--of", "everything"]) == 2
    assert "invalid choice: 'everything'" in one_error_line(capsys, subcommand=True)
    with pytest.raises(GalleryError, match="not 'everything'"):
        make_gallery(run_dir, of="everything")
    from ariel.cli import _gallery

    assert _gallery.OF == OF  # the command's choices, written out to keep --help instant


def test_a_cvt_archive_is_binned_by_its_measures(tmp_path: Path) -> None:
    """A CVT archive (run.json's ``archive``, `Run.archive_description`) has no grid: each
    elite goes to the bin of its measures, `ATLAS_BINS` per measure over the ranges."""
    from ariel.recording.analysis._gallery_select import ATLAS_BINS, archive_atlas

    config = tmp_path / "cvt.toml"
    config.write_text(tiny_run_toml("cvt", 5, generations=2))
    options = 'body.optimizer_options={archive="cvt", cells=16}'
    ariel.run_experiment(
        config,
        out=tmp_path / "run",
        progress=False,
        overrides=['body.optimizer="map_elites"', options],
    )
    run = load_run(tmp_path / "run")
    atlas = archive_atlas(run, run.maximise)
    assert atlas.binned and atlas.cells == 16 and atlas.positions
    assert atlas.rows <= ATLAS_BINS and atlas.columns <= ATLAS_BINS
    archive = run.archive[run.archive["generation"] == run.archive["generation"].max()]
    bins = {  # (row, column) over the default ranges: joints_ratio 0..1 up, num_limbs 0..8 across
        body_id: (min(int(ratio * 8), 7), min(int(limbs), 7))
        for body_id, (limbs, ratio) in zip(archive["body_id"], archive["measures"])
    }
    low = min(row for row, _ in bins.values())
    left = min(column for _, column in bins.values())
    assert atlas.row_edges[0] == low / 8 and atlas.column_edges[0] == left
    for body_id, (row, column) in atlas.positions.items():
        assert bins[body_id] == (row + low, column + left)


def test_the_atlas_puts_the_first_measure_across_and_the_second_up(tmp_path: Path) -> None:
    """As the report's heatmap and the Rerun viewer draw the archive: an elite in the highest
    bin of the first measure and the lowest of the second is in the last column and the bottom
    row, in the PNG and on the page."""
    import re

    import pandas as pd

    from ariel.recording.analysis._gallery import Gallery, GalleryBody
    from ariel.recording.analysis._gallery_html import gallery_html
    from ariel.recording.analysis._gallery_select import archive_atlas

    measures = ["num_limbs", "joints_ratio"]  # over 0..8 and 0..1, 8 bins each
    described = {"kind": "grid", "measures": measures, "ranges": [[0, 8], [0, 1]], "bins": [8, 8]}
    archive = pd.DataFrame(
        {
            "generation": [1, 1],
            "body_id": ["corner", "other"],
            "cell": [7 * 8 + 0, 0 * 8 + 3],  # num_limbs bin 7, ratio bin 0; bins 0 and 3
            "fitness": [1.0, 0.5],
            "grid": [[8, 8]] * 2,
            "measures": [[7.5, 0.05], [0.5, 0.4]],
        }
    )
    run = type("Run", (), {"archive": archive, "archive_description": described})()
    atlas = archive_atlas(run, maximise=True)  # type: ignore[arg-type]
    assert atlas is not None and (atlas.rows, atlas.columns) == (4, 8)
    assert atlas.positions == {"corner": (0, 7), "other": (3, 0)}  # (row up, column across)
    assert atlas.column_edges == tuple(range(9)) and atlas.row_edges == (0, 0.125, 0.25, 0.375, 0.5)

    bodies = []
    for body_id, colour in (("corner", (255, 0, 0)), ("other", (0, 0, 255))):
        picture = tmp_path / f"{body_id}.png"
        Image.new("RGB", (64, 64), colour).save(picture)
        cell = atlas.positions[body_id]
        bodies.append(GalleryBody(tmp_path, body_id, "e", 1, 1.0, {}, "", "view", picture, cell))
    gallery = Gallery(tmp_path, "archive", "atlas", "", ("num_limbs", "joints_ratio"), bodies)
    gallery.atlas = atlas
    sheet = np.asarray(_gallery_sheet.atlas_sheet(gallery, 256).convert("RGB")).astype(int)
    cell = _gallery_sheet._cell_size(atlas, 256)
    left = _gallery_sheet.MARGIN + _gallery_sheet.LINE + 90
    top = _gallery_sheet.MARGIN + 28 + _gallery_sheet.LINE + _gallery_sheet.GAP
    for channel, (row, column) in ((0, (atlas.rows - 1, 7)), (2, (0, 0))):  # from the top
        others = np.delete(sheet, channel, axis=-1).max(axis=-1)
        ys, xs = np.nonzero((sheet[..., channel] > 200) & (others < 50))
        assert ((ys.mean() - top) // cell, (xs.mean() - left) // cell) == (row, column)

    page = gallery_html(gallery)
    cards = re.findall(r'grid-row: (\d+); grid-column: (\d+)"><img [^>]*alt="body (\w+)"', page)
    # the bins' rows 1 to 4 (4 the lowest; 5: the columns' bins), columns 2 to 9 (1: the rows')
    assert {body: (int(r), int(c)) for r, c, body in cards} == {"corner": (4, 9), "other": (1, 2)}
    assert 'style="grid-row: 5; grid-column: 9">7</div>' in page  # num_limbs' last bin
    assert 'style="grid-row: 4; grid-column: 1">0 to 0.125</div>' in page
    assert "columns: num_limbs" in page and "rows (growing upwards): joints_ratio" in page


@pytest.mark.usefixtures("gl_available")
def test_a_campaign_shows_the_best_body_of_each_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from _helpers import REPO

    from ariel.runs import run_campaign

    folder = tmp_path / "campaign"
    run_campaign(REPO / "tests" / "data" / "campaign_tiny.toml", out=folder, progress=False)
    gallery = make_gallery(folder)
    captions = [body.caption for body in gallery.bodies]
    assert captions == ["fresh, seed 1", "fresh, seed 2", "inherit, seed 1", "inherit, seed 2"]
    assert gallery.png == folder / "gallery" / "final.png" and _pictures(gallery) == 4
    for body in gallery.bodies:  # cached in each run's own folder
        assert body.thumbnail.parent == body.run / "gallery" / "thumbnails"
    assert exit_code(["gallery", str(folder), "--of", "lineage-of-best"]) == 2
    assert "a campaign's gallery shows the best body" in one_error_line(capsys)


def test_an_out_that_is_a_symbolic_link_is_refused(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """As `ariel compare --out`: it wrote final.png and final.html into the link's target."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (tmp_path / "link").symlink_to(outside)
    argv = ["gallery", str(run_dir), "--out", str(tmp_path / "link")]
    assert exit_code(argv) == 2
    assert "it is a symbolic link" in capsys.readouterr().err
    assert list(outside.iterdir()) == []


def test_a_crafted_huge_thumbnail_is_drawn_as_missing(tmp_path: Path) -> None:
    """A cached thumbnail whose PNG header claims 60,000 x 60,000 pixels (a few bytes on disk,
    GBs decoded) ended the gallery in PIL's DecompressionBombError traceback."""
    import struct
    import types
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", 60_000, 60_000, 8, 2, 0, 0, 0)
    bomb = tmp_path / "b000001-256.png"
    bomb.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IEND", b""))
    tile = _gallery_sheet._thumbnail(types.SimpleNamespace(thumbnail=bomb), 64)  # type: ignore[arg-type]
    assert tile.size == (64, 64)
    assert tile.getpixel((0, 0)) == _gallery_sheet.EMPTY  # the grey "no thumbnail" tile
    # The page embedded it as it was (3.6 gigapixels for the browser): "no thumbnail" too.
    from ariel.recording.analysis._gallery_render import cached_thumbnail

    assert cached_thumbnail(bomb) is None
    small = struct.pack(">IIBBBBB", 256, 256, 8, 2, 0, 0, 0)
    bomb.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", small) + chunk(b"IEND", b""))
    assert cached_thumbnail(bomb) == bomb.read_bytes()


def test_a_crafted_elite_leaves_the_report_s_archive_thumbnails_out_with_a_note(
    fresh: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A damaged elite's row stopped the whole report in one line; now archive.png is drawn
    without its thumbnails and a note says why."""
    from ariel.errors import DamagedRunError
    from ariel.recording import make_report
    from ariel.recording.analysis import _report_archive

    def damaged(run: object, body_id: str) -> None:
        raise DamagedRunError(f"run folder 'x' is damaged: {body_id} \x1b[2J")

    monkeypatch.setattr(_report_archive, "_thumbnail", damaged)
    report = make_report(fresh, render=True)
    assert fresh / "report" / "archive.png" in report.written
    note = next(n for n in report.notes if n.startswith("archive.png: body thumbnails left out"))
    assert "is damaged: b" in note and "\\x1b[2J" in note


# Two galleries writing into one folder at once: one waits for the other (its lock), so the
# folder holds one gallery's PNG and page, never one's PNG with the other's page.


def test_a_gallery_waits_for_another_writing_into_its_folder(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "sheets"
    from ariel.recording import RunInUseError, RunLock

    lock = RunLock(out, create=True, kind="gallery").acquire()  # another gallery, writing
    import threading

    threading.Timer(0.5, lock.release).start()
    gallery = make_gallery(run_dir, out=out, render=False)  # waits, then writes
    assert gallery.png == out / "final.png" and gallery.png.is_file()
    assert sorted(p.name for p in out.iterdir()) == ["final.html", "final.png"]

    import ariel.recording.analysis._gallery as module

    monkeypatch.setattr(module, "_WAIT_S", 0.0)
    with RunLock(out, kind="gallery"), pytest.raises(RunInUseError, match="gallery folder"):
        make_gallery(run_dir, out=out, render=False)  # one that never lets go: one line


def test_a_killed_gallery_s_temporaries_are_removed_by_the_next(
    run_dir: Path, tmp_path: Path
) -> None:
    """A gallery killed with SIGKILL leaves ``.final.png.<token>.tmp``; a later gallery into
    the folder used to leave it there for ever."""
    import os

    out = tmp_path / "sheets"
    (out / "thumbnails").mkdir(parents=True)
    (out / ".final.png.0123abcd.tmp").write_bytes(b"half")
    old = out / "thumbnails" / ".b000001-256.png.0123abcd.tmp"
    new = out / "thumbnails" / ".b000002-256.png.4567cdef.tmp"  # another gallery's, drawing
    old.write_bytes(b"half")
    new.write_bytes(b"half")
    os.utime(old, (0, 0))
    make_gallery(run_dir, out=out, render=False)
    assert sorted(p.name for p in out.iterdir()) == ["final.html", "final.png", "thumbnails"]
    assert [p.name for p in (out / "thumbnails").iterdir()] == [new.name]


@pytest.mark.usefixtures("gl_available")
def test_a_read_only_run_s_gallery_out_of_it_draws_its_thumbnails_there(
    fresh: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Shared data one may not write to: `ariel gallery RUN --out DIR` showed no picture at
    all ("no thumbnail (cannot write 'RUN/gallery')"); they are drawn into DIR instead."""
    from ariel.recording.analysis import _gallery

    run_folder = fresh.resolve()
    monkeypatch.setattr(  # as for user nobody on a chmod a-w copy (root may write anyway)
        _gallery, "_writable", lambda path: run_folder not in Path(path).resolve().parents
    )
    gallery = make_gallery(fresh, out=tmp_path / "out", workers=1)
    assert gallery.bodies and all(body.thumbnail is not None for body in gallery.bodies)
    assert not (fresh / "gallery").exists()  # nothing written into the run
    drawn = sorted((tmp_path / "out" / "thumbnails").rglob("*.png"))
    assert {body.thumbnail for body in gallery.bodies} == set(drawn)
