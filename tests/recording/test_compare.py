"""`ariel compare`'s statistics on synthetic runs: a known difference is found (A12, p), in the
fitness's direction; identical conditions show none; the page embeds its figures."""

from __future__ import annotations

import base64
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ariel.recording._compare import RunCurve, compare_runs
from ariel.recording._compare_stats import a12, holm, pairwise_table
from ariel.recording._curves import best_so_far


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
    (row,) = result.stats.to_dict("records")
    assert (row["a"], row["b"], row["n_a"], row["n_b"]) == ("high", "low", 10, 10)
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
    assert len(result.stats) == 3  # a-b, a-c, b-c
    assert (result.stats["p_holm"] > 0.05).all() and (result.stats["better"] == "-").all()
    assert ((result.stats["a12"] - 0.5).abs() < 0.3).all()
    same = pairwise_table({"x": finals[0], "y": finals[0].copy()}, maximise=True)[0]
    assert same["a12"] == 0.5 and same["p_value"] == 1.0 and same["difference"] == 0.0


def test_the_page_embeds_every_figure_and_the_tables_are_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.recording import _compare_plots

    drawn = {}
    save = _compare_plots._save

    def keep(figure, path):
        drawn[path.stem] = figure
        return save(figure, path)

    monkeypatch.setattr(_compare_plots, "_save", keep)
    runs = [synthetic_run(c, s, 1.0 + s) for c in ("a", "b") for s in range(3)]
    result = compare_runs(
        runs, tmp_path / "compare", maximise=True, title="page", fitness_fn="xy_displacement"
    )
    assert sorted(result.figures) == ["best_so_far", "final_best", "morphology"]
    # axes with units, evaluations counted in whole numbers
    (curves,) = drawn["best_so_far"].axes
    assert curves.get_ylabel() == "best fitness: xy_displacement (m), higher is better"
    assert all(float(t).is_integer() for t in curves.get_xticks())
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
    markdown = (tmp_path / "compare" / "stats.md").read_text()
    assert "| A | B |" in markdown and "| a | b | 3 | 3 |" in markdown
    runs_csv = pd.read_csv(tmp_path / "compare" / "runs.csv")
    assert runs_csv["final_best"].tolist() == [1.0, 2.0, 3.0, 1.0, 2.0, 3.0]
