"""`make_report`: the per-generation table and the PNG figures of a run."""

from __future__ import annotations

import io
import json
import re
import shutil
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from _helpers import with_run_id
from PIL import Image

from ariel.errors import DamagedRunError
from ariel.evolution import run_experiment
from ariel.recording import ancestors, lineage_statistics, load_run, make_report
from ariel.recording.analysis._report import TABLE_COLUMNS, print_report
from ariel.recording.rerun._joint_names import joint_labels

CONFIG = {
    "name": "reporttiny",
    "seed": 4,
    "generations": 3,
    "body": {"options": {"number_of_modules": 6}, "population": 3, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 0.5},
    "executor": {"kind": "serial"},
}
FIGURES = ["fitness.png", "morphology.png", "lineage.png", "trajectory.png", "joints.png"]
# The final population's gallery (`ariel gallery`), written after the lineage figure.
WRITTEN = [*FIGURES[:3], "gallery.png", "gallery.html", *FIGURES[3:]]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "coevolution"
    run_experiment(CONFIG, out=out)
    return out


@pytest.fixture(scope="module")
def report(run_dir: Path):
    return make_report(run_dir, render=False)


def _check_png(path: Path, min_size: tuple[int, int] = (500, 350)) -> np.ndarray:
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as image:
        image.verify()
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.width >= min_size[0] and image.height >= min_size[1], image.size
        pixels = np.asarray(image.convert("RGB"))
    assert pixels.std() > 5  # not a blank canvas
    return pixels


def _thumbnail_cards(report) -> dict[str, tuple[int, ...]]:
    """lineage.png's thumbnails: caption ("best b000012", "founder b000001") -> its pixels'
    shape."""
    from matplotlib.offsetbox import AnnotationBbox

    (axes, _colorbar) = report.figures["lineage.png"].axes
    cards = {}
    for artist in axes.artists:
        if isinstance(artist, AnnotationBbox):
            image, label = artist.offsetbox.get_children()
            cards[label.get_text()] = image.get_data().shape
    return cards


def _table_text(report) -> str:
    out = io.StringIO()
    from rich.console import Console

    print_report(report, Console(file=out, width=100))
    return out.getvalue()


def test_the_report_writes_every_figure_as_a_readable_png(run_dir: Path, report) -> None:
    folder = run_dir / "report"
    assert report.written == [folder / name for name in FIGURES]
    assert sorted(p.name for p in folder.iterdir()) == sorted(FIGURES)
    for path in report.written:
        _check_png(path)
    assert report.notes == [
        "lineage.png: thumbnails left out (rendering off)",
        "gallery.png, gallery.html: left out (rendering off)",
        "best_body.png: left out (rendering off)",
    ]


def test_the_table_lists_every_generation(run_dir: Path, report) -> None:
    run = load_run(run_dir)
    table = report.table
    assert list(table.columns) == list(TABLE_COLUMNS)
    assert table["generation"].tolist() == [0, 1, 2]
    assert table["evaluations"].tolist() == [
        int((run.evaluations["generation"] == g).sum()) for g in range(3)
    ]
    assert table["best_fitness"].tolist() == run.generations["best_fitness"].tolist()
    text = _table_text(report)
    header = next(line for line in text.splitlines() if "generation" in line and "best" in line)
    assert header.split() == list(TABLE_COLUMNS.values())
    rows = [line.split() for line in text.splitlines() if line.split()[:1] in (["0"], ["1"], ["2"])]
    assert [r[0] for r in rows] == ["0", "1", "2"]
    assert [int(r[1]) for r in rows] == table["evaluations"].tolist()
    best = report.best
    assert best["fitness"] == run.evaluations["fitness"].max()
    assert f"best evaluation: {best['eval_id']}" in text and repr(best["fitness"]) in text
    for path in report.written:
        assert f"wrote {path}" in text


def _visible_axes(figure) -> list:
    """The figure's plotting axes: not colour bars, not the axes of a rendered image."""
    return [a for a in figure.axes if a.axison and not hasattr(a, "_colorbar")]


def _integer_ticks(axis) -> bool:
    from matplotlib.ticker import MaxNLocator

    ticks = axis.get_majorticklocs()
    locator = axis.get_major_locator()
    return (
        isinstance(locator, MaxNLocator)
        and locator._integer
        and all(float(t).is_integer() for t in ticks)
    )


def test_every_axis_says_its_unit_and_counts_tick_whole_numbers(report) -> None:
    from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES

    figures = report.figures
    assert sorted(figures) == sorted(FIGURES)
    for name, figure in figures.items():
        for axes in _visible_axes(figure):
            assert axes.get_xlabel() and axes.get_ylabel(), (name, axes.get_title())
    (fitness,) = _visible_axes(figures["fitness.png"])
    assert fitness.get_xlabel() == "generation" and _integer_ticks(fitness.xaxis)
    assert fitness.get_ylabel() == "fitness: xy_displacement (m), higher is better"
    morphology = {a.get_title(): a for a in _visible_axes(figures["morphology.png"])}
    assert set(morphology) == set(DESCRIPTOR_NAMES)
    for descriptor, axes in morphology.items():
        assert _integer_ticks(axes.xaxis), descriptor  # generations
        counts = descriptor.startswith("num_") or descriptor == "depth"
        assert _integer_ticks(axes.yaxis) == counts, descriptor
    assert morphology["num_modules"].get_ylabel() == "modules"
    assert morphology["extent_x"].get_ylabel() == "m"
    assert "population after selection" in figures["morphology.png"].get_suptitle()
    (path,) = _visible_axes(figures["trajectory.png"])
    assert (path.get_xlabel(), path.get_ylabel()) == ("core x (m)", "core y (m)")
    for axes in _visible_axes(figures["joints.png"]):
        assert (axes.get_xlabel(), axes.get_ylabel()) == ("time (s)", "angle (rad)")


def test_joints_are_named_by_branch_and_hinge(run_dir: Path, report) -> None:
    run = load_run(run_dir)
    titles = [a.get_title() for a in _visible_axes(report.figures["joints.png"])]
    graph = run.bodies.loc[run.bodies["body_id"] == report.best["body_id"], "graph"].iloc[0]
    assert titles == joint_labels(report.best["joint_names"], graph)
    assert all(re.fullmatch(r"(front|back|right|left) branch, hinge \d+", t) for t in titles)


def test_no_title_is_clipped_even_for_a_long_run_id(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import ariel.utils.renderers

    def grey(model, data, *, width, height, **view):  # best_body.png without OpenGL
        return np.full((height, width, 3), 128, dtype=np.uint8)

    monkeypatch.setattr(ariel.utils.renderers, "single_frame_renderer", grey)
    copy = tmp_path / "long"
    shutil.copytree(run_dir, copy)
    long_id = "coevolve_flat_with_a_longer_name-20250101-120000-s42"  # a default run id
    info = json.loads((with_run_id(copy, long_id) / "run.json").read_text())
    report = make_report(copy)
    assert sorted(report.figures) == sorted([*FIGURES, "best_body.png"])
    for name, figure in report.figures.items():
        canvas = FigureCanvasAgg(figure)  # as savefig draws it
        canvas.draw()
        renderer = canvas.get_renderer()
        titles = [figure._suptitle] + [a.title for a in figure.axes]
        for title in titles:
            if title is None or not title.get_text():
                continue
            box = title.get_window_extent(renderer)
            assert box.x0 >= 0 and box.x1 <= figure.bbox.width, (name, title.get_text())
            assert box.y1 <= figure.bbox.height, (name, title.get_text())
        assert info["run_id"] in " ".join(t.get_text() for t in titles if t is not None)


def test_a_brain_only_run_reports_without_morphology(tmp_path: Path) -> None:
    config = {
        **CONFIG,
        "generations": 2,
        "body": {"encoder": "prebuilt", "genotype": "gecko"},
    }
    out = tmp_path / "brain"
    run_experiment(config, out=out)
    report = make_report(out, render=False)
    assert [p.name for p in report.written] == ["fitness.png", "trajectory.png", "joints.png"]
    assert any(n.startswith("morphology.png: left out (brain-only") for n in report.notes)
    assert report.table["generation"].tolist() == [0, 1]
    # the gecko has 8 joints: one panel each in a 3-column grid, named without prefix and suffix
    _check_png(out / "report" / "joints.png", min_size=(1000, 700))
    titles = [a.get_title() for a in _visible_axes(report.figures["joints.png"])]
    assert titles[:3] == ["neck", "spine", "fl leg"]
    # fitness: the best so far against the mean of each generation's CMA-ES candidates
    (axes,) = _visible_axes(report.figures["fitness.png"])
    lines = {line.get_label(): line.get_ydata() for line in axes.get_lines()}
    assert set(lines) == {"best so far", "mean of the generation's CMA-ES candidates"}
    evals = load_run(out).evaluations
    means = evals.groupby("generation")["fitness"].mean().to_numpy()
    assert np.allclose(lines["mean of the generation's CMA-ES candidates"], means)
    assert np.allclose(lines["best so far"], report.table["best_fitness"])
    assert (lines["best so far"] > means).all()  # a best above the candidates' mean
    assert "CMA-ES candidates" in _table_text(report)


def test_a_killed_run_reports_its_finished_generations_only(run_dir: Path, tmp_path: Path) -> None:
    killed = tmp_path / "killed"
    shutil.copytree(run_dir, killed)
    shutil.rmtree(killed / "report", ignore_errors=True)
    info = json.loads((killed / "run.json").read_text())
    info.update(status="running", generations_done=2)  # generation 2's files are not counted
    (killed / "run.json").write_text(json.dumps(info))
    report = make_report(killed, render=False)
    assert report.table["generation"].tolist() == [0, 1]
    assert report.best["generation"] <= 1
    assert [p.name for p in report.written] == FIGURES
    assert "stopped (killed?), 2/3 generations" in _table_text(report)  # as `ariel runs`


def test_a_run_without_finished_generations_writes_nothing(run_dir: Path, tmp_path: Path) -> None:
    fresh = tmp_path / "fresh"
    shutil.copytree(run_dir, fresh)
    shutil.rmtree(fresh / "report", ignore_errors=True)
    info = json.loads((fresh / "run.json").read_text())
    info.update(status="running", generations_done=0)
    (fresh / "run.json").write_text(json.dumps(info))
    report = make_report(fresh)
    assert report.written == [] and len(report.table) == 0
    assert report.notes == ["no finished generation yet: no figures"]
    assert not (fresh / "report").exists()


def test_a_report_stopped_before_its_first_figure_leaves_no_empty_folder(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C during `ariel report` left an empty report/ behind; one that was there stays."""
    from ariel.recording.analysis import _report

    copy = tmp_path / "copy"
    shutil.copytree(run_dir, copy)
    shutil.rmtree(copy / "report", ignore_errors=True)

    def stopped(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(_report, "_draw", stopped)
    with pytest.raises(KeyboardInterrupt):
        make_report(copy, render=False)
    assert not (copy / "report").exists()
    (copy / "report").mkdir()
    with pytest.raises(KeyboardInterrupt):
        make_report(copy, render=False)
    assert (copy / "report").is_dir()  # not this call's: left as it was


def test_a_copied_run_reports_into_the_copy(run_dir: Path, tmp_path: Path) -> None:
    copy = tmp_path / "a" / "copy"
    shutil.copytree(run_dir, copy)
    shutil.rmtree(copy / "report", ignore_errors=True)
    away = run_dir.with_name(run_dir.name + "-away")
    run_dir.rename(away)  # nothing may still point at the original folder
    backend = matplotlib.get_backend()
    try:
        report = make_report(copy, render=False)
    finally:
        away.rename(run_dir)
    assert report.written == [copy / "report" / name for name in FIGURES]
    assert matplotlib.get_backend() == backend  # drawn on Agg canvases, pyplot untouched


def test_a_run_whose_body_encoder_is_not_installed_reports_without_its_bodies(
    run_dir: Path, tmp_path: Path
) -> None:
    """The tables' figures need no plugin (report and gallery refused the whole run)."""
    from ariel.recording.analysis import make_gallery

    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("report", "gallery"))
    info = json.loads((copy / "run.json").read_text())
    info["config"]["body"]["encoder"] = "encoder_under_test"
    (copy / "run.json").write_text(json.dumps(info))
    report = make_report(copy)  # render=True: the bodies would be drawn
    missing = "body encoder 'encoder_under_test' is not installed here (or does not load)"
    assert report.notes[0] == f"rendering off: {missing}, which draws the run's bodies"
    assert [path.name for path in report.written] == FIGURES
    assert repr(report) == (
        f"<Report of run: 3 generations, 5 files written in {copy / 'report'}, 4 notes>"
    )
    gallery = make_gallery(copy, progress=False)
    assert repr(gallery).startswith("<Gallery of run (final): 3 bodies, wrote ")
    assert any(note.endswith(f"thumbnail(s) left out: {missing}") for note in gallery.notes)
    assert (copy / "gallery" / "final.png").is_file()


def test_a_gallery_leaves_out_only_the_bodies_of_a_run_whose_plugin_is_missing(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A campaign's gallery drew no body at all when one run's encoder was not installed."""
    from ariel.recording.analysis import _gallery, _gallery_render
    from ariel.recording.analysis._gallery_select import Pick

    here, missing = tmp_path / "here", tmp_path / "missing"
    for folder in (here, missing):
        shutil.copytree(run_dir, folder, ignore=shutil.ignore_patterns("report", "gallery"))
    info = json.loads((missing / "run.json").read_text())
    info["config"]["body"]["encoder"] = "encoder_under_test"
    (missing / "run.json").write_text(json.dumps(info))
    drawn: list[str] = []

    def render(jobs, **kwargs):
        drawn.extend(job.run_path for job in jobs)
        return {job.path: None for job in jobs}

    monkeypatch.setattr(_gallery_render, "gl_problem", lambda: None)
    monkeypatch.setattr(_gallery_render, "render_thumbnails", render)
    picks = [Pick(load_run(f), load_run(f).bodies.iloc[0].to_dict()) for f in (missing, here)]
    gallery = _gallery.Gallery(tmp_path, "final", "t", "s", ("num_modules", "symmetry"))
    shown = _gallery._thumbnails(gallery, picks, workers=1, render=True)
    assert drawn == [str(here)] and shown[0] is None and shown[1] is not None
    assert gallery.notes == [
        "1 thumbnail(s) left out: body encoder 'encoder_under_test' is not installed here "
        "(or does not load)"
    ]


def test_without_opengl_the_body_image_is_left_out_with_a_note(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ariel.utils.renderers

    def no_gl(*args, **kwargs):
        raise RuntimeError("no OpenGL backend available for headless rendering (test)")

    monkeypatch.setattr(ariel.utils.renderers, "create_renderer", no_gl)
    copy = tmp_path / "nogl"
    shutil.copytree(run_dir, copy)
    report = make_report(copy)
    assert [p.name for p in report.written] == WRITTEN  # the gallery without its pictures
    assert len(report.notes) == 3  # the lineage and the gallery drawn without thumbnails
    assert re.fullmatch(r"lineage\.png: \d thumbnail\(s\) left out: no OpenGL .*", report.notes[0])
    assert "OpenGL" in report.notes[1]
    assert not _thumbnail_cards(report)
    assert report.notes[2] == (
        "best_body.png: left out (no OpenGL backend available for headless rendering (test))"
    )


@pytest.fixture
def gl_available() -> None:
    import mujoco

    from ariel.utils._gl import create_renderer

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    try:
        create_renderer(model, 16, 16).close()
    except RuntimeError as exc:
        pytest.skip(str(exc))


@pytest.mark.usefixtures("gl_available")
def test_the_best_body_is_rendered(run_dir: Path, tmp_path: Path) -> None:
    copy = tmp_path / "render"
    shutil.copytree(run_dir, copy)
    report = make_report(copy)
    assert report.notes == []
    assert [p.name for p in report.written] == [*WRITTEN, "best_body.png"]
    gallery = (copy / "report" / "gallery.html").read_text()
    population = load_run(copy).population  # the final one: a picture per body
    final = population[population["generation"] == population["generation"].max()]
    assert gallery.count("data:image/png;base64,") == len(final) > 0
    # lineage.png: thumbnails of the best body and of its ancestry's founders, the gallery's
    frame = load_run(copy).lineage()
    best = int(lineage_statistics(frame)["best_id"].iloc[-1])
    names = dict(zip(frame["id"], frame["body_id"]))
    founders = [i for i in ancestors(frame, best) if not ancestors(frame, i)]
    expected = {f"best {names[best]}", *(f"founder {names[i]}" for i in founders)}
    cards = _thumbnail_cards(report)
    assert set(cards) == expected and all(shape == (256, 256, 3) for shape in cards.values())
    for body_id in [names[best], *(names[i] for i in founders)]:
        assert (copy / "gallery" / "thumbnails" / f"{body_id}-256.png").is_file()  # cached
    assert report.written[-1] == copy / "report" / "best_body.png"
    pixels = _check_png(report.written[-1])
    # The core module is yellow: the body is in the picture.
    yellow = (pixels[..., 0] > 150) & (pixels[..., 1] > 150) & (pixels[..., 2] < 100)
    assert yellow.sum() > 500


@pytest.mark.parametrize(
    ("table", "column", "left_out"),
    [
        ("trajectories", "t", ["trajectory.png", "joints.png"]),  # "arange: cannot compute..."
        ("trajectories", "core_x", ["trajectory.png"]),  # "Axis limits cannot be NaN or Inf"
        ("bodies", "fitness", ["lineage.png"]),  # fails in the lineage's layout, before saving
    ],
)
def test_values_matplotlib_cannot_draw_leave_that_figure_out_with_a_note(
    run_dir: Path, tmp_path: Path, table: str, column: str, left_out: list[str]
) -> None:
    """A crafted table (consistent manifest) holding 1e308 where a run writes small numbers: a
    traceback from matplotlib before; the other figures are written."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ariel.recording.store._manifest import write_manifest

    crafted = tmp_path / "crafted"
    shutil.copytree(run_dir, crafted)
    shutil.rmtree(crafted / "report", ignore_errors=True)
    for path in sorted((crafted / table).glob("gen-*.parquet")):
        rows = pq.read_table(path)
        at = rows.schema.get_field_index(column)
        values = pa.array([1e308] * rows.num_rows, type=rows.schema.field(column).type)
        pq.write_table(rows.set_column(at, column, values), path)
        write_manifest(crafted, int(path.stem.split("-")[1]))
    report = make_report(crafted, render=False)
    notes = [note for note in report.notes if "cannot be drawn" in note]
    assert [note.split(":")[0] for note in notes] == left_out
    written = [p.name for p in report.written]
    assert set(written) == set(FIGURES) - set(left_out)
    assert sorted(p.name for p in (crafted / "report").iterdir()) == sorted(written)


# -- archive.png: measure 0 across, measure 1 up (as the Rerun viewer draws the archive) ------


def _archive_axes(description: dict, cells: dict[int, float], tmp_path: Path):
    """archive.png's heatmap of an archive holding ``cells`` (cell -> fitness), drawn alone."""
    import pandas as pd
    from matplotlib.figure import Figure

    from ariel.recording.analysis._report_archive import archive_figure

    grid = description.get("bins") or [len(description.get("centroids", []))]
    archive = pd.DataFrame(
        {
            "generation": [1] * len(cells),
            "body_id": [f"b{c:06d}" for c in cells],
            "cell": list(cells),
            "fitness": list(cells.values()),
            "grid": [list(grid)] * len(cells),
        }
    )
    run = type("Run", (), {"archive": archive, "archive_description": description})()
    run.body_optimizer = "map_elites"
    run.config = {"task": {"fitness": "xy_displacement"}}
    report = type("Report", (), {"run": run, "folder": tmp_path, "notes": []})()
    saved = []
    archive_figure(
        report,  # type: ignore[arg-type]
        True,
        render=False,
        figure=lambda width, height: Figure(figsize=(width, height)),
        save=lambda figure, path, report: saved.append(figure),
    )
    return saved[0].axes[0]


def test_the_archive_heatmap_puts_measure_0_across_and_measure_1_up(tmp_path: Path) -> None:
    measures, ranges = ["num_limbs", "joints_ratio"], [[0.0, 8.0], [0.0, 1.0]]
    # an 8 x 4 grid: (num_limbs bin 7, joints_ratio bin 0) is cell 28, (0, 3) is cell 3
    grid = {"kind": "grid", "measures": measures, "ranges": ranges, "bins": [8, 4]}
    axes = _archive_axes(grid, {28: 1.0, 3: 0.5}, tmp_path)
    assert axes.get_xlabel().startswith("num_limbs") and axes.get_ylabel().startswith("joints")
    assert all(float(t).is_integer() for t in axes.get_xticks())  # a count: whole numbers
    (image,) = axes.get_images()
    shown = np.asarray(image.get_array())
    assert shown.shape == (4, 8) and tuple(image.get_extent()) == (0.0, 8.0, 0.0, 1.0)
    assert shown[0, 7] == 1.0 and shown[3, 0] == 0.5  # origin lower: row 0 at the bottom
    assert np.isnan(shown).sum() == 30

    one = {"kind": "grid", "measures": measures[:1], "ranges": ranges[:1], "bins": [8]}
    axes = _archive_axes(one, {7: 1.0}, tmp_path)
    (image,) = axes.get_images()
    assert np.asarray(image.get_array()).shape == (1, 8)  # a single band across
    assert axes.get_xlabel().startswith("num_limbs") and axes.get_ylabel() == ""

    centroids = [[7.5, 0.1], [0.5, 0.9]]  # high num_limbs, low joints_ratio; the other way
    cvt = {"kind": "cvt", "measures": measures, "ranges": ranges, "centroids": centroids}
    axes = _archive_axes(cvt, {0: 1.0, 1: 0.5}, tmp_path)
    assert axes.get_xlabel().startswith("num_limbs") and axes.get_ylabel().startswith("joints")
    shown = np.asarray(axes.get_images()[0].get_array())
    assert shown[0, -1] == 1.0 and shown[-1, 0] == 0.5  # bottom right: cell 0; top left: 1
    assert tuple(axes.get_images()[0].get_extent()) == (0.0, 8.0, 0.0, 1.0)


def _craft(run_dir: Path, crafted: Path, table: str, edit) -> Path:
    """A copy of ``run_dir`` whose ``table`` files are ``edit``ed (a pyarrow table -> a
    table), their manifests written again: `ariel verify` passes."""
    import pyarrow.parquet as pq

    from ariel.recording.store._manifest import write_manifest

    if not crafted.exists():
        shutil.copytree(run_dir, crafted)
        shutil.rmtree(crafted / "report", ignore_errors=True)
    for path in sorted((crafted / table).glob("gen-*.parquet")):
        pq.write_table(edit(pq.read_table(path)), path)
        write_manifest(crafted, int(path.stem.split("-")[1]))
    return crafted


def test_joint_lists_of_other_lengths_leave_joints_png_out_with_a_note(
    run_dir: Path, tmp_path: Path
) -> None:
    """Before, lists of 0, None and 50 values: numpy's "inhomogeneous shape" traceback."""
    import pyarrow as pa

    def ragged(rows):
        lists = [[] if i % 3 == 0 else None if i % 3 == 1 else [0.1] * 50 for i in range(len(rows))]
        at = rows.schema.get_field_index("joint_angle")
        return rows.set_column(at, "joint_angle", pa.array(lists, pa.list_(pa.float64())))

    report = make_report(_craft(run_dir, tmp_path / "run", "trajectories", ragged), render=False)
    assert "joints.png: left out (the trajectories table's joint lists are not one value " in (
        "\n".join(report.notes)
    )
    written = [p.name for p in report.written]
    assert "trajectory.png" in written and "joints.png" not in written


EVIL = "\x1b[31m\u202e[/bold]$\\frac{$"


def test_text_from_the_folder_is_drawn_escaped(run_dir: Path, tmp_path: Path) -> None:
    """Crafted joint names: drawn as escapes (no raw ESC for matplotlib to warn about, no bidi
    override, no mathtext), every figure written. A crafted eval id is refused on load (the
    tables' ids must have an id's shape), so none is ever drawn."""
    import warnings

    import pyarrow as pa

    def renamed(rows):
        names = [[f"{EVIL}{j}" for j in range(len(n))] for n in rows["joint_names"].to_pylist()]
        at = rows.schema.get_field_index("joint_names")
        return rows.set_column(at, "joint_names", pa.array(names, pa.list_(pa.string())))

    crafted = _craft(run_dir, tmp_path / "run", "evaluations", renamed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = make_report(crafted, render=False)
    assert not [w for w in caught if not str(w.message).isprintable()]
    assert [p.name for p in report.written] == FIGURES
    figure = report.figures["joints.png"]
    texts = [axes.get_title() for axes in figure.axes]
    for text in texts:
        assert text.replace("\n", " ").isprintable(), text
        assert r"\x1b[31m\u202e[/bold]\$\frac{\$" in text.replace("\n", ""), text

    def reid(rows):
        ids = pa.array([EVIL + i for i in rows.column("eval_id").to_pylist()])
        return rows.set_column(rows.schema.get_field_index("eval_id"), "eval_id", ids)

    _craft(run_dir, crafted, "evaluations", reid)
    with pytest.raises(DamagedRunError, match=r"has eval_id .*, not an id: changed by hand"):
        make_report(crafted, render=False)


def test_a_killed_report_s_stale_temporaries_are_removed_by_the_next(
    run_dir: Path, tmp_path: Path
) -> None:
    """A report killed with SIGKILL leaves ``report/.fitness.png.<token>.tmp``; later reports
    left it for ever. One another report may be writing now (recent) is left alone."""
    import os

    copy = Path(shutil.copytree(run_dir, tmp_path / "copy"))
    stale = copy / "report" / ".morphology.png.0123abcd.tmp"
    recent = copy / "report" / ".fitness.png.4567cdef.tmp"
    stale.write_bytes(b"half")
    recent.write_bytes(b"half")
    os.utime(stale, (0, 0))
    make_report(copy, render=False)
    assert not stale.exists() and recent.exists()


@pytest.mark.parametrize("fails", [False, True], ids=["drawn", "a-write-fails"])
def test_a_run_replaced_while_its_report_is_drawn_is_said_in_one_line(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails: bool
) -> None:
    """`ariel run --overwrite` into the folder during `ariel report`: the report finished with
    figures of both runs in report/ (or failed saying the run was unchanged)."""
    from ariel.errors import NotARunError, RunStorageError
    from ariel.recording.analysis import _report

    copy = Path(shutil.copytree(run_dir, tmp_path / "copy"))

    def overwritten(report: object, maximise: bool, render: bool) -> None:
        info = json.loads((copy / "run.json").read_text())
        info["created"] = "2099-01-01T00:00:00+00:00"  # a new run in the folder
        (copy / "run.json").write_text(json.dumps(info))
        if fails:
            raise RunStorageError("cannot write 'report/fitness.png': No such file or directory")

    monkeypatch.setattr(_report, "_draw", overwritten)
    with pytest.raises(NotARunError, match=r"was replaced by another run while its report was"):
        make_report(copy, render=False)


def test_out_takes_the_report_of_a_run_it_must_not_write_into(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from _helpers import exit_code, one_error_line

    from ariel.cli import main

    shared = tmp_path / "shared"  # e.g. a read-only disk: its report goes to a folder of ours
    shutil.copytree(run_dir, shared)
    shutil.rmtree(shared / "report", ignore_errors=True)
    out = tmp_path / "mine" / "report"
    for _ in range(2):  # an earlier report's folder takes the next
        assert main(["report", str(shared), "--no-render", "--out", str(out)]) == 0
    assert f"wrote {out / 'fitness.png'}" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(FIGURES)
    assert not (shared / "report").exists()  # nothing written into the run
    (out.parent / "notes.txt").write_text("mine")
    link = tmp_path / "link"
    link.symlink_to(out.parent)
    elsewhere = tmp_path / "linked-thumbnails"
    elsewhere.mkdir()
    (tmp_path / "report-2").mkdir()
    (tmp_path / "report-2" / "thumbnails").symlink_to(elsewhere)  # thumbnails went through it
    refused = {
        tmp_path / "report-2": "holds files a report does not write ('thumbnails')",
        shared / "figures": "is inside the run or campaign folder",
        out.parent: "holds files a report does not write ('notes.txt' and 1 more)",
        out.parent / "notes.txt": "is not a folder",
        link: "it is a symbolic link",
    }
    for folder, why in refused.items():
        assert exit_code(["report", str(shared), "--no-render", "--out", str(folder)]) == 2
        assert why in one_error_line(capsys)
    assert not (shared / "figures").exists() and (out.parent / "notes.txt").read_text() == "mine"


@pytest.mark.usefixtures("gl_available")
def test_out_holds_the_thumbnails_of_a_run_it_cannot_write(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """lineage.png said "no thumbnail (cannot write 'RUN/gallery')" where the gallery beside
    it drew its thumbnails into --out."""
    from ariel.recording.analysis import _gallery

    shared = tmp_path / "shared"
    shutil.copytree(run_dir, shared)
    shutil.rmtree(shared / "report", ignore_errors=True)
    shutil.rmtree(shared / "gallery", ignore_errors=True)
    monkeypatch.setattr(_gallery, "_writable", lambda path: False)  # as on a read-only disk
    report = make_report(shared, out=tmp_path / "mine")
    assert not [note for note in report.notes if "thumbnail" in note], report.notes
    assert len(_thumbnail_cards(report)) >= 2  # the best and a founder
    assert list((tmp_path / "mine" / "thumbnails").rglob("*.png"))
    assert not (shared / "gallery").exists()


def test_a_long_run_s_morphology_draws_a_bounded_number_of_generations(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """300 generations drew 300 boxes per descriptor, merged into black bars (90 s of the
    report's time, probe G3): past MORPHOLOGY_BOXES, that many evenly spread, and a note."""
    from ariel.recording.analysis import _report

    monkeypatch.setattr(_report, "MORPHOLOGY_BOXES", 2)
    report = make_report(run_dir, render=False, out=tmp_path / "report")
    generations = len(load_run(run_dir).generations)
    assert generations > 2
    assert f"morphology.png: 2 of {generations} generations, spread" in report.notes
    axes = _visible_axes(report.figures["morphology.png"])[0]
    boxes = [line for line in axes.lines if len(line.get_xdata()) == 5]  # each box's outline
    assert sorted({float(min(b.get_xdata())) for b in boxes}) == pytest.approx(
        [-0.3 * (generations - 1), 0.7 * (generations - 1)], abs=1e-9
    )


def test_a_run_that_ends_while_the_report_is_drawn_is_not_called_killed(
    run_dir: Path, tmp_path: Path
) -> None:
    """Read while running, finished while the figures were drawn: the header said "stopped
    (killed?)" (its lock was free by then), of a run that ended normally (probe G1)."""
    from ariel.recording.analysis._report_figures import run_status

    copy = Path(shutil.copytree(run_dir, tmp_path / "copy"))
    info = json.loads((copy / "run.json").read_text())
    (copy / "run.json").write_text(json.dumps({**info, "status": "running"}))
    run = load_run(copy)
    assert run_status(run) == "stopped (killed?)"  # no process holds it: killed
    (copy / "run.json").write_text(json.dumps({**info, "status": "finished"}))
    assert run_status(run) == "running when read, finished since"
