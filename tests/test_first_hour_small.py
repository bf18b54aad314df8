"""Small things a new user meets in the first hour: ``ariel runs --prune`` removes the runs that
failed or were interrupted before a generation finished, and nothing else; a campaign file, an
experiment file and a campaign folder handed to the other kind's command say which to use."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import pytest
from _helpers import exit_code, one_error_line

from ariel.cli import main


def _run_folder(path: Path, status: str, generations_done: int = 0) -> Path:
    """A run folder as `ariel run` leaves it: run.json (and whatever the test adds)."""
    path.mkdir(parents=True)
    info = {
        "format": 1,
        "run_id": path.name,
        "status": status,
        "generations_done": generations_done,
        "config": {"generations": 3},
    }
    (path / "run.json").write_text(json.dumps(info))
    return path


@pytest.fixture
def runs(tmp_path: Path) -> dict[str, Path]:
    root = tmp_path / "runs"
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("not ours")
    made = {
        "failed": _run_folder(root / "failed", "failed"),
        "interrupted": _run_folder(root / "interrupted", "interrupted"),
        "killed": _run_folder(root / "killed", "running"),  # run.json says running, no lock
        "finished": _run_folder(root / "finished", "finished", 3),
        "one_generation": _run_folder(root / "one_generation", "interrupted", 1),
        "checkpointed": _run_folder(root / "checkpointed", "failed"),
        "tables": _run_folder(root / "tables", "failed"),
        "noted": _run_folder(root / "noted", "failed"),  # the user's notes in it
        # a symbolic link to a folder that would be prunable, and that folder
        "target": _run_folder(outside / "linked_run", "failed"),
    }
    (made["checkpointed"] / "checkpoints").mkdir()
    (made["checkpointed"] / "checkpoints" / "state.json").write_text("{}")
    (made["tables"] / "evaluations").mkdir()
    (made["tables"] / "evaluations" / "gen-000000.parquet").write_bytes(b"")
    (made["noted"] / "notes.txt").write_text("why this run failed")
    (made["failed"] / "error.log").write_text("Traceback ...")  # a plugin failed: ours
    made["link"] = root / "link"
    made["link"].symlink_to(made["target"], target_is_directory=True)
    # inside a prunable folder: links out of the runs folder, which must survive
    (made["failed"] / "out").symlink_to(outside, target_is_directory=True)
    (made["failed"] / "file").symlink_to(outside / "keep.txt")
    made["root"], made["outside"] = root, outside
    return made


KEPT = ("finished", "one_generation", "checkpointed", "tables", "noted", "target")
PRUNED = ("failed", "interrupted", "killed")


def test_prune_asks_and_deletes_only_runs_without_a_finished_generation(
    runs: dict[str, Path], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    root = runs["root"]
    monkeypatch.setattr("sys.stdin", io.StringIO("n\n"))
    assert main(["runs", str(root), "--prune"]) == 0
    out = capsys.readouterr().out
    assert "3 run folder(s)" in out and "[y/N]" in out and "nothing deleted" in out
    listed = {line.split()[0] for line in out.splitlines() if line.startswith("  ")}
    assert listed == set(PRUNED)
    assert f"left alone: {runs['link']}: it is a symbolic link" in out
    assert (
        f"left alone: {runs['noted']}: it holds 'notes.txt', which no run writes (move it out, "
        "or delete the folder yourself)"
    ) in out
    assert all(runs[name].exists() for name in PRUNED)  # "n": nothing deleted

    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # no answer at all: no
    assert main(["runs", str(root), "--prune"]) == 0
    assert all(runs[name].exists() for name in PRUNED)
    monkeypatch.setattr("sys.stdin", None)  # no stdin (`<&-`): input() raised RuntimeError
    assert main(["runs", str(root), "--prune"]) == 0
    assert "nothing deleted" in capsys.readouterr().out
    assert all(runs[name].exists() for name in PRUNED)

    monkeypatch.setattr("sys.stdin", io.StringIO("y\n"))
    assert main(["runs", str(root), "--prune"]) == 0
    out = capsys.readouterr().out
    assert all(f"deleted {runs[name]}" in out for name in PRUNED)
    assert not any(runs[name].exists() for name in PRUNED)
    assert all(runs[name].is_dir() for name in KEPT)
    assert runs["link"].is_symlink() and (runs["target"] / "run.json").is_file()
    assert (runs["outside"] / "keep.txt").read_text() == "not ours"  # links inside: not followed

    assert main(["runs", str(root), "--prune"]) == 0  # nothing left to prune
    assert "nothing to prune under" in capsys.readouterr().out


def test_prune_yes_skips_the_question(
    runs: dict[str, Path], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("sys.stdin", io.StringIO("n\n"))  # never read
    assert main(["runs", str(runs["root"]), "--prune", "--yes"]) == 0
    assert "[y/N]" not in capsys.readouterr().out
    assert not any(runs[name].exists() for name in PRUNED)
    assert all(runs[name].is_dir() for name in KEPT)


def test_prune_leaves_a_running_run_alone(
    runs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.recording import RunLock

    with RunLock(runs["killed"]):  # now a process runs it
        assert main(["runs", str(runs["root"]), "--prune", "--yes"]) == 0
        assert runs["killed"].is_dir()
    out = capsys.readouterr().out
    assert f"deleted {runs['failed']}" in out and str(runs["killed"]) not in out


def test_prune_run_refuses_links_finished_runs_and_folders_elsewhere(
    runs: dict[str, Path],
) -> None:
    from ariel.recording.store._prune import PruneError, prune_run

    root = runs["root"]
    for path, message in (
        (runs["link"], "symbolic link is never followed"),
        (runs["finished"], "its status is 'finished'"),
        (runs["one_generation"], "generation(s) finished"),
        (runs["checkpointed"], "it holds a checkpoint"),
        (runs["tables"], "it holds a generation's evaluations table"),
        (runs["noted"], "it holds 'notes.txt', which no run writes"),
        (runs["target"], "is not a folder directly under"),
    ):
        with pytest.raises(PruneError, match=re.escape(message)):
            prune_run(root, path)
        assert path.is_dir()
    from ariel.recording import RunLock

    with RunLock(runs["failed"]), pytest.raises(PruneError, match="is in use by pid"):
        prune_run(root, runs["failed"])  # resumed between the listing and the deletion
    assert runs["failed"].is_dir()


def test_yes_without_prune_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(["runs", str(tmp_path), "--yes"]) == 2
    assert "--yes goes with --prune" in one_error_line(capsys, quiet=True)


def test_what_a_run_writes_at_the_top_of_its_folder_is_known_to_prune(tmp_path: Path) -> None:
    """`RUN_FOLDER_NAMES` in step with a real run's folder (Rerun recordings and a report): a
    name missing there would keep every interrupted run of that kind from being pruned."""
    from _helpers import ariel_run, tiny_run_toml

    from ariel.recording.store._prune import RUN_FOLDER_NAMES

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("names", 1, generations=1, record="rerun = true"))
    ariel_run(config, tmp_path / "run")
    assert exit_code(["report", str(tmp_path / "run"), "--no-render"]) == 0
    names = {path.name for path in (tmp_path / "run").iterdir()}
    assert {"run.json", "recordings", "run.rrd", "blueprint.rbl", "report"} <= names
    assert names <= RUN_FOLDER_NAMES


def test_a_campaign_file_an_experiment_file_and_a_campaign_folder_name_their_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: "unknown key 'base'", "base: Field required" and "not an ariel run folder (no
    run.json)", none saying what the file or folder is."""
    from _helpers import REPO

    campaign = REPO / "experiments" / "campaigns" / "inheritance.toml"
    experiment = REPO / "experiments" / "coevolve_flat.toml"
    assert exit_code(["run", str(campaign)]) == 2
    line = one_error_line(capsys)
    assert "is a campaign file (it has base, condition, seeds), not an experiment" in line
    assert line.endswith(f"ariel campaign run {campaign} (from Python: run_campaign)")
    assert exit_code(["campaign", "run", str(experiment), "--dry-run"]) == 2
    line = one_error_line(capsys)
    assert "is an experiment file (it has seed, generations, body," in line
    assert f"ariel run {experiment}, or name it as a campaign file's base" in line
    folder = tmp_path / "campaign"
    folder.mkdir()
    (folder / "campaign.json").write_text("{}")
    assert exit_code(["report", str(folder)]) == 2
    line = one_error_line(capsys)
    assert "is not an ariel run folder (a campaign folder: its runs are under runs/" in line
    assert f"ariel campaign status {folder} lists them" in line
    assert list(tmp_path.iterdir()) == [folder]  # nothing written
    # A run folder given to `runs`, a folder given to `campaign run`: "no runs under RUN" and
    # "campaign file 'DIR' not found" before.
    run = _run_folder(tmp_path / "runs" / "one", "finished")
    assert exit_code(["runs", str(run)]) == 2
    line = one_error_line(capsys)
    assert f"{str(run)!r} is a run folder; list the folder that holds it: " in line
    assert line.endswith(f"ariel runs {run.parent}")
    assert exit_code(["campaign", "run", str(folder)]) == 2
    assert f"campaign file {str(folder)!r} is a folder, not a TOML file" in one_error_line(capsys)


def test_runs_from_a_folder_without_data_runs_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """From another folder than the repository, it said "no runs under data/runs", as if the
    runs had gone."""
    monkeypatch.chdir(tmp_path)
    assert main(["runs"]) == 0
    said = capsys.readouterr().out
    assert said.startswith("no runs: data/runs does not exist here (") and "runs DIR)" in said
