"""The lineage where researchers meet it: `Run.lineage` and `Campaign.lineages`, the public
names, ``ariel export RUN --lineage FILE.csv``, ``ariel compare``'s lineage measures and
figure, and ``ariel report``'s ``lineage.png``; all on one tiny run."""

from __future__ import annotations

import base64
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from _helpers import edit_json, exit_code, one_error_line, tiny_run_toml, with_run_id

import ariel
from ariel.body_phenotypes.robogen_lite.graph_io import graph_key
from ariel.recording import load_run
from ariel.recording.store._lineage import (
    ancestors,
    campaign_lineages,
    lineage,
    lineage_statistics,
    write_lineage_csv,
)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny co-evolution run of 4 generations (crossover on: bodies of two parents)."""
    folder = tmp_path_factory.mktemp("wiring")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("wiring", 3, generations=4))
    out = folder / "run"
    ariel.run_experiment(config, out=out, progress=False)
    return out


@pytest.fixture(scope="module")
def frame(run_dir: Path) -> pd.DataFrame:
    return lineage(load_run(run_dir))


def test_run_and_campaign_give_the_lineage_and_the_names_are_public(
    run_dir: Path, frame: pd.DataFrame, tmp_path: Path
) -> None:
    run = load_run(run_dir)
    pd.testing.assert_frame_equal(run.lineage(), frame)
    assert run.lineage().attrs == frame.attrs
    from ariel.recording import Campaign

    campaign = Campaign(path=tmp_path, info={}, runs={("a", 3): run})
    found = campaign.lineages()
    assert list(found) == [run.info["run_id"]] == list(campaign_lineages(campaign))
    pd.testing.assert_frame_equal(found[run.info["run_id"]], frame)
    import ariel.recording as recording
    from ariel.recording.store import _lineage

    for name in ("lineage", "write_lineage_csv", "lineage_statistics", "ancestors"):
        assert getattr(recording, name) is getattr(_lineage, name) and name in recording.__all__
    assert "lineage_statistics_by_run" in recording.__all__


def test_export_writes_the_lineage_csv_and_never_replaces_a_file(
    run_dir: Path, frame: pd.DataFrame, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "phylogeny.csv"
    assert exit_code(["export", str(run_dir), "--lineage", str(path)]) == 0
    assert f"wrote {path}: the lineage of {len(frame)} bodies" in capsys.readouterr().out
    expected = write_lineage_csv(frame, tmp_path / "expected.csv")
    assert path.read_text() == expected.read_text()
    assert path.read_text().startswith("id,ancestor_list,origin_time,destruction_time,")
    # an existing file, or a link to nowhere, is refused in one line and left alone
    path.write_text("precious\n")
    dangling = tmp_path / "dangling.csv"
    dangling.symlink_to(tmp_path / "nowhere")
    for target in (path, dangling):
        assert exit_code(["export", str(run_dir), "--lineage", str(target)]) == 2
        assert "already exists" in one_error_line(capsys, quiet=True)
    assert path.read_text() == "precious\n" and not (tmp_path / "nowhere").exists()
    # without --lineage, EVAL_ID and DIR are still needed; with it, both or neither
    for argv in (["export", str(run_dir)], ["export", str(run_dir), "best"]):
        assert exit_code(argv) == 2
        assert "give EVAL_ID and DIR" in one_error_line(capsys, quiet=True)
    other = tmp_path / "other.csv"
    argv = ["export", str(run_dir), "best", "--lineage", str(other)]
    assert exit_code(argv) == 2 and not other.exists()
    one_error_line(capsys, quiet=True)
    # both at once: the evaluation's folder and the lineage
    argv = ["export", str(run_dir), "best", str(tmp_path / "best"), "--lineage", str(other)]
    assert exit_code(argv) == 0
    assert (tmp_path / "best" / "body.xml").is_file()
    assert other.read_text() == expected.read_text()


def _copy_as_another_run(run_dir: Path, target: Path) -> Path:
    """The run again, as a run of its own (another run id and creation time)."""
    with_run_id(Path(shutil.copytree(run_dir, target)), "wiring-copy")
    edit_json(target / "run.json", lambda info: info.update(created="2001-01-01T00:00:00+00:00"))
    return target


def test_compare_adds_the_lineage_measures_and_figure(
    run_dir: Path, frame: pd.DataFrame, tmp_path: Path
) -> None:
    from ariel.recording import compare

    copy = _copy_as_another_run(run_dir, tmp_path / "copy")
    result = compare([run_dir, copy], out=tmp_path / "cmp", labels={run_dir: "a", copy: "b"})
    last = lineage_statistics(frame).iloc[-1]  # the budget is every evaluation: the last one
    assert result.runs["surviving_lineages"].tolist() == [last["surviving_lineages"]] * 2
    assert result.runs["best_depth"].tolist() == [last["best_depth"]] * 2
    measures = result.stats["measure"].tolist()
    assert measures == ["final best", "AUC", "surviving lineages", "best depth", "distinct bodies"]
    bodies = load_run(run_dir).bodies
    made = bodies[bodies["is_new"] & (bodies["graph"] != "")]["graph"].map(graph_key).nunique()
    assert result.runs["distinct_made"].tolist() == [made] * 2 and made > 1
    assert result.omnibus.empty  # two conditions
    summary = result.summary_table().set_index("")
    assert summary.loc["surviving lineages: median", "a"] == f"{last['surviving_lineages']:g}"
    assert "best depth: mean ± sd" in summary.index
    figure = result.figures["lineages"]
    assert figure == tmp_path / "cmp" / "lineages.png" and figure.read_bytes()[:4] == b"\x89PNG"
    html = result.html.read_text()
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert base64.b64encode(figure.read_bytes()).decode() in images
    assert "Lineage (co-evolution runs)" in html and "![lineages](lineages.png)" in (
        result.readme.read_text()
    )


def test_a_lineage_difference_names_the_higher_condition_in_either_fitness_direction() -> None:
    from ariel.recording.analysis._compare import RunCurve, compare_runs

    def curve(condition: str, seed: int, lineages: float) -> RunCurve:
        evaluations = pd.DataFrame(
            {
                "generation": np.repeat([0, 1], 4),
                "eval_id": [f"b{i:06d}-i000-c000" for i in range(8)],
                "fitness": np.linspace(1.0, 2.0, 8) + seed,
                "status": ["ok"] * 8,
            }
        )
        table = pd.DataFrame(
            {
                "generation": [0, 1],
                "evaluations": [4, 8],
                "surviving_lineages": [4.0, lineages],
                "best_depth": [0.0, 1.0],
            }
        )
        return RunCurve(condition, seed, evaluations, lineage=table)

    runs = [curve("many", s, 4.0) for s in range(6)] + [curve("few", s, 1.0) for s in range(6)]
    for maximise in (True, False):
        result = compare_runs(runs, None, maximise=maximise, write=False)
        rows = result.stats.set_index("measure")
        assert rows.loc["surviving lineages", "better"] == "higher: many"
        assert rows.loc["surviving lineages", "a12"] == 1.0  # P(a run of "many" is higher)
        assert rows.loc["best depth", "better"] == "-"  # the same everywhere
    plain = compare_runs(
        [RunCurve(c.condition, c.seed, c.evaluations) for c in runs],
        None,
        maximise=True,
        write=False,
    )
    assert plain.stats["measure"].unique().tolist() == ["final best", "AUC"]
    assert "surviving_lineages" not in plain.runs


def test_the_report_draws_the_ancestry_of_the_final_population(
    run_dir: Path, frame: pd.DataFrame
) -> None:
    from ariel.recording import make_report
    from ariel.recording.analysis._report_lineage import lineage_figure

    report = make_report(run_dir, render=False)
    path = run_dir / "report" / "lineage.png"
    assert path in report.written and path.read_bytes()[:4] == b"\x89PNG"
    (axes, _colorbar) = report.figures["lineage.png"].axes
    best = int(lineage_statistics(frame)["best_id"].iloc[-1])
    body = frame.loc[frame["id"] == best, "body_id"].iloc[0]
    chain = len(ancestors(frame, best))
    assert f"best body {body} " in axes.get_title()
    assert (f"{chain} ancestor" if chain else "a founder") in axes.get_title()
    assert axes.get_xlabel() == "generation"
    # a brain-only run has no lineage to draw: a note
    stub = SimpleNamespace(run=SimpleNamespace(brain_only=True), notes=[])
    lineage_figure(stub, True, figure=None, save=None)
    assert stub.notes == ["lineage.png: left out (brain-only run: one fixed body)"]


def test_equal_lineage_curves_stay_apart_and_end_in_a_dot(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Two conditions with the same medians drew one line over the other (one condition
    missing from the plot), and the last generation's value was a step of no width."""
    from ariel.recording.analysis import _compare_plots

    drawn = {}
    monkeypatch.setattr(_compare_plots, "_save", lambda figure, path: drawn.setdefault("f", figure))
    x, y = np.array([10.0, 20.0, 30.0]), np.array([4.0, 4.0, 3.0])
    same = (x, y, y, y)
    _compare_plots.lineages_figure({"surviving_lineages": {"a": same, "b": same}}, tmp_path / "l")
    lines = drawn["f"].axes[0].get_lines()
    steps = [line for line in lines if line.get_drawstyle() == "steps-post"]
    assert len({line.get_linestyle() for line in steps}) == 2
    dots = [line for line in lines if line.get_marker() == "o"]
    assert [tuple(line.get_xydata()[-1]) for line in dots] == [(30.0, 3.0)] * 2
