"""Which run the analysis notebooks read (analysis/run_choice.py): the newest finished one, a
relative ARIEL_RUN_DIR taken from where the command was typed, a wrong folder in one line. No
notebook is executed here: these are the helper's choices, on hand-made run.json files."""

from __future__ import annotations

import importlib.util
import json
import os
import sys
from pathlib import Path

import pytest

from ariel.recording.store._run_folder import RUN_FORMAT

ANALYSIS = Path(__file__).resolve().parents[2] / "analysis"


@pytest.fixture(scope="module")
def rc():
    spec = importlib.util.spec_from_file_location("run_choice", ANALYSIS / "run_choice.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("run_choice", module)
    spec.loader.exec_module(module)
    return module


def _run(root: Path, name: str, created: str, status: str, done: int) -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    info = {
        "format": RUN_FORMAT,
        "run_id": name,
        "status": status,
        "generations_done": done,
        "created": created,
        "config": {"generations": 3},
    }
    (folder / "run.json").write_text(json.dumps(info))
    return folder


def test_the_newest_finished_run_is_chosen_and_newer_unfinished_ones_are_named(rc, tmp_path):
    root = tmp_path / "runs"
    _run(root, "old-finished", "2026-01-01T00:00:00+00:00", "finished", 3)
    finished = _run(root, "new-finished", "2026-02-01T00:00:00+00:00", "finished", 3)
    # Newer, but thrown away: interrupted after a generation, and killed before its first.
    _run(root, "try-interrupted", "2026-03-01T00:00:00+00:00", "interrupted", 1)
    _run(root, "try-killed", "2026-04-01T00:00:00+00:00", "running", 0)
    (root / "not-a-run").mkdir()

    choice = rc.choose_run(environ={}, root=root)
    assert choice.path == finished
    assert choice.why.startswith(f"the newest finished run under {root}; passed over, newer: ")
    assert "try-killed (stopped (killed?), 0 generations)" in choice.why
    assert "try-interrupted (interrupted, 1 generations)" in choice.why
    assert "old-finished" not in choice.why


def test_without_a_finished_run_the_newest_with_a_finished_generation(rc, tmp_path):
    root = tmp_path / "runs"
    _run(root, "a", "2026-01-01T00:00:00+00:00", "interrupted", 2)
    b = _run(root, "b", "2026-02-01T00:00:00+00:00", "interrupted", 1)
    _run(root, "c", "2026-03-01T00:00:00+00:00", "interrupted", 0)  # no tables: never chosen
    choice = rc.choose_run(environ={}, root=root)
    assert choice.path == b
    assert "no finished run" in choice.why and "newest with a finished generation" in choice.why
    assert "passed over, newer: c (interrupted, 0 generations)" in choice.why


def test_no_usable_run_is_one_line(rc, tmp_path):
    root = tmp_path / "runs"
    with pytest.raises(rc.ChoiceError, match=r"^no run under .*: `make run` first") as empty:
        rc.choose_run(environ={}, root=root)
    _run(root, "c", "2026-03-01T00:00:00+00:00", "interrupted", 0)
    with pytest.raises(rc.ChoiceError, match=r"no run with a finished generation \(1 without\)"):
        rc.choose_run(environ={}, root=root)
    # IPython shows the message in one line instead of a traceback.
    assert empty.value._render_traceback_() == [f"error: {empty.value}"]
    assert "\n" not in str(empty.value)


def test_a_relative_ariel_run_dir_is_taken_from_where_the_command_was_typed(rc, tmp_path):
    """jupyter nbconvert at /x with ARIEL_RUN_DIR=data/runs/r: the kernel runs in analysis/,
    but $PWD (passed on by Jupyter) is /x, so /x/data/runs/r is read."""
    typed_in = tmp_path / "checkout"
    run = _run(typed_in / "data" / "runs", "r", "2026-01-01T00:00:00+00:00", "finished", 3)
    kernel = typed_in / "analysis"
    kernel.mkdir()
    environ = {"ARIEL_RUN_DIR": "data/runs/r", "PWD": str(typed_in)}
    choice = rc.choose_run(environ=environ, cwd=kernel)
    assert choice.path == run and choice.path.is_absolute()
    assert choice.why == "ARIEL_RUN_DIR=data/runs/r"
    # The environment variable wins over RUN_DIR in the notebook.
    assert rc.choose_run("elsewhere", environ=environ, cwd=kernel).path == run
    # Relative to the kernel's folder still works when $PWD is somewhere else.
    rel = {"ARIEL_RUN_DIR": "../data/runs/r", "PWD": str(tmp_path / "nowhere")}
    assert rc.choose_run(environ=rel, cwd=kernel).path == run
    # An absolute path is taken as it is.
    assert rc.choose_run(environ={"ARIEL_RUN_DIR": str(run)}, cwd=kernel).path == run


def test_dot_dot_after_a_linked_folder_is_the_folder_the_os_opens(rc, tmp_path):
    """From a linked folder, ../r is r beside the link's target, as for ariel and load_run;
    read as text (normpath) it was a decoy r beside the link."""
    (tmp_path / "real" / "deep").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "real" / "deep")
    meant = _run(tmp_path / "real", "r", "2026-01-01T00:00:00+00:00", "finished", 3)
    _run(tmp_path, "r", "2026-01-01T00:00:00+00:00", "finished", 3)  # the decoy
    environ = {"ARIEL_RUN_DIR": "../r", "PWD": str(tmp_path / "link")}
    assert rc.choose_run(environ=environ, cwd=tmp_path).path == meant


def test_a_relative_path_falls_back_to_the_repository_root(rc, tmp_path, monkeypatch):
    """Without $PWD (a kernel started by an editor), data/runs/<id> is the repository's."""
    repo = tmp_path / "repo"
    run = _run(repo / "data" / "runs", "r", "2026-01-01T00:00:00+00:00", "finished", 3)
    monkeypatch.setattr(rc, "REPO", repo)
    choice = rc.choose_run("data/runs/r", environ={}, cwd=tmp_path / "elsewhere")
    assert choice.path == run and choice.why == "RUN_DIR = 'data/runs/r'"


def test_a_missing_folder_is_one_line_naming_where_it_looked(rc, tmp_path):
    environ = {"ARIEL_RUN_DIR": "data/runs/typo", "PWD": str(tmp_path)}
    with pytest.raises(rc.ChoiceError) as error:
        rc.choose_run(environ=environ, cwd=tmp_path / "analysis")
    message = str(error.value)
    assert message.startswith("ARIEL_RUN_DIR=data/runs/typo: no such folder (looked in ")
    assert str(tmp_path / "data" / "runs" / "typo") in message
    assert str(rc.REPO / "data" / "runs" / "typo") in message
    assert "\n" not in message and error.value._render_traceback_() == [f"error: {message}"]
    with pytest.raises(rc.ChoiceError, match=r"^RUN_DIR=/no/such/run: no such folder$"):
        rc.choose_run("/no/such/run", environ={})


def test_open_run_turns_a_folder_that_is_not_a_run_into_one_line(rc, tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(rc.ChoiceError) as error:
        rc.open_run(environ={"ARIEL_RUN_DIR": str(tmp_path / "empty")})
    assert "is not an ariel run folder (no run.json)" in str(error.value)
    assert str(error.value).startswith(f"ARIEL_RUN_DIR={tmp_path / 'empty'}: ")


def test_a_relative_campaign_dir_and_the_newest_campaign(rc, tmp_path):
    root = tmp_path / "data" / "campaigns"
    for name, mtime in (("second", 2_000_000_000), ("first", 1_000_000_000)):
        (root / name).mkdir(parents=True)
        (root / name / "campaign.json").write_text("{}")
        os.utime(root / name / "campaign.json", (mtime, mtime))
    choice = rc.choose_campaign(environ={}, root=root)
    assert choice.path == root / "second" and choice.why == f"the newest campaign under {root}"
    environ = {"ARIEL_CAMPAIGN_DIR": "data/campaigns/first", "PWD": str(tmp_path)}
    assert rc.choose_campaign(environ=environ, cwd=tmp_path / "analysis").path == root / "first"
    with pytest.raises(rc.ChoiceError, match=r"^no campaign under "):
        rc.choose_campaign(environ={}, root=tmp_path / "none")


def test_a_run_without_a_finished_generation_is_one_line(rc, tmp_path):
    """Named, a run killed in its first generation ended the notebooks in tracebacks (an
    empty boxplot, "no finished evaluation"), not the one line `ariel report` gives."""
    young = _run(tmp_path, "young", "2026-11-28T10:00:00", "interrupted", 0)
    with pytest.raises(rc.ChoiceError) as error:
        rc.open_run(environ={"ARIEL_RUN_DIR": str(young)})
    assert str(error.value).endswith(
        "has no finished generation yet: nothing to analyse (resume it, or name another run)"
    )
    assert error.value._render_traceback_() == [f"error: {error.value}"]


def test_a_run_json_with_a_created_of_another_type_does_not_stop_the_choice(rc, tmp_path):
    """One run.json whose created was a number (sorted beside text) stopped the notebooks from
    opening any run of the folder: TypeError in the sort."""
    _run(tmp_path, "good", "2026-11-28T10:00:00", "finished", 3)
    odd = _run(tmp_path, "odd", "2026-11-28T11:00:00", "finished", 3)
    info = json.loads((odd / "run.json").read_text())
    (odd / "run.json").write_text(json.dumps({**info, "created": 17}))
    assert rc.newest_run(tmp_path).path == tmp_path / "good"
