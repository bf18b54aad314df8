"""The run's progress: a live bar per generation on a terminal, one line per generation else."""

from __future__ import annotations

import io
import math
import re
import sys
import types

import pytest

from ariel.evolution import run_experiment
from ariel.evolution._progress import Progress
from ariel.recording import load_run

TINY = {
    "name": "progress",
    "seed": 3,
    "generations": 2,
    "body": {"options": {"number_of_modules": 6}, "population": 3, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 0.5},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


def test_the_live_display_counts_each_generation_and_the_run() -> None:
    stream = io.StringIO()
    with Progress(total=30, live=True, stream=stream) as progress:
        progress.start_generation(0, 18)
        progress.advance(6, best=1.5)
        rich = progress._rich
        generation = rich.tasks[0]
        assert (generation.description, generation.total, generation.completed) == ("gen 0", 18, 6)
        # one batch back: no ETA yet (from the start, the workers' start-up made it ~5x long)
        assert generation.fields["eta"] == "-" == rich.tasks[1].fields["eta"]
        assert rich.tasks[1].total == 30 and rich.tasks[1].completed == 6
        assert "best 1.5" in rich.tasks[1].fields["info"]
        progress.advance(12)
        progress.end_generation(0, 2.0, 1.0)
        progress.start_generation(1, 12)
        assert progress.generation_done == 0
        progress.advance(3)
        assert rich.tasks[0].completed == 3 and rich.tasks[0].total == 12
        assert rich.tasks[0].fields["eta"] != "-" and rich.tasks[1].fields["eta"] != "-"
        assert rich.tasks[1].completed == 21
    shown = stream.getvalue()
    assert "gen 0: evaluations 18/30, best 2, mean 1" in shown
    assert "eval/s" in shown and "ETA" in shown


def test_at_80_columns_the_bars_and_counts_stay_and_the_info_is_cut(monkeypatch) -> None:
    """Narrower than its whole line, rich shrank every column alike: both rows showed only
    'gen 1      6.4 eval/s  ETA 0s', no bar and no done/total."""
    from rich.console import Console

    monkeypatch.setenv("COLUMNS", "80")
    with Progress(total=3840, live=True, stream=io.StringIO()) as progress:
        progress.start_generation(1, 384)
        progress.advance(200, best=0.088642)
        progress._population = ", morphs 12/16, archive 30/100 cells, QD-score 12.5"
        progress._refresh()
        screen = Console(file=io.StringIO(), width=80)
        screen.print(progress._rich.get_renderable())
        rows = screen.file.getvalue().splitlines()
    generation, run = (row for row in rows if "eval/s" in row)
    assert "━" in generation and "200/384" in generation
    assert "╸" in run and "200/3840" in run and "best 0.08864" in run and run.endswith("…")


def test_without_a_terminal_one_line_per_generation() -> None:
    stream = io.StringIO()
    with Progress(total=10, stream=stream) as progress:  # StringIO is no terminal
        assert not progress.live
        progress.start_generation(0, 10)
        progress.advance(4)
        assert stream.getvalue() == ""  # nothing inside a generation
        progress.advance(6)
        progress.end_generation(0, 1.0, 0.5, ", 1 unstable")
    (line,) = stream.getvalue().splitlines()
    assert line.startswith("gen 0: evaluations 10/10, best 1, mean 0.5")
    assert line.endswith(", 1 unstable")


def test_the_driver_announces_each_generations_evaluations(tmp_path, monkeypatch) -> None:
    seen: list[tuple[int, int | None, int]] = []
    original_start, original_end = Progress.start_generation, Progress.end_generation

    def start(self: Progress, generation: int, evaluations: int | None = None) -> None:
        original_start(self, generation, evaluations)
        seen.append((generation, evaluations, 0))

    def end(self: Progress, generation: int, *args: object, **kwargs: object) -> None:
        number, evaluations, _ = seen[-1]
        seen[-1] = (number, evaluations, self.generation_done)
        original_end(self, generation, *args, **kwargs)

    monkeypatch.setattr(Progress, "start_generation", start)
    monkeypatch.setattr(Progress, "end_generation", end)
    run_experiment(TINY, out=tmp_path / "run", progress=False)
    # 3 bodies then 2 offspring, each a brain run of 3 x 2: the bar fills exactly.
    assert seen == [(0, 18, 18), (1, 12, 12)]


def test_the_live_best_is_the_runs_never_falling_and_survives_a_resume(tmp_path, monkeypatch):
    """The run row's best was this generation's: it fell at every generation's start, and a
    resumed run forgot what the generations before had found (0.0886 before, 0.0016 after)."""
    from ariel.evolution import resume_experiment

    bests: list[tuple[str, float]] = []
    original_advance, original_end = Progress.advance, Progress.end_generation

    def advance(self: Progress, evaluations: int, best: float | None = None) -> None:
        bests.append(("batch" if evaluations else "start", math.nan if best is None else best))
        original_advance(self, evaluations, best)

    def end(self: Progress, generation: int, best: float, *args: object, **kwargs: object):
        bests.append(("end", best))
        original_end(self, generation, best, *args, **kwargs)

    monkeypatch.setattr(Progress, "advance", advance)
    monkeypatch.setattr(Progress, "end_generation", end)
    config = {**TINY, "generations": 3}
    with monkeypatch.context() as patch:  # stopped after generation 0: resumed for 1 and 2
        original = Progress.start_generation

        def stop_at_1(self: Progress, generation: int, evaluations: int | None = None) -> None:
            if generation == 1:
                raise KeyboardInterrupt
            original(self, generation, evaluations)

        patch.setattr(Progress, "start_generation", stop_at_1)
        with pytest.raises(KeyboardInterrupt):
            run_experiment(config, out=tmp_path / "run", progress=False)
    resume_experiment(tmp_path / "run", progress=False)
    values = [best for _, best in bests if not math.isnan(best)]
    assert [kind for kind, _ in bests].count("end") == 3
    assert values == sorted(values)  # maximised: the run's best never falls
    # the resumed run shows its best so far before its first new batch (it showed "-")
    (start,) = [k for k, (kind, _) in enumerate(bests) if kind == "start"]
    assert bests[start][1] == bests[start - 1][1] and bests[start - 1][0] == "end"


@pytest.mark.parametrize("seconds", [0, 5, 75, 4000])
def test_eta_reads_as_time(seconds: int) -> None:
    from ariel.evolution._progress import eta_text

    text = eta_text(seconds, 1.0)
    assert text == {0: "0s", 5: "5s", 75: "1m15s", 4000: "1h06m"}[seconds]


def test_the_line_says_distinct_bodies_and_the_archives_quality() -> None:
    stream = io.StringIO()
    archive = {
        "coverage": 14 / 64,
        "qd_score": 3.41,
        "norm_qd_score": 3.41 / 64,
        "filled": 14,
        "cells": 64,
    }
    with Progress(total=10, stream=stream) as progress:
        progress.advance(5)
        progress.end_generation(0, 1.0, 0.5, morphs=(5, 8), archive=archive)
        progress.advance(5)
        progress.end_generation(1, 1.0, 0.5, ", 1 unstable")  # brain-only: neither
    first, second = stream.getvalue().splitlines()
    assert first.startswith(
        "gen 0: evaluations 5/10, best 1, mean 0.5, morphs 5/8, coverage 22% (14/64), "
        "qd_score 3.41, norm_qd_score 0.05328, "
    )
    assert second.startswith("gen 1: evaluations 10/10, best 1, mean 0.5, ")
    assert "morphs" not in second and "qd_score" not in second


def _value(line: str, name: str) -> str:
    return re.search(rf"{name} ([^,]+)", line).group(1)


@pytest.mark.parametrize("optimizer", ["ga", "map_elites"])
def test_a_coevolution_run_prints_what_its_records_hold(optimizer: str, tmp_path, capsys) -> None:
    config = {**TINY, "body": {**TINY["body"], "optimizer": optimizer}}
    run_experiment(config, out=tmp_path / "run", progress=True)  # no terminal: plain lines
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("gen ")]
    run = load_run(tmp_path / "run")
    generations = run.generations
    assert len(lines) == len(generations) == 2
    for line, row in zip(lines, generations.itertuples()):
        alive = int((run.population["generation"] == row.generation).sum())
        assert _value(line, "morphs") == f"{row.distinct_bodies}/{alive}"
        assert 1 <= row.distinct_bodies <= alive
        if optimizer == "map_elites":
            assert _value(line, "coverage").startswith(f"{row.coverage:.0%} (")
            assert _value(line, "qd_score") == f"{row.qd_score:.4g}"
            assert _value(line, "norm_qd_score") == f"{row.norm_qd_score:.4g}"
        else:
            assert "coverage" not in line and "qd_score" not in line


def test_a_brain_only_run_prints_no_morphologies(tmp_path, capsys) -> None:
    config = {
        **TINY,
        "body": {"encoder": "prebuilt", "genotype": "gecko"},
        "brain": {"popsize": 2, "iterations": 1},
        "task": {"duration": 0.2},
    }
    run_experiment(config, out=tmp_path / "run", progress=True)
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("gen ")]
    assert len(lines) == 2 and not any("morphs" in line for line in lines)
    # best: the fixed body's best so far; mean: of the generation's CMA-ES candidates, as
    # `ariel report` draws it (the population's mean would be its one body's best again)
    run = load_run(tmp_path / "run")
    evaluations = run.evaluations[run.evaluations["fitness"].map(math.isfinite)]
    means = evaluations.groupby("generation")["fitness"].mean()
    for line, row in zip(lines, run.generations.itertuples()):
        assert _value(line, "best") == f"{row.best_fitness:.4g}"
        assert _value(line, "mean of candidates") == f"{means[row.generation]:.4g}"
    assert any(means[g] != run.generations["best_fitness"][g] for g in means.index)


class _Stream(io.StringIO):
    def __init__(self, tty: bool) -> None:
        super().__init__()
        self.tty = tty

    def isatty(self) -> bool:
        return self.tty


@pytest.mark.parametrize(
    ("stdout", "stderr", "shell", "shown"),
    [
        (False, False, None, False),  # a pipe, a batch job's log, pytest
        (True, False, None, True),  # a terminal
        (False, True, None, True),  # stdout piped (| tee), stderr on the terminal
        (False, False, types.SimpleNamespace(kernel=object()), True),  # a Jupyter kernel
        (False, False, types.SimpleNamespace(), False),  # IPython without a kernel, no terminal
    ],
)
def test_progress_is_shown_by_default_only_where_someone_watches(
    stdout: bool, stderr: bool, shell: object, shown: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.evolution._progress import auto_progress, shows_progress

    monkeypatch.setattr(sys, "stdout", _Stream(stdout))
    monkeypatch.setattr(sys, "stderr", _Stream(stderr))
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: shell))
    assert auto_progress() is shown
    assert shows_progress(None) is shown
    assert shows_progress(True) is True and shows_progress(False) is False


def test_run_experiments_default_progress_is_the_automatic_one(tmp_path, monkeypatch, capsys):
    import ariel.evolution._progress as progress

    config = {**TINY, "generations": 1}
    run_experiment(config, out=tmp_path / "quiet")  # pytest: no terminal, no notebook
    assert capsys.readouterr().out == ""
    monkeypatch.setattr(progress, "auto_progress", lambda: True)  # as on a terminal
    run_experiment(config, out=tmp_path / "watched")
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("run watched: ") and lines[1].startswith("gen 0: ")
    run_experiment(config, out=tmp_path / "off", progress=False)
    assert capsys.readouterr().out == ""


def test_a_decoded_graph_no_key_is_made_of_is_stored_as_no_graph() -> None:
    """An encoder whose decode gave an empty graph mid-run crashed the run unattributed
    (NetworkXPointlessConcept from the graph key), and readers would call it damaged."""
    import networkx as nx

    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko_graph
    from ariel.evolution._bodies import graph_text

    assert graph_text(nx.DiGraph()) == ""
    assert '"nodes": [{' in graph_text(gecko_graph())
