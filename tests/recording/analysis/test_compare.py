"""`ariel compare`'s statistics on synthetic runs: a known difference is found (A12, p), in the
fitness's direction; identical conditions show none; the page embeds its figures. Its output
is safe to write from a folder someone sent: no write through a link, names escaped for each
medium, a default folder the user can see (issue 27)."""

from __future__ import annotations

import base64
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _helpers import exit_code, one_error_line, snapshot

from ariel.cli import main
from ariel.recording import compare, load_run
from ariel.recording.analysis._compare import RunCurve, compare_runs
from ariel.recording.analysis._compare_design import CompareError, check_comparable
from ariel.recording.analysis._compare_stats import NOT_DETECTABLE, a12, holm, pairwise_table
from ariel.recording.store._curves import best_so_far
from ariel.recording.store._files import UnsafePathError


def synthetic_run(
    condition: str, seed: int, final: float, evaluations: int = 40, *, maximise: bool = True
) -> RunCurve:
    """A run whose fitness improves to ``final`` (its best; up when ``maximise``, else down)
    over ``evaluations``, 8 per generation, with a failed evaluation in the middle."""
    rng = np.random.default_rng(seed)
    if maximise:
        fitness = final * np.sort(rng.uniform(0.2, 1.0, evaluations))
    else:
        fitness = final * np.sort(rng.uniform(1.0, 1.8, evaluations))[::-1]
    fitness[-1] = final
    status = ["ok"] * evaluations
    status[evaluations // 2] = "error"
    frame = pd.DataFrame(
        {
            "generation": np.arange(evaluations) // 8,
            "eval_id": [f"b{i:06d}-i000-c000" for i in range(evaluations)],
            "fitness": fitness,
            "status": status,
            "num_modules": rng.integers(3, 12, evaluations).astype(float),
            "symmetry": rng.uniform(0, 1, evaluations),
        }
    )
    return RunCurve(condition, seed, frame)


def test_unfinished_runs_and_runs_without_a_success_are_warned_about() -> None:
    """A stopped campaign (its runs all at one generation) read as a finished one, and runs of
    which every evaluation failed were left out of the tests without a word."""
    runs = [synthetic_run(c, seed, 1.0) for c in ("a", "b") for seed in (1, 2)]
    runs[0].info.update(status="interrupted")
    runs[1].info.update(status="running")
    runs[2].info.update(status="finished")
    runs[3].evaluations["fitness"] = -math.inf
    runs[3].evaluations["status"] = "error"
    compared = compare_runs(runs, None, maximise=True, write=False)
    assert (
        repr(compared)
        == "<Comparison comparison: 2 conditions, 4 runs, at 40 evaluations, 3 notes>"
    )
    notes = compared.notes
    assert notes[:2] == [
        "2 of 4 runs are not finished (1 interrupted, 1 running): compared at the generations "
        "they have finished; compare again once they finish",
        "1 run(s) have no successful evaluation (b seed 2): their fitness measures are missing "
        "from the tests (their evaluations' status and error say why)",
    ]
    for run in runs:
        run.info.update(status="finished")
    runs[3].evaluations["fitness"] = 1.0
    assert not any(
        "finished" in n or "success" in n
        for n in compare_runs(runs, None, maximise=True, write=False).notes
    )


def test_archives_of_different_sizes_are_noted() -> None:
    """A 64-cell grid's coverage beside a 32-cell CVT's was compared without a word."""
    runs = [synthetic_run(c, seed, 1.0) for c in ("grid", "cvt") for seed in (1, 2)]
    grid = {"kind": "grid", "bins": [8, 8]}
    for run in runs:
        run.info.update(archive=grid if run.condition == "grid" else {"kind": "cvt"})
        if run.condition == "cvt":
            run.info["archive"]["centroids"] = [[0.5, 0.5]] * 32
    said = "the runs' archives differ in size (32, 64 cells): coverage and norm_qd_score"
    notes = compare_runs(runs, None, maximise=True, write=False).notes
    assert any(note.startswith(said) for note in notes)
    for run in runs:
        run.info.update(archive=grid)
    assert not any(
        "archives differ" in n for n in compare_runs(runs, None, maximise=True, write=False).notes
    )


def test_best_so_far_follows_the_direction_and_skips_failures() -> None:
    frame = pd.DataFrame(
        {
            "generation": [0, 0, 0, 1],
            "eval_id": ["b1", "b0", "b2", "b3"],
            "fitness": [3.0, 5.0, -math.inf, 1.0],
            "status": ["ok", "error", "ok", "ok"],
        }
    )
    x, best = best_so_far(frame, maximise=True)  # order: b0 (error), b1, b2 (inf), b3
    assert x.tolist() == [1, 2, 3, 4]
    assert np.isnan(best[0]) and best[1:].tolist() == [3.0, 3.0, 3.0]
    assert best_so_far(frame, maximise=False)[1][1:].tolist() == [3.0, 3.0, 1.0]


def test_a12_counts_wins_and_half_ties_in_the_fitness_direction() -> None:
    a, b = np.array([1.0, 2.0, 3.0]), np.array([2.0, 0.0])
    wins = sum((x > y) + 0.5 * (x == y) for x in a for y in b) / 6
    assert a12(a, b, maximise=True) == pytest.approx(wins)
    assert a12(a, b, maximise=False) == pytest.approx(1 - wins)


def test_holm_multiplies_by_the_remaining_count_and_stays_monotone() -> None:
    adjusted = holm(np.array([0.01, 0.04, 0.03, 0.5]))
    assert adjusted.tolist() == pytest.approx([0.04, 0.09, 0.09, 0.5])


@pytest.mark.parametrize("maximise", [True, False])
def test_a_known_difference_is_found_in_the_fitness_direction(
    maximise: bool, tmp_path: Path
) -> None:
    rng = np.random.default_rng(3)
    high = [
        synthetic_run("high", s, 2.0 + 0.1 * rng.normal(), maximise=maximise) for s in range(10)
    ]
    low = [
        synthetic_run("low", 100 + s, 1.0 + 0.1 * rng.normal(), maximise=maximise)
        for s in range(10)
    ]
    result = compare_runs(high + low, tmp_path, maximise=maximise, title="synthetic")
    final, auc = result.stats.to_dict("records")  # the final best, then the AUC
    assert (final["measure"], auc["measure"]) == ("final best", "AUC")
    assert auc["a12"] == final["a12"] and auc["p_holm"] < 1e-3  # the anytime measure agrees
    row = final
    assert (row["a"], row["b"], row["n_a"], row["n_b"]) == ("high", "low", 10, 10)
    assert row["test"] == "Mann-Whitney U" and row["n_pairs"] is None  # no design: unpaired
    assert row["p_holm"] < 1e-3  # 10 vs 10, fully separated: p = 1.8e-4
    if maximise:  # every "high" run beats every "low" run
        assert row["a12"] == 1.0 and row["better"] == "high"
    else:  # lower is better: the same numbers, the other way round
        assert row["a12"] == 0.0 and row["better"] == "low"
    assert row["effect"] == "large"
    assert 0.8 < row["difference"] < 1.2 and row["ci_low"] < row["difference"] < row["ci_high"]
    assert row["ci_low"] > 0.5  # the CI excludes no difference


def test_identical_conditions_show_no_difference(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    finals = rng.normal(1.0, 0.2, size=(3, 8))
    runs = [
        synthetic_run(name, 10 * i + s, finals[i, s])
        for i, name in enumerate(("a", "b", "c"))
        for s in range(8)
    ]
    result = compare_runs(runs, tmp_path, maximise=True)
    assert len(result.stats) == 6  # a-b, a-c, b-c: final best and AUC
    assert (result.stats["p_holm"] > 0.05).all() and (result.stats["better"] == "-").all()
    assert ((result.stats["a12"] - 0.5).abs() < 0.3).all()
    assert (result.stats["effect"] != NOT_DETECTABLE).all()  # 8 vs 8 could detect one
    # k = 3: the omnibus test of independent samples, for each measure
    assert result.omnibus["test"].tolist() == ["Kruskal-Wallis", "Kruskal-Wallis"]
    assert (result.omnibus["p_value"] > 0.05).all()
    same = pairwise_table({"x": finals[0], "y": finals[0].copy()}, maximise=True)[0]
    assert same["a12"] == 0.5 and same["p_value"] == 1.0 and same["difference"] == 0.0


def test_the_page_embeds_every_figure_and_the_tables_are_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.recording.analysis import _compare_plots

    drawn = {}
    save = _compare_plots._save

    def keep(figure, path):
        drawn[path.stem] = figure
        return save(figure, path)

    monkeypatch.setattr(_compare_plots, "_save", keep)
    runs = [synthetic_run(c, s, 10.0 + s) for c in ("a", "b") for s in range(3)]
    result = compare_runs(
        runs, tmp_path / "compare", maximise=True, title="page", fitness_fn="xy_displacement"
    )
    assert sorted(result.figures) == ["best_so_far", "final_best", "morphology"]
    # axes with units, evaluations counted in whole numbers
    (curves,) = drawn["best_so_far"].axes
    assert curves.get_ylabel() == "best fitness: xy_displacement (m), higher is better"
    assert all(float(t).is_integer() for t in curves.get_xticks())
    # the y axis starts where the data starts (medians from about 2.4, bands lower), not at 0
    lowest = min(np.nanmin(line.get_ydata()) for line in curves.get_lines())
    assert 0.5 * lowest < curves.get_ylim()[0] < lowest
    # ... and each condition is one legend entry, its line drawn over its band
    legend = [t.get_text() for t in curves.get_legend().get_texts()]
    assert legend == ["a", "b"]
    assert "95 % bootstrap band" in curves.get_title()
    shapes = {a.get_title(): a for a in drawn["morphology"].axes if a.get_visible()}
    assert shapes["num_modules"].get_ylabel() == "modules"
    assert shapes["symmetry"].get_ylabel() == "score, 0 to 1"
    assert all(float(t).is_integer() for t in shapes["num_modules"].get_xticks())
    html = result.html.read_text()
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert len(images) == 3
    for name, data in zip(result.figures, images):
        assert base64.b64decode(data) == result.figures[name].read_bytes()
    assert 'src="http' not in html and "href=" not in html  # nothing outside the page
    csv = pd.read_csv(tmp_path / "compare" / "stats.csv")
    assert csv.loc[0, "a"] == "a" and csv.loc[0, "n_a"] == 3
    assert csv["measure"].tolist() == ["final best", "AUC"]
    markdown = (tmp_path / "compare" / "stats.md").read_text()
    assert "| measure | A | B | median A (mean ± sd) |" in markdown
    assert "| final best | a | b | 11 (11 ± 1) | 11 (11 ± 1) |" in markdown
    assert "| 0.50 (n=3 vs 3) | — (n too small) | - |" in markdown  # no label from 3 vs 3
    runs_csv = pd.read_csv(tmp_path / "compare" / "runs.csv")
    assert runs_csv["final_best"].tolist() == [10.0, 11.0, 12.0, 10.0, 11.0, 12.0]
    # what was compared, said on the page and in the README
    readme = (tmp_path / "compare" / "README.md").read_text()
    labels = [label for label, _ in result.about]
    assert labels == [
        "compared",
        "conditions",
        "budget",
        "seeds",
        "tests",
        "software",
        "git commit",
    ]
    for label, text in result.about:
        assert f"- **{label}**: {text}" in readme
        assert f"<th>{label}</th><td>{text}</td>" in html
    assert "compared at 40 evaluations per run" in dict(result.about)["budget"]
    assert "Mann-Whitney U" in dict(result.about)["tests"]
    assert result.notes[0].startswith("fewer than 5 runs per condition (fewest: 3)")
    assert result.notes[0] in readme and "Warnings" in html


# --- one budget for all ------------------------------------------------------------------------


def test_unequal_budgets_are_compared_at_the_smallest_common_one(tmp_path: Path) -> None:
    """3 generations of 8 evaluations against 2: every run at 16 evaluations, its best so far
    after its first 16 (the final best) and the mean of its best so far over 1..16 (AUC)."""
    runs = [synthetic_run("long", s, 2.0 + s, evaluations=24) for s in range(3)]
    runs += [synthetic_run("short", 10 + s, 1.0 + s, evaluations=16) for s in range(3)]
    result = compare_runs(runs, tmp_path, maximise=True, write=False)
    assert result.budget == 16 and not any(tmp_path.iterdir())  # write=False: no file
    assert result.notes[0] == (
        "the runs made 16 to 24 evaluations: compared at 16 evaluations per run (the smallest "
        "common budget; choose another with --at-evaluations N)"
    )
    for run, row in zip(runs, result.runs.to_dict("records")):
        _, best = best_so_far(run.evaluations, maximise=True)
        assert row["final_best"] == best[15] and row["compared_at"] == 16
        assert row["auc"] == pytest.approx(np.nanmean(best[:16]))
        assert row["evaluations"] == len(run.evaluations)
    long = result.runs[result.runs["condition"] == "long"]
    assert (long["final_best"] < 2.0 + np.arange(3)).all()  # not their best of all 24

    chosen = compare_runs(runs, tmp_path, maximise=True, at_evaluations=10, write=False)
    assert chosen.budget == 10 and "compared at 10 evaluations per run" in chosen.notes[0]
    for run, row in zip(runs, chosen.runs.to_dict("records")):
        assert row["final_best"] == best_so_far(run.evaluations, maximise=True)[1][9]
    with pytest.raises(CompareError, match="--at-evaluations 17 exceeds the 16 evaluations"):
        compare_runs(runs, tmp_path, maximise=True, at_evaluations=17, write=False)


def test_shared_seeds_are_paired_with_wilcoxon_and_friedman(tmp_path: Path) -> None:
    runs = [
        synthetic_run(name, s, 1.0 + s + 0.01 * i)  # the same seeds: the same curves + a shift
        for i, name in enumerate(("a", "b", "c"))
        for s in range(6)
    ]
    result = compare_runs(runs, tmp_path, maximise=True, paired=True, write=False)
    assert set(result.stats["test"]) == {"Wilcoxon signed-rank"}
    assert (result.stats["n_pairs"] == 6).all()
    assert result.omnibus["test"].tolist() == ["Friedman", "Friedman"]
    assert result.omnibus.loc[0, "n"] == 6
    seeds = dict(result.about)["seeds"]
    assert seeds.startswith("shared, common random numbers") and "0-5 in every condition" in seeds
    table = result.table()
    assert "A better (pairs)" in table.columns and table.loc[0, "A better (pairs)"] == "0 of 6"
    assert table.loc[0, "test"] == "Wilcoxon signed-rank, 6 pairs"
    assert list(result.omnibus_table()["test"]) == ["Friedman", "Friedman"]


def test_qd_columns_are_shown_per_condition_where_the_runs_have_them(tmp_path: Path) -> None:
    runs = [synthetic_run(c, s, 1.0 + s) for c in ("ga", "me") for s in range(2)]
    plain = compare_runs(runs, tmp_path, maximise=True, write=False)
    assert not any("qd_score" in label for label in plain.summary_table()[""])
    for run in runs:  # 5 generations of 8; the archive fills up
        if run.condition == "me":
            run.generations = pd.DataFrame(
                {"generation": range(5), "qd_score": [1.0, 2, 3, 4, 5], "coverage": 0.1}
            )
    result = compare_runs(runs, tmp_path, maximise=True, at_evaluations=20, write=False)
    summary = result.summary_table().set_index("")
    # at 20 evaluations, generation 1 (evaluations 9-16) is the last one wholly within them
    assert (
        summary.loc["qd_score: median", "me"] == "2"
        and summary.loc["coverage: median", "me"] == "0.1"
    )
    assert summary.loc["qd_score: median", "ga"] == "-"


# --- only runs measured the same way ------------------------------------------------------------

CONFIG = {
    "task": {"fitness": "xy_displacement", "options": {}, "duration": 8.0, "settle": 1.0},
    "world": {"name": "flat", "options": {}},
}


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("task.fitness", "forward_speed"),
        ("task.options", {"axis": "x"}),
        ("task.duration", 15.0),
        ("task.settle", 0.0),
        ("world.name", "rugged"),
        ("world.options", {"height": 0.1}),
    ],
)
def test_runs_measured_differently_are_refused_in_one_line(key: str, value: object) -> None:
    section, name = key.split(".")
    other = {**CONFIG, section: {**CONFIG[section], name: value}}
    with pytest.raises(CompareError) as refused:
        check_comparable([("run a", CONFIG), ("run a2", CONFIG), ("run b", other)])
    message = str(refused.value)
    assert "\n" not in message and message.startswith(f"the runs differ in {key}: ")
    assert "in run a, " in message and message.endswith(
        "only runs measured the same way (fitness, duration, settle, world) can be compared"
    )


def test_a_run_from_before_settle_counts_as_settle_0() -> None:
    old = {**CONFIG, "task": {k: v for k, v in CONFIG["task"].items() if k != "settle"}}
    settled_0 = {**CONFIG, "task": {**CONFIG["task"], "settle": 0.0}}
    check_comparable([("old", old), ("new", settled_0)])  # no error
    with pytest.raises(CompareError, match=r"task\.settle: 1\.0 in new, 0\.0 in old"):
        check_comparable([("new", CONFIG), ("old", old)])


# --- real runs through the command ----------------------------------------------------------------

TINY = {
    "name": "tiny",
    "seed": 1,
    "generations": 3,
    "body": {"options": {"number_of_modules": 10}, "population": 2, "offspring": 2},
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.3},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A tiny run of 3 generations, and a copy of it cut to 2 (its run.json says so)."""
    from ariel.evolution import run_experiment

    folder = tmp_path_factory.mktemp("compare")
    long, short = folder / "long", folder / "short"
    run_experiment(TINY, out=long, progress=False)
    shutil.copytree(long, short)
    for generation_2 in sorted(short.glob("**/gen-000002*"), reverse=True):  # cut it off
        shutil.rmtree(generation_2) if generation_2.is_dir() else generation_2.unlink()
    edit_run_json(short, generations_done=2, generations=2)
    return long, short


def edit_run_json(run_dir: Path, *, generations_done: int | None = None, **config: object) -> None:
    """Change run.json: ``generations_done``, and config keys (``task__duration=...``)."""
    path = run_dir / "run.json"
    info = json.loads(path.read_text())
    if generations_done is not None:
        info["generations_done"] = generations_done
    for key, value in config.items():
        *sections, name = key.split("__")
        target = info["config"]
        for section in sections:
            target = target[section]
        target[name] = value
    path.write_text(json.dumps(info))


def test_the_command_compares_runs_of_3_and_2_generations_at_the_smaller_budget(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    long, short = two_runs
    out = tmp_path / "out"
    assert main(["compare", str(long), str(short), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    evaluations = load_run(long).evaluations
    budget = int((evaluations["generation"] < 2).sum())
    assert (
        f"warning: the runs made {budget} to {len(evaluations)} evaluations: compared at "
        in printed
    )
    assert f"compared at {budget} evaluations per run" in printed
    assert (
        "warning: fewer than 5 runs per condition (fewest: 1): Mann-Whitney U cannot give p below 1"
        in printed
    )
    runs = pd.read_csv(out / "runs.csv")
    expected = best_so_far(evaluations, maximise=True)[1][budget - 1]
    assert runs["final_best"].tolist() == pytest.approx([expected, expected])
    readme = (out / "README.md").read_text()
    info = json.loads((long / "run.json").read_text())
    assert f"- **git commit**: {info['git_commit']}" in readme
    assert f"mujoco {info['versions']['mujoco']}" in readme
    assert "- `task.duration` = `0.3`" in readme  # the settings every run shares

    assert main(["compare", str(long), str(short), "--out", str(out), "--at-evaluations", "3"]) == 0
    assert "replacing the comparison that was there" in capsys.readouterr().out
    runs = pd.read_csv(out / "runs.csv")
    assert runs["final_best"].tolist() == pytest.approx(
        [best_so_far(evaluations, maximise=True)[1][2]] * 2
    )


@pytest.mark.parametrize(("value", "expected"), [("1000", "exceeds the"), ("0", "integer >= 1")])
def test_a_bad_at_evaluations_is_one_line_exit_2(
    two_runs: tuple[Path, Path],
    value: str,
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    long, short = two_runs
    argv = [
        "compare",
        str(long),
        str(short),
        "--out",
        str(tmp_path / "o"),
        "--at-evaluations",
        value,
    ]
    assert exit_code(argv) == 2
    assert expected in one_error_line(capsys, subcommand=True, quiet=True)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("task__duration", 0.5),
        ("task__settle", 2.5),
        ("world__name", "rugged"),
        ("task__fitness", "x"),
    ],
)
def test_the_command_refuses_runs_measured_differently(
    two_runs: tuple[Path, Path],
    key: str,
    value: object,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    long, _ = two_runs
    other = tmp_path / "other"
    shutil.copytree(long, other)
    edit_run_json(other, **{key: value})
    assert exit_code(["compare", str(long), str(other), "--out", str(tmp_path / "o")]) == 2
    line = one_error_line(capsys, quiet=True)
    assert f"the runs differ in {key.replace('__', '.')}: " in line and str(other) in line


# --- a folder someone sent: no write through a link, names escaped --------------------------


def test_a_linked_output_folder_is_refused_and_its_target_kept(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    victim = tmp_path / "home"
    victim.mkdir()
    (victim / ".bashrc").write_text("precious\n")
    out = tmp_path / "compare"
    out.symlink_to(victim)  # a received campaign's compare/ -> ~
    runs = [synthetic_run(c, s, 1.0 + s) for c in ("a", "b") for s in range(2)]
    with pytest.raises(UnsafePathError, match="is a symbolic link"):
        compare_runs(runs, out, maximise=True)
    long, short = two_runs
    assert exit_code(["compare", str(long), str(short), "--out", str(out)]) == 2
    assert "is a symbolic link" in one_error_line(capsys, quiet=True)
    assert snapshot(victim) == {".bashrc": b"precious\n"}


def test_a_linked_file_in_the_output_folder_is_replaced_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "bashrc"
    victim.write_text("precious\n")
    out = tmp_path / "compare"
    out.mkdir()
    for name in ("stats.md", "README.md", "runs.csv", "final_best.png", "compare.html"):
        (out / name).symlink_to(victim)
    (out / "omnibus.csv").symlink_to(tmp_path / "dangling")
    runs = [synthetic_run(c, s, 1.0 + s) for c in ("a", "b") for s in range(2)]
    result = compare_runs(runs, out, maximise=True)
    assert victim.read_text() == "precious\n" and not (tmp_path / "dangling").exists()
    assert result.replaced  # it held what looked like an earlier comparison
    assert not any(p.is_symlink() for p in out.iterdir())
    assert not (out / "omnibus.csv").exists()  # two conditions: none; the link removed
    assert "| final best | a | b |" in (out / "stats.md").read_text()


def test_a_comparison_being_written_into_the_folder_refuses_a_second_one(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two compares with one --out at once both exited 0 and left a mix of their files."""
    from ariel.recording import RunLock

    long, short = two_runs
    out = tmp_path / "compare"
    with RunLock(out, create=True, kind="comparison"):  # another compare, still writing
        assert exit_code(["compare", str(long), str(short), "--out", str(out)]) == 2
        line = one_error_line(capsys)
        assert f"comparison folder '{out}' is in use by pid " in line
        assert [p.name for p in out.iterdir()] == [".lock"]
    assert not out.exists()  # made for the lock, removed with it: it held nothing else
    out.mkdir()
    (out / ".stats.csv.0123abcd.tmp").write_text("half")  # a compare killed by SIGKILL
    assert exit_code(["compare", str(long), str(short), "--out", str(out)]) == 0
    assert (out / "compare.html").is_file() and not (out / ".lock").exists()
    assert not list(out.glob(".*.tmp"))  # removed under the lock: no other compare writes


def test_an_output_folder_of_other_files_or_a_file_is_refused_in_one_line(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    long, short = two_runs
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "README.md").write_text("my notes\n")
    (mine / "thesis.tex").write_text("chapter 1\n")
    assert exit_code(["compare", str(long), str(short), "--out", str(mine)]) == 2
    assert "holds files a comparison does not write ('thesis.tex')" in one_error_line(capsys)
    assert (mine / "README.md").read_text() == "my notes\n" and len(list(mine.iterdir())) == 2
    assert exit_code(["compare", str(long), str(short), "--out", str(mine / "thesis.tex")]) == 2
    assert "is a file, not a folder" in one_error_line(capsys)


CRAFTED = "x\nrm -rf ~ <script>alert(1)</script>"


def test_names_from_folders_are_escaped_for_each_medium(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A campaign id and condition names with a newline, HTML, a formula, rich markup and
    mathtext: each stays one name in stats.md, README.md, compare.html, the CSVs, the figures
    and the terminal."""
    from ariel.cli._campaign import _print_frame

    names = [CRAFTED, '=HYPERLINK("http://x","y")', "[/bold]$\\frac{$ \x1b[2J\x1b]0;t\x07"]
    runs = [synthetic_run(name, s, 1.0 + s + i) for i, name in enumerate(names) for s in range(2)]
    result = compare_runs(runs, tmp_path / "c", maximise=True, title=CRAFTED, fitness_fn=CRAFTED)
    for name in ("stats.md", "README.md"):
        text = (tmp_path / "c" / name).read_text()
        assert "<script>" not in text and "&lt;script&gt;" in text, name
        assert not any(line.startswith("rm -rf") for line in text.splitlines()), name
        assert "# x\\\\nrm -rf ~ &lt;script&gt;" in text, name  # the heading: one line
        assert "\x1b" not in text, name
    page = (tmp_path / "c" / "compare.html").read_text()
    assert "<script>" not in page and "&lt;script&gt;" in page and "\x1b" not in page
    assert not any(line.startswith("rm -rf") for line in page.splitlines())
    for name in ("runs.csv", "stats.csv", "summary.csv", "omnibus.csv"):
        frame = pd.read_csv(tmp_path / "c" / name)
        cells = [str(v) for column in frame.columns for v in frame[column]]
        assert not any(c.startswith(("=", "+", "@")) for c in cells), name
    conditions = pd.read_csv(tmp_path / "c" / "runs.csv")["condition"].tolist()
    assert """'=HYPERLINK("http://x","y")""" in conditions
    assert CRAFTED in conditions  # a CSV cell holds the newline as data, quoted
    assert "\x1b" not in (tmp_path / "c" / "runs.csv").read_text()  # `cat runs.csv` is safe
    assert "[/bold]$\\frac{$ \\x1b[2J\\x1b]0;t\\x07" in conditions
    assert set(result.figures) >= {"best_so_far", "final_best"}  # mathtext drew as text

    _print_frame(result.summary_table(), f"{result.title}: per condition")
    printed = capsys.readouterr().out
    assert "\x1b" not in printed and "\x07" not in printed and "[/bold]" in printed


def test_the_default_output_of_run_folders_is_a_new_folder_here(
    two_runs: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Not ``compare/`` in the runs' common parent (a folder the user never named), and a
    second comparison does not overwrite the first."""
    long, short = two_runs
    monkeypatch.chdir(tmp_path)
    written = []
    for _ in range(2):
        assert main(["compare", str(long), str(short)]) == 0
        line = capsys.readouterr().out.splitlines()[-1]  # printed relative to here
        folder = line.removeprefix("wrote ").split("/", 1)[0]
        assert folder.startswith("compare-") and "replacing" not in line
        assert f"(open {folder}/compare.html; " in line
        written.append(folder)
    assert written[0] != written[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(written)
    assert all((tmp_path / folder / "compare.html").is_file() for folder in written)
    assert not (long.parent / "compare").exists()
    odd = tmp_path / "it's"  # the printed path is quoted: `open` it as printed (probe G4)
    assert main(["compare", str(long), str(short), "--out", "it's"]) == 0
    line = capsys.readouterr().out.splitlines()[-1]
    assert "(open 'it'\"'\"'s/compare.html'; " in line and (odd / "compare.html").is_file()


# --- each run once, names a person can read, a clear --out (issue: compare reliability) ------


def test_a_folder_given_twice_counts_once(tmp_path: Path) -> None:
    from ariel.recording.analysis._compare import unique_folders

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (tmp_path / "sub").mkdir()
    (tmp_path / "link").symlink_to(a)
    given = [a, b, a, tmp_path / "sub" / ".." / "a", tmp_path / "link"]
    kept, notes = unique_folders(given)
    assert kept == [a, b]
    assert notes == [
        f"the same run was given 4 times: {str(a)!r}, {str(a)!r}, "
        f"{str(tmp_path / 'sub' / '..' / 'a')!r}, {str(tmp_path / 'link')!r} (one folder); "
        "counted once"
    ]
    assert unique_folders([a, b]) == ([a, b], [])


def test_the_command_counts_a_run_given_twice_or_copied_once(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``R R sub/../R`` and a copy of R's folder are one run; a run that only shares R's run
    id (``--out a/seed1``, ``--out b/seed1``) is another."""
    long, short = two_runs
    copy, other = tmp_path / "copy", tmp_path / "other"
    shutil.copytree(long, copy)
    shutil.copytree(long, other)
    info = json.loads((other / "run.json").read_text())
    info["created"] = "2001-01-01T00:00:00+00:00"  # the same run id, another run
    (other / "run.json").write_text(json.dumps(info))
    alias = long.parent / "." / long.name
    out = tmp_path / "out"
    argv = ["compare", str(long), str(short), str(long), str(alias), str(copy), str(other)]
    assert main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    runs = pd.read_csv(out / "runs.csv")
    assert sorted(runs["path"]) == sorted([str(long), str(short), str(other)])
    assert (
        f"warning: the same run was given 3 times: {str(long)!r}, {str(long)!r}, "
        f"{str(alias)!r} (one folder); counted once" in printed
    )
    assert (
        f"warning: the same run was given twice: {str(long)!r}, {str(copy)!r} (run id "
        f"{info['run_id']!r}: a copy); counted once" in printed
    )
    assert "counted once" in (out / "README.md").read_text()


def test_labels_name_the_conditions_of_run_folders(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    long, short = two_runs
    other = tmp_path / "other"
    shutil.copytree(long, other)
    edit_run_json(other, brain__sigma0=0.5)
    out = tmp_path / "out"
    argv = ["compare", str(long), str(short), str(other), "--out", str(out)]
    labels = ["--label", f"fresh={long}", "--label", f"fresh={other}", "--label", f"cut={short}"]
    assert main([*argv, *labels]) == 0
    assert "runs: fresh 2, cut 1" in capsys.readouterr().out
    runs = pd.read_csv(out / "runs.csv")
    assert runs["condition"].tolist() == ["fresh", "cut", "fresh"]
    readme = (out / "README.md").read_text()  # what each label stands for
    assert "fresh: brain.sigma0 = 1.0 \\| 0.5, generations = 3" in readme or (
        "fresh: brain.sigma0 = 1.0 | 0.5, generations = 3" in readme
    )
    assert "cut: brain.sigma0 = 1.0, generations = 2" in readme
    assert "each condition named by --label" in readme


def test_runs_of_another_results_version_are_another_condition(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """A run made by an ariel whose results differ is not pooled with today's for having the
    same config (nor told apart by keys it lacks: settle=- for a run from before task.settle,
    which compare reads as the 0 it was)."""
    from ariel.recording.analysis._compare_design import condition_settings

    long, _ = two_runs
    old = tmp_path / "old"
    shutil.copytree(long, old)
    info = json.loads((old / "run.json").read_text())
    info["results_version"] = 0
    info["created"] = "2001-01-01T00:00:00+00:00"  # another run, not a copy
    (old / "run.json").write_text(json.dumps(info))
    out = tmp_path / "out"
    assert main(["compare", str(long), str(old), "--out", str(out)]) == 0
    runs = pd.read_csv(out / "runs.csv")
    assert sorted(runs["condition"]) == ["results_version=0", "results_version=2"]
    without = {**info["config"], "task": {k: v for k, v in info["config"]["task"].items()}}
    without["task"].pop("settle")
    assert condition_settings(without)["task.settle"] == "0.0"  # the neutral value it had


@pytest.mark.parametrize(
    ("labels", "expected"),
    [
        (["bad name={long}", "b={short}"], "--label 'bad name': a label is 1 to 64 ASCII let"),
        (["{x65}={long}", "b={short}"], "a label is 1 to 64 ASCII letters"),
        (["é={long}", "b={short}"], "--label 'é': a label is 1 to 64 ASCII letters"),  # not \xe9
        (["a[red]={long}", "b={short}"], "--label 'a[red]': a label is"),
        (["a={long}"], "has no --label: label every run folder or none"),
        (["a={long}", "b={short}", "c={nowhere}"], "that folder is not one of the run folders"),
        (["a={long}", "b={long}/.", "c={short}"], "has two labels, 'a' and 'b'"),
        (["a={long}", "b={long}", "c={short}"], "has two labels, 'a' and 'b'"),
    ],
)
def test_a_bad_label_is_one_line_exit_2(
    two_runs: tuple[Path, Path],
    labels: list[str],
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    long, short = two_runs
    names = {"long": long, "short": short, "nowhere": tmp_path, "x65": "x" * 65}
    argv = ["compare", str(long), str(short), "--out", str(tmp_path / "o")]
    for label in labels:
        argv += ["--label", label.format(**names)]
    assert exit_code(argv) == 2
    assert expected in one_error_line(capsys, quiet=True)
    assert not (tmp_path / "o").exists()


def test_a_label_without_a_folder_is_a_usage_error(
    two_runs: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    long, short = two_runs
    assert exit_code(["compare", str(long), str(short), "--label", "fresh"]) == 2
    assert "expected NAME=RUN_DIR, not 'fresh'" in one_error_line(capsys, subcommand=True)


def test_automatic_names_stay_short_and_distinct() -> None:
    from ariel.recording.analysis._compare import NAME_LIMIT, condition_names

    assert condition_names(["brain.inherit"], [{"brain.inherit": "false"}]) == [
        "brain.inherit=false"
    ]  # short: the whole key, as before
    keys = [f"body.setting_{i:02d}" for i in range(30)] + ["body.options", "brain.options"]
    flats = [{k: str(v) for k in keys} for v in range(4)]
    flats[3]["body.options"] = '{"a": 1}'
    whole = [",".join(f"{k}={f[k]}" for k in keys) for f in flats]
    assert min(map(len, whole)) > 500
    names = condition_names(keys, flats)
    assert all(len(n) <= NAME_LIMIT for n in names) and len(set(names)) == 4
    assert names[0].startswith("setting_00=0,setting_01=0,")  # the keys' last components
    assert re.fullmatch(r".*~[0-9a-f]{8}", names[0])  # cut, with a hash of the whole name
    assert condition_names(keys, flats) == names  # stable: the same settings, the same name
    two = ["body.options", "brain.options", "body.population"]
    few = [
        {"body.options": "{}", "brain.options": str(v), "body.population": "1" * 15} for v in (1, 2)
    ]
    assert (
        condition_names(two, few)[0] == f"body.options={{}},brain.options=1,population={'1' * 15}"
    )


def test_long_differences_give_short_names_and_the_page_keeps_them_whole(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    long, _ = two_runs
    other = tmp_path / "other"
    shutil.copytree(long, other)
    edit_run_json(
        other,
        body__crossover_rate=0.9,
        body__tournament=3,
        brain__sigma0=0.25,
        brain__smoothing=0.75,
        brain__control_period=25,
    )
    out = tmp_path / "out"
    assert main(["compare", str(long), str(other), "--out", str(out)]) == 0
    conditions = pd.read_csv(out / "runs.csv")["condition"].tolist()
    assert all(len(c) <= 60 for c in conditions) and len(set(conditions)) == 2
    assert conditions[0].startswith("crossover_rate=0.5,tournament=2,control_period=50,")
    printed = capsys.readouterr().out
    assert f"runs: {conditions[0]} 1, {conditions[1]} 1" in printed
    whole = (
        "body.crossover_rate = 0.9, body.tournament = 3, brain.control_period = 25, "
        "brain.sigma0 = 0.25, brain.smoothing = 0.75"
    )
    assert f"{conditions[1]}: {whole}" in (out / "README.md").read_text()
    assert whole in (out / "compare.html").read_text()


def test_the_command_prints_names_with_markup_and_control_characters_as_text(
    two_runs: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run folder and a config name holding rich markup, mathtext and terminal control
    sequences: the command draws and prints them as text."""
    long, _ = two_runs
    crafted = "[/bold][red]$\\frac{$\x1b[2J\x1b]0;t\x07"
    first, second = tmp_path / "a[red]$\\frac{$\x1b]0;t\x07", tmp_path / "b[/x]"
    for i, folder in enumerate((first, second)):
        shutil.copytree(long, folder)
        info = json.loads((folder / "run.json").read_text())
        info["config"]["name"] = crafted
        info["created"] = f"2001-01-0{i + 1}T00:00:00+00:00"
        (folder / "run.json").write_text(json.dumps(info))
    out = tmp_path / "out"
    assert main(["compare", str(first), str(second), str(first), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    printed = captured.out + captured.err
    assert "\x1b" not in printed and "\x07" not in printed
    assert "[/bold][red]$\\frac{$\\x1b[2J" in printed  # the name as it is, one line
    assert f"the same run was given twice: {str(first)!r}, {str(first)!r}" in printed
    assert "a[red]$\\\\frac{$\\x1b]0;t\\x07'" in printed  # the folder's name: repr
    assert {"best_so_far.png", "final_best.png"} <= {p.name for p in out.iterdir()}


@pytest.mark.parametrize(
    ("make", "given", "expected"),
    [
        ("file", "afile/sub", "cannot make '{out}': '{base}/afile' is a file, not a folder"),
        (
            "dangling",
            "dangling",
            "it is a symbolic link (to '{base}/nowhere', which does not exist)",
        ),
        (
            "dangling",
            "dangling/sub",
            "cannot make '{out}': '{base}/dangling' is a symbolic link to '{base}/nowhere', "
            "which does not exist",
        ),
    ],
)
def test_an_output_folder_that_cannot_be_made_is_one_line_exit_2(
    two_runs: tuple[Path, Path],
    make: str,
    given: str,
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    long, short = two_runs
    (tmp_path / "afile").write_text("notes\n")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    out = tmp_path / given
    assert exit_code(["compare", str(long), str(short), "--out", str(out)]) == 2
    line = one_error_line(capsys, quiet=True)
    assert expected.format(out=out, base=tmp_path) in line
    assert (tmp_path / "afile").read_text() == "notes\n" and not (tmp_path / "nowhere").exists()


def test_many_conditions_are_announced_before_the_statistics(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from ariel.recording.analysis import _compare

    events: list[str] = []

    def counted(*args, **kwargs):
        events.append("statistics")
        return [], [], []  # the pairs themselves are not what this test is about

    monkeypatch.setattr(_compare, "_statistics", counted)
    runs = [synthetic_run(f"c{i}", 0, 1.0 + i, evaluations=8) for i in range(21)]
    compare_runs(runs, None, maximise=True, write=False, announce=events.append)
    assert events == [
        "21 conditions: testing 210 pairs of conditions for each of 2 measures, each with a "
        "bootstrap CI (the time grows with the square of the number of conditions)",
        "statistics",
    ]
    events.clear()
    compare_runs(runs[:20], None, maximise=True, write=False, announce=events.append)
    assert events == ["statistics"]


def test_the_command_announces_many_conditions_on_stderr(
    two_runs: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from ariel.recording.analysis import _compare

    monkeypatch.setattr(_compare, "MANY_CONDITIONS", 1)  # long and short: 2 conditions
    long, short = two_runs
    assert main(["compare", str(long), str(short), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert (
        err.startswith("note: 2 conditions: testing 1 pairs of conditions") and err.count("\n") == 1
    )


def test_the_command_prints_at_most_40_pairs_and_12_conditions(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """200 conditions are 19,900 pairs: the terminal gets the first rows and columns and the
    name of the file that has them all."""
    from ariel.cli._campaign import _print_capped

    pairs = pd.DataFrame({"pair": [f"c{i} vs c{i + 1}" for i in range(100)], "p": ["0.5"] * 100})
    _print_capped(pairs, "pairs", rows=40, columns=12, file="stats.md")
    out = capsys.readouterr().out
    assert "pairs (the first 40 of 100 rows; all in stats.md)" in " ".join(out.split())
    assert "c39 vs c40" in out and "c40 vs c41" not in out
    summary = pd.DataFrame([["runs", *["5"] * 30]], columns=["", *[f"k{i}" for i in range(30)]])
    _print_capped(summary, "per condition", rows=40, columns=12, file="summary.csv")
    out = capsys.readouterr().out
    assert "(the first 12 of 30 conditions; all in summary.csv)" in " ".join(out.split())
    assert "k11" in out and "k12" not in out
    _print_capped(pairs.head(3), "few", rows=40, columns=12, file="stats.md")
    assert "the first" not in capsys.readouterr().out  # nothing left out: nothing said


def test_a_compare_stopped_by_sigterm_says_so_in_one_line(
    two_runs: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """200 conditions take minutes: a batch system's SIGTERM ends it with one line, exit 143
    (it ended silently)."""
    import os
    import signal

    from ariel.recording import analysis

    def stopped(*args: object, **kwargs: object) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(10_000):  # the handler runs between bytecodes
            pass
        raise AssertionError("not stopped")

    monkeypatch.setattr(analysis, "compare", stopped)
    assert main(["compare", *map(str, two_runs), "--out", str(tmp_path / "out")]) == 143
    assert capsys.readouterr().err.splitlines() == ["interrupted (SIGTERM)"]  # one line


def test_one_condition_is_said_in_words(two_runs: tuple[Path, Path]) -> None:
    """``ariel compare RUN``: an empty table of pairs under "1 runs:", and no word on why."""
    comparison = compare([two_runs[0]], write=False)
    assert comparison.title == "1 run" and comparison.stats.empty
    assert any(
        note.startswith("one condition (")
        and note.endswith("no pair of conditions to test, only its summary")
        for note in comparison.notes
    )


def test_many_conditions_get_their_own_colours_and_a_legend_beside_the_figure(
    tmp_path: Path,
) -> None:
    """With 12 conditions, conditions 1 and 11 shared a colour, and the legend (24 entries:
    a line and a band each) ran off the top of the figure and covered its title."""
    from matplotlib.colors import to_hex
    from PIL import Image

    from ariel.recording import condition_colours
    from ariel.recording.analysis import _compare_plots as plots
    from ariel.recording.rerun import condition_colours as rerun_colours

    for count in (3, 12, 25, 40):
        names = [f"condition-{k}" for k in range(count)]
        colours = condition_colours(names)
        assert len(set(colours.values())) == count
        # The Rerun view's are the same (it repeated ten), the first ten matplotlib's C0-C9.
        assert {n: to_hex([c / 255 for c in rgb]) for n, rgb in rerun_colours(names).items()} == (
            colours
        )
        if count <= 20:  # beyond, evenly along turbo
            assert [colours[n] for n in names[:10]] == [
                to_hex(f"C{i}") for i in range(min(count, 10))
            ]
    grid = np.arange(1.0, 9.0)
    curves = {name: (grid, grid * k, grid * k - 1, grid * k + 1) for k, name in enumerate(names)}
    path = plots.best_so_far_figure(curves, tmp_path / "best.png", ylabel="best (m)")
    with Image.open(path) as image:
        wide = image.width
    few = dict(list(curves.items())[: plots.LEGEND_INSIDE])
    path = plots.best_so_far_figure(few, tmp_path / "few.png", ylabel="best (m)")
    with Image.open(path) as image:
        assert wide > image.width + 200  # 40 entries beside the axes, in two columns


def test_the_terminal_tables_wrap_long_condition_names_rather_than_cut_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Cut to "sigma0-0.1…", the A and B columns of a pair read the same."""
    from ariel.cli._tables import print_frame

    names = [f"sigma0-0.1_smoothing-0.{k}_a_long_tail_of_settings" for k in (2, 4)]
    frame = pd.DataFrame({f"column {k}": [names[0], names[1]] for k in range(12)})
    print_frame(frame, "pairs")
    printed = capsys.readouterr().out
    assert "…" not in printed and "..." not in printed


def test_runs_with_no_generation_within_the_budget_are_named(tmp_path: Path) -> None:
    """A condition whose first generation alone outgrew the budget had '-' for its lineage
    measures without a word (F2: no_learning's 48 evaluations against a budget of 32)."""
    runs = [synthetic_run(c, s, 1.0 + s, evaluations=40) for c in ("a", "b") for s in range(2)]
    for run in runs:
        run.lineage = pd.DataFrame(
            {"generation": range(5), "evaluations": range(8, 41, 8), "surviving_lineages": 2.0}
        )
        if run.condition == "b":  # one generation of 40: nothing whole within 20
            run.evaluations = run.evaluations.assign(generation=0)
    result = compare_runs(runs, tmp_path, maximise=True, at_evaluations=20, write=False)
    (note,) = [n for n in result.notes if "finish no generation" in n]
    assert note.startswith(
        "2 run(s) finish no generation within the 20 evaluations compared (b seed"
    )
    plain = compare_runs(runs[:2], tmp_path, maximise=True, at_evaluations=20, write=False)
    assert not any("finish no generation" in n for n in plain.notes)


def test_the_body_loop_makes_no_condition_of_brain_only_runs() -> None:
    """Two brain-only runs differing only in body.optimizer (or population, offspring...) ran
    the same experiment, yet compare named them two conditions (probe F5)."""
    from ariel.recording.analysis._compare_design import condition_settings

    a = {"body": {"encoder": "prebuilt", "genotype": "gecko", "optimizer": "map_elites"}}
    b = {"body": {"encoder": "prebuilt", "genotype": "gecko", "offspring": 40}}
    assert condition_settings(a, brain_only=True) == condition_settings(b, brain_only=True)
    assert condition_settings(a) != condition_settings(b)  # a co-evolution run: they differ


def test_runs_without_a_finished_generation_are_named_as_left_out(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """A running campaign's runs (or a whole condition) with no generation yet were dropped
    without a word, README.md still counting them (probes G1, G2)."""
    long, short = two_runs
    empty = tmp_path / "empty"
    shutil.copytree(long, empty)
    for generation in sorted(empty.glob("**/gen-*"), reverse=True):
        shutil.rmtree(generation) if generation.is_dir() else generation.unlink()
    info = json.loads((empty / "run.json").read_text())
    info.update(generations_done=0, status="interrupted", created="2001-01-01T00:00:00+00:00")
    (empty / "run.json").write_text(json.dumps(info))
    notes = compare([long, short, empty], write=False).notes
    assert f"1 of 3 runs left out: no finished generation yet ({empty})" in notes
    assert not any("left out" in n for n in compare([long, short], write=False).notes)


def test_a_comparison_is_never_written_inside_a_run_folder(
    two_runs: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out RUN/cmp``, or no --out from inside a run folder, wrote the comparison among the
    run's records, which report, export and view --screenshot refuse (probe G4)."""
    long, short = two_runs
    before = sorted(p.name for p in long.iterdir())
    assert main(["compare", str(long), str(short), "--out", str(long / "cmp")]) == 2
    assert f"is inside the run folder {str(long)!r}, whose records are never" in (
        capsys.readouterr().err
    )
    monkeypatch.chdir(long)
    assert main(["compare", str(long), str(short)]) == 2
    assert "is inside the run folder" in capsys.readouterr().err
    assert sorted(p.name for p in long.iterdir()) == before  # no folder left behind
