"""The gallery and the report on what testers met: a novelty run's report, a killed run's
status, a MAP-Elites run killed in generation 0, populations too big for one sheet, small
sheets whose subtitle was cut, a campaign stopped early, and a crowded lineage."""

from __future__ import annotations

import io
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest
from _helpers import exit_code, tiny_run_toml
from rich.console import Console

import ariel
from ariel.recording import load_run, make_gallery, make_report
from ariel.recording.analysis import _gallery, _gallery_progress, _gallery_select, _gallery_sheet
from ariel.recording.analysis._report import print_report


@pytest.fixture(scope="module")
def elites_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("limits")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("limits", 3))
    out = folder / "run"
    ariel.run_experiment(config, out=out, progress=False, overrides=['body.optimizer="map_elites"'])
    return out


def _killed(run_dir: Path, copy: Path, done: int) -> Path:
    """A copy of the run whose run.json says it is running after ``done`` generations, with
    no process holding its lock (killed with SIGKILL)."""
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("gallery", "report"))
    info = json.loads((copy / "run.json").read_text())
    info.update(status="running", generations_done=done)
    (copy / "run.json").write_text(json.dumps(info))
    return copy


def _printed(report) -> str:
    out = io.StringIO()
    print_report(report, Console(file=out, width=200))
    return out.getvalue()


def test_a_novelty_report_does_not_call_its_population_the_archive_s_elites(
    tmp_path: Path,
) -> None:
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("novelty", 2))
    out = tmp_path / "run"
    ariel.run_experiment(config, out=out, progress=False, overrides=['body.optimizer="novelty"'])
    report = make_report(out, render=False)
    title = report.figures["fitness.png"].axes[0].get_title()
    assert "fitness of the population after selection" in title
    assert "elites" not in title
    archive = report.figures["archive.png"].axes[0].get_title()
    assert archive.startswith("result archive after generation 1: ")
    assert archive.endswith("\nthe best body per cell (not the novelty archive)")
    text = _printed(report)
    assert "MAP-Elites" not in text.split("result archive:")[0]
    assert "result archive after each generation" in text
    assert "novelty archive" in text


def test_a_killed_run_s_report_says_stopped_as_ariel_runs_does(
    elites_run: Path, tmp_path: Path
) -> None:
    killed = _killed(elites_run, tmp_path / "killed", done=1)
    assert ariel.recording.list_runs(tmp_path)[0]["status"] == "stopped (killed?)"
    assert ": stopped (killed?), 1/2 generations" in _printed(make_report(killed, render=False))


def test_the_archive_of_a_map_elites_run_before_its_first_generation(
    elites_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    killed = _killed(elites_run, tmp_path / "killed", done=0)
    assert exit_code(["gallery", str(killed), "--of", "archive"]) == 0
    assert ": no finished generation yet" in capsys.readouterr().out
    for of in ("elites", "archive"):
        gallery = make_gallery(killed, of=of, render=False)
        assert gallery.bodies == [] and gallery.notes == []


def test_a_gallery_shows_at_most_the_best_most_shown(
    elites_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_gallery_select, "MOST_SHOWN", 1)
    run = load_run(elites_run)
    final = run.population[run.population["generation"] == run.generations_done - 1]
    best = final.sort_values("fitness", ascending=not run.maximise)["body_id"].iloc[0]
    gallery = make_gallery(elites_run, out=tmp_path / "out", render=False)
    assert [body.body_id for body in gallery.bodies] == [best]
    assert f"the best 1 of {len(final)} bodies" in gallery.title
    assert f"the best 1 of {len(final)} shown" in gallery.subtitle
    assert f"{len(final)} bodies: the best 1 of {len(final)} shown" in gallery.notes[0]
    assert gallery.html.read_text().count("ariel view") <= 2  # the page lists the same one


def test_drawing_many_thumbnails_shows_progress() -> None:
    out = io.StringIO()
    with _gallery_progress.ThumbnailProgress(100, workers=2, show=True, stream=out) as shown:
        for _ in range(100):
            shown.advance(1)
    lines = out.getvalue().splitlines()
    assert lines[0] == "drawing 100 thumbnails (2 processes)"
    assert "thumbnails: 50/100 drawn" in lines and len(lines) == 10
    quiet = io.StringIO()
    with _gallery_progress.ThumbnailProgress(4, workers=1, show=True, stream=quiet) as shown:
        shown.advance(4)  # a few: as quick as before, no lines
    assert quiet.getvalue() == ""


def test_a_small_sheet_wraps_its_subtitle_instead_of_cutting_it() -> None:
    subtitle = (
        "fitness: sustained_displacement (m), higher is better; each label: body id, fitness, "
        "num_modules, num_hinges"
    )
    body = _gallery.GalleryBody(Path("."), "b000001", "e", 0, 1.0, {}, "", "view", None)
    gallery = _gallery.Gallery(Path("."), "final", "run: one body", subtitle, ("a", "b"), [body])
    sheet = _gallery_sheet.contact_sheet(gallery, 256)
    _, subtitles, top = _gallery_sheet._header("run: one body", subtitle, sheet.width - 32)
    assert sheet.width == 640 and len(subtitles) == 2 and " ".join(subtitles) == subtitle
    assert sheet.height == top + 256 + 3 * _gallery_sheet.LINE + 6 + 12 + 16


def test_a_campaign_stopped_early_says_whose_best_body_it_shows() -> None:
    def run(status: str, done: int) -> SimpleNamespace:
        return SimpleNamespace(
            info={"status": status}, generations_done=done, config={"generations": 80}
        )

    stopped = [run("running", 11), run("running", 14), run("finished", 80)]
    assert _gallery._campaign_what(stopped) == (
        "each run's population after its last finished generation (3 runs, 2 not finished: "
        "11 to 14 of 80 generations done)"
    )
    finished = [run("finished", 80)]
    assert _gallery._campaign_what(finished) == "each run's final population (1 runs)"


def test_a_crowded_lineage_draws_small_dots_and_room_for_the_star() -> None:
    from matplotlib.figure import Figure

    from ariel.recording.analysis import _report_lineage

    tall = Figure(figsize=(11, 12))
    pitch = _report_lineage._row_pitch(tall, 600)
    assert pitch < 2 and _report_lineage._dot(34, pitch) < 10  # was 34 whatever the rows
    assert _report_lineage._dot(34, _report_lineage._row_pitch(tall, 20)) == 34


def test_a_caption_too_long_is_cut_in_the_middle_keeping_what_tells_it_apart() -> None:
    """Cut at the end, nine cards read "b000001 (tournament_size_two_wit…": the variant and
    the seed were gone."""
    from PIL import Image, ImageDraw, ImageFont

    from ariel.recording.analysis._gallery_sheet import _fitted

    draw = ImageDraw.Draw(Image.new("RGB", (10, 10)))
    font = ImageFont.load_default()
    long = "b000001 (tournament_size_two_with_crossover_rate_one_half_variant_{}, seed {})"
    cut = {_fitted(draw, long.format(v, s), font, 160) for v in "AB" for s in (1, 2)}
    assert len(cut) == 4 and all("…" in text for text in cut)
    assert all(draw.textlength(text, font=font) <= 160 for text in cut)
    assert all(text.startswith("b000001 (") and text.endswith(")") for text in cut)


def test_campaign_status_folds_long_condition_names_rather_than_cutting_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from ariel.cli._tables import print_campaign_status

    names = [f"tournament_size_two_with_crossover_rate_one_half_variant_{v}" for v in "AB"]
    row = {"seed": 1, "status": "finished", "generations_done": 2, "generations": 2}
    print_campaign_status(
        [{**row, "condition": n, "evaluations": 8, "best_fitness": 0.1} for n in names], "c"
    )
    printed = capsys.readouterr().out
    assert "…" not in printed and "variant_A" in printed.replace("\n", "").replace(" ", "")
