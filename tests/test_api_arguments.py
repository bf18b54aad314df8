"""The Python API's arguments, for scripts and notebooks that no type checker reads: a wrong
type or a value nested past any config is one line naming the argument, before anything is
written (a truthy ``overwrite="no"`` must not replace a run); a plugin the workers cannot
import is refused before the run, and one they did not run the registration of is named so."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import ariel
from ariel.errors import ConfigError, NotARunError, UnknownPluginError
from ariel.evolution import load_config
from ariel.plugins import fitness_function, fitness_functions
from ariel.recording import (
    compare,
    fitness_label,
    joint_labels,
    lineage_statistics,
    list_runs,
    load_campaign,
    load_run,
    make_gallery,
    make_report,
    replay,
    verify_run,
    write_lineage_csv,
)
from ariel.recording.store._failures import plugin_failure
from ariel.runs import campaign_status, resume_campaign, resume_experiment, run_campaign


def _deep(levels: int) -> list[Any]:
    top: list[Any] = []
    inner = top
    for _ in range(levels):
        inner.append([])
        inner = inner[0]
    return top


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda out: ariel.run_experiment(out=out, overwrite="no"), "overwrite must be True or"),
        (lambda out: ariel.run_experiment(out=out, progress="no"), "progress must be True, F"),
        (lambda out: ariel.run_experiment(out=3), "run_experiment: out must be a path (a str o"),
        (lambda out: ariel.run_experiment(5, out=out), "config must be an ExperimentConfig, a T"),
        (lambda out: ariel.run_experiment(out=out, overrides="seed=2"), "overrides must be a l"),
        (lambda out: ariel.run_experiment(out=out, overrides=[None]), "overrides[0] must be a "),
        (lambda out: resume_experiment(None), "resume_experiment: run_dir must be a path"),
        (lambda out: run_campaign(out, overrides="seed=2"), "run_campaign: overrides must be "),
        (lambda out: resume_campaign(out, progress=1), "resume_campaign: progress must be True"),
        (lambda out: load_run(None), "load_run: path must be a path (a str or pathlib.Path), n"),
        (lambda out: list_runs(5), "list_runs: root must be a path (a str or pathlib.Path), no"),
        (lambda out: verify_run(None), "verify_run: run_dir must be a path"),
        # One folder as a str was read a character at a time ("'c' is not a run folder").
        (lambda out: compare(str(out)), "compare: paths must be a list of paths such as ['"),
        (lambda out: compare([out, 3]), "compare: paths[1] must be a path (a str or pathlib."),
        # A truthy "no" read as True: the CSV replaced, compare's files and a body drawn.
        (lambda out: write_lineage_csv(pd.DataFrame(), out, overwrite="no"), "overwrite must"),
        (lambda out: compare([out], write="no"), "compare: write must be True or False, not"),
        (lambda out: make_report(out, render="no"), "make_report: render must be True or Fa"),
        (lambda out: make_report(None), "make_report: run_dir must be a path"),
        (lambda out: make_gallery(out, render="no"), "make_gallery: render must be True or F"),
        (lambda out: make_gallery(out, progress="no"), "make_gallery: progress must be True,"),
        (lambda out: lineage_statistics(pd.DataFrame(), maximise="no"), "maximise must be Tr"),
        (lambda out: fitness_label("xy_displacement", "no"), "fitness_label: maximise must be"),
        (lambda out: load_campaign(None), "load_campaign: path must be a path (a str or p"),
        (lambda out: campaign_status(123), "campaign_status: campaign_dir must be a path"),
        (lambda out: joint_labels("abc"), "joint_labels: names must be a list of joint names"),
        (lambda out: replay(out, 5), "replay: eval_id must be an evaluation id or 'best', not"),
        (lambda out: write_lineage_csv(load_run, out), "write_lineage_csv: frame must be a lin"),
    ],
)
def test_an_argument_of_the_wrong_type_is_one_line_naming_it(
    tmp_path: Path, call: Any, message: str
) -> None:
    out = tmp_path / "run"
    with pytest.raises(TypeError) as info:
        call(out)
    assert message in str(info.value) and "\n" not in str(info.value)
    assert not out.exists()


def test_a_leading_tilde_is_the_home_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``out="~/x"`` made a folder named ``~`` in the current one (``rm -rf ~`` next)."""
    from ariel.utils import path_argument

    monkeypatch.setenv("HOME", str(tmp_path))
    assert path_argument("out", "~/runs/x") == tmp_path / "runs" / "x"
    assert path_argument("out", Path("a/~")) == Path("a/~")  # only a leading one
    with pytest.raises(NotARunError, match="nope"):
        load_run("~/nope")  # said "no such folder" of the literal '~/nope' before, too
    assert list_runs("~") == []


def test_worker_counts_are_checked_before_a_folder_is_made(tmp_path: Path) -> None:
    """``workers=True`` passed the check (a bool is an int) and failed after the run folder
    was made; a NumPy integer (a loop over np.arange) was refused though it is a count."""
    from ariel.runs._prepare import executor_settings

    out = tmp_path / "run"
    with pytest.raises(ConfigError, match=r"executor.workers: must be an integer >= 1 \(got True"):
        ariel.run_experiment(out=out, executor="local", workers=True)
    assert not out.exists()
    settings = executor_settings(load_config(), kind="local", workers=np.int64(2))
    assert settings.workers == 2 and type(settings.workers) is int


def test_numpy_scalars_in_config_data_are_numbers_and_other_objects_are_named() -> None:
    config = load_config({"seed": np.int64(5), "task": {"duration": np.float32(0.5)}})
    assert config.seed == 5 and type(config.seed) is int and config.task.duration == 0.5
    with pytest.raises(ConfigError, match=r"^task.duration: object is no config value type"):
        load_config({"task": {"duration": object()}})
    with pytest.raises(ConfigError, match=r"^seed: ndarray is no config value type"):
        load_config({"seed": np.arange(3)})


@pytest.mark.parametrize("generations", [-1, 1.5, float("nan"), "2", True])
def test_verify_run_takes_a_whole_number_of_generations(tmp_path: Path, generations: Any) -> None:
    with pytest.raises(ValueError, match="generations must be None or a whole number >= 0"):
        verify_run(tmp_path, generations=generations)


def test_data_nested_past_a_config_file_s_depth_is_one_config_error(tmp_path: Path) -> None:
    """A TOML file nested past 90 levels was already one line; overrides, dicts and genotype
    files ran Python out of stack (RecursionError, a traceback of thousands of lines)."""
    deep = "[" * 600 + "]" * 600
    with pytest.raises(ConfigError, match=r"--set body.options: nested too deeply \(at most 90"):
        load_config(None, [f"body.options={{x={deep}}}"])
    with pytest.raises(ConfigError, match=r"^config: nested too deeply \(at most 90 levels\)$"):
        load_config({"description": _deep(5000)})
    genotype = tmp_path / "deep.json"
    genotype.write_text("[" * 5000 + "]" * 5000)
    with pytest.raises(ConfigError, match=r"not a genotype \(its JSON nests too deeply\)$"):
        ariel.run_experiment(out=tmp_path / "run", overrides=[f"body.genotype={genotype}"])
    assert not (tmp_path / "run").exists()


@pytest.fixture
def notebook_fitness(monkeypatch: pytest.MonkeyPatch) -> Any:
    """A fitness function defined as a notebook cell defines one: in ``__main__``, no file."""
    monkeypatch.setitem(sys.modules, "__main__", types.ModuleType("__main__"))

    def cell_fitness(record: Any) -> float:
        return float(record.core_pos[-1, 0])

    cell_fitness.__module__ = "__main__"
    fitness_functions.register("cell_fitness", fitness_function(maximise=True)(cell_fitness))
    yield "cell_fitness"
    fitness_functions.unregister("cell_fitness")


def test_a_notebook_s_plugin_is_refused_for_worker_processes_before_the_run(
    tmp_path: Path, notebook_fitness: str
) -> None:
    out = tmp_path / "run"
    overrides = [f"task.fitness={json.dumps(notebook_fitness)}"]
    with pytest.raises(ConfigError) as info:
        ariel.run_experiment(out=out, executor="local", workers=1, overrides=overrides)
    assert str(info.value).startswith(
        "task.fitness: fitness function 'cell_fitness' is defined in this notebook (or "
        "interactive session), which the local executor's worker processes cannot import"
    )
    assert not out.exists()


def test_a_plugin_the_workers_never_registered_is_named_so_not_blamed(tmp_path: Path) -> None:
    """Registered under ``if __name__ == "__main__":``, the plugin passed the checks here and
    was unknown in the workers: "fix the plugin" was the wrong advice."""
    task = types.SimpleNamespace(eval_id="b000000-i000-c001")
    exc = UnknownPluginError("unknown fitness function 'gfit'; known: xy_displacement")
    line = str(plugin_failure(tmp_path, load_config(), task, exc))  # type: ignore[arg-type]
    assert "a worker process does not know a plugin this process knows" in line
    assert 'under `if __name__ == "__main__":`' in line and "fix the plugin" not in line
    assert (tmp_path / "error.log").is_file() and "\n" not in line


def test_a_worker_s_bad_environment_is_not_blamed_on_a_plugin(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Dask worker started with ARIEL_EVAL_THREADS=abc: "a plugin of the run (fitness
    function ..., controller ...) failed ...; fix the plugin" (probe G6)."""
    from ariel.evaluation import evaluation_threads
    from ariel.evaluation._threads import EVAL_THREADS_VARIABLE

    monkeypatch.setenv(EVAL_THREADS_VARIABLE, "abc")
    with pytest.raises(ConfigError) as raised:
        evaluation_threads()
    task = types.SimpleNamespace(eval_id="b000000-i000-c001")
    line = str(plugin_failure(tmp_path, load_config(), task, raised.value))  # type: ignore[arg-type]
    assert line.startswith("in evaluation b000000-i000-c001: ConfigError: ARIEL_EVAL_THREADS")
    assert "a Dask worker's environment" in line and "plugin" not in line


@pytest.mark.parametrize("after_run_json", [True, False])
def test_an_interrupt_while_the_folder_is_made_names_it_once_run_json_is_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, after_run_json: bool
) -> None:
    """Ctrl-C between run.json and the first generation printed no resume hint (the folder
    resumes from generation 0); before run.json there is nothing to resume."""
    from ariel.recording.store import RunFolder

    def interrupted(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    where = "start_segment" if after_run_json else "create"
    monkeypatch.setattr(RunFolder, where, interrupted)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt) as info:
        ariel.run_experiment(out=out, executor="serial", progress=False)
    assert getattr(info.value, "run_dir", None) == (out if after_run_json else None)
