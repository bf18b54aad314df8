"""Run folders that stand alone and can be trusted (issue 16): no writes through links, damage
detected by the manifest (`ariel verify`), what readers need recorded in run.json, strict JSON,
the software of every resumed segment."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from _helpers import (
    exit_code,
    one_error_line,
    snapshot,
    tiny_finished_run,
)

from ariel.cli import main
from ariel.recording import DamagedRunError, load_run, verify_run
from ariel.recording.store._files import UnsafePathError, atomic_write_json
from ariel.recording.store._list_runs import UNREADABLE, list_runs
from ariel.recording.store._lock import RunLock


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny co-evolution run (2 generations, serial): copy it before changing it."""
    return tiny_finished_run(tmp_path_factory, "trust", 3)


def _copy(run: Path, tmp_path: Path, name: str = "copy", *, status: str | None = None) -> Path:
    copy = tmp_path / name
    shutil.copytree(run, copy, symlinks=True)
    if status is not None:
        info = json.loads((copy / "run.json").read_text())
        info["status"] = status
        (copy / "run.json").write_text(json.dumps(info))
    return copy


# --- 1: loading a run folder runs no code from it ---------------------------------------------


class _Planted:
    """Unpickling this runs ``os.system``: what a crafted checkpoint would do."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (os.system, (f"touch {self.marker}",))


def test_a_crafted_pickle_checkpoint_runs_nothing(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pickle

    copy = _copy(finished, tmp_path, status="interrupted")
    (copy / "checkpoints" / "state.json").unlink()
    marker = tmp_path / "code-ran"
    (copy / "checkpoints" / "state.pkl").write_bytes(pickle.dumps(_Planted(marker)))
    before = snapshot(copy)
    assert exit_code(["resume", str(copy), "--quiet"]) == 2
    assert "pickle checkpoint of an older ariel, not loaded" in one_error_line(capsys)
    assert not marker.exists()
    assert snapshot(copy) == before
    assert len(load_run(copy).evaluations) > 0  # the tables still load
    assert not marker.exists()


def test_a_crafted_json_checkpoint_is_one_line(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path, status="interrupted")
    state = json.loads((copy / "checkpoints" / "state.json").read_text())
    state["state"]["population"] = [{"number": "os.system('x')", "surprise": 1}]
    (copy / "checkpoints" / "state.json").write_text(json.dumps(state))
    assert exit_code(["resume", str(copy), "--quiet"]) == 2
    assert "unreadable checkpoint (not a loop state" in one_error_line(capsys)


# --- 2: nothing written through a symbolic link ----------------------------------------------


def test_a_lock_file_linked_elsewhere_is_refused_and_the_target_kept(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path, status="interrupted")
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    (copy / ".lock").symlink_to(victim)
    assert exit_code(["resume", str(copy), "--quiet"]) == 2
    assert "is a symbolic link" in one_error_line(capsys)
    assert victim.read_text() == "precious\n"


def test_a_hard_linked_lock_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    os.link(victim, tmp_path / "run" / ".lock")
    with pytest.raises(UnsafePathError, match="hard link"), RunLock(tmp_path / "run"):
        pass
    assert victim.read_text() == "precious\n"


def test_a_lock_file_that_is_a_fifo_is_refused_naming_it(tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    os.mkfifo(tmp_path / "run" / ".lock")
    with (
        pytest.raises(UnsafePathError, match=r"\.lock': it is a FIFO, not a file a run writes"),
        RunLock(tmp_path / "run"),
    ):
        pass


def test_report_replaces_a_linked_figure_and_refuses_a_linked_folder(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path)
    victim = tmp_path / "victim.png"
    victim.write_text("precious\n")
    (copy / "report").mkdir()
    (copy / "report" / "fitness.png").symlink_to(victim)
    assert main(["report", str(copy), "--no-render"]) == 0
    capsys.readouterr()
    assert victim.read_text() == "precious\n"  # the link was replaced, not followed
    assert not (copy / "report" / "fitness.png").is_symlink()

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.rmtree(copy / "report")
    (copy / "report").symlink_to(elsewhere)
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    assert "'report' is a symbolic link" in one_error_line(capsys).replace(str(copy) + "/", "")
    assert list(elsewhere.iterdir()) == []


def test_a_planted_temporary_link_is_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / ".run.json.tmp").symlink_to(victim)
    atomic_write_json(tmp_path / "run" / "run.json", {"a": 1}, root=tmp_path / "run")
    assert victim.read_text() == "precious\n"
    assert json.loads((tmp_path / "run" / "run.json").read_text()) == {"a": 1}


def test_a_table_linked_out_of_the_folder_is_refused_on_read(
    finished: Path, tmp_path: Path
) -> None:
    copy = _copy(finished, tmp_path)
    outside = tmp_path / "outside.parquet"
    table = copy / "bodies" / "gen-000000.parquet"
    shutil.copy(table, outside)
    table.unlink()
    table.symlink_to(outside)  # same bytes: only the link is wrong
    with pytest.raises(DamagedRunError, match="symbolic link out of the run folder"):
        load_run(copy)


# --- 4: the manifest ---------------------------------------------------------------------------


def test_a_clean_run_verifies(finished: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert sorted(p.name for p in (finished / "manifests").iterdir()) == [
        "gen-000000.json",
        "gen-000001.json",
    ]
    assert main(["verify", str(finished)]) == 0
    assert capsys.readouterr().out.startswith("ok: ")


def test_a_deleted_generation_file_is_refused_by_resume_and_readers(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path, status="interrupted")
    (copy / "evaluations" / "gen-000000.parquet").unlink()
    before = snapshot(copy)
    assert exit_code(["resume", str(copy), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert "evaluations/gen-000000.parquet is missing" in line
    assert snapshot(copy) == before  # nothing written, the run not marked finished
    with pytest.raises(DamagedRunError, match=r"gen-000000\.parquet is missing"):
        load_run(copy)
    assert exit_code(["replay", str(copy), "best"]) == 2
    assert "is missing" in one_error_line(capsys)
    assert main(["verify", str(copy)]) == 1
    assert "damaged: evaluations/gen-000000.parquet is missing" in capsys.readouterr().out


def test_a_single_flipped_bit_is_caught(finished: Path, tmp_path: Path) -> None:
    copy = _copy(finished, tmp_path)
    path = copy / "trajectories" / "gen-000001.parquet"
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x04
    path.write_bytes(bytes(data))
    result = verify_run(copy)
    assert result.problems == [
        "trajectories/gen-000001.parquet has other bytes than when it was written (SHA-256)"
    ]
    with pytest.raises(DamagedRunError, match="other bytes"):
        load_run(copy).trajectories  # noqa: B018


def _as_made_before_manifests(run: Path) -> None:
    """``run`` as an ariel made before manifests left it: no manifests, no run.json keys that
    came with them (a run.json with them, or a manifests/ folder, is checked against them). Its
    ``plugins`` stay: run.json named them from the first run loop on (every pre-manifest folder
    was refused as damaged for having them)."""
    shutil.rmtree(run / "manifests")
    info = json.loads((run / "run.json").read_text())
    assert "plugins" in info
    for key in ("manifests", "segments", "maximise", "brain_only", "results_version"):
        del info[key]
    (run / "run.json").write_text(json.dumps(info))


def test_a_run_made_before_manifests_and_named_optimizers_reads_as_one(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Such a folder (run.json naming its plugins) was refused as damaged by every reader."""
    copy = _copy(finished, tmp_path)
    _as_made_before_manifests(copy)
    info = json.loads((copy / "run.json").read_text())
    del info["config"]["body"]["optimizer"], info["config"]["body"]["optimizer_options"]
    (copy / "run.json").write_text(json.dumps(info))
    run = load_run(copy)
    assert run.body_optimizer == "ga" and len(run.generations) == 2
    assert main(["report", str(copy), "--no-render"]) == 0
    capsys.readouterr()
    assert main(["verify", str(copy)]) == 0
    assert "a run made before manifests" in capsys.readouterr().out


def test_a_truncated_table_is_one_line(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path)
    with open(copy / "bodies" / "gen-000000.parquet", "r+b") as file:
        file.truncate(100)
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    assert "bodies/gen-000000.parquet has 100 bytes" in one_error_line(capsys)
    # Without a manifest (an old run) the decoding error itself is the one line.
    _as_made_before_manifests(copy)
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    assert "is not a readable Parquet table" in one_error_line(capsys)


def test_a_run_made_before_manifests_verifies_and_resume_adopts_them(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _copy(finished, tmp_path, status="interrupted")
    _as_made_before_manifests(copy)
    assert main(["verify", str(copy)]) == 0
    assert "a run made before manifests" in capsys.readouterr().out
    assert len(load_run(copy).evaluations) > 0
    assert main(["resume", str(copy), "--quiet"]) == 0
    capsys.readouterr()
    assert json.loads((copy / "run.json").read_text())["manifests"] == 1
    assert verify_run(copy).checked and verify_run(copy).ok


# --- 5, 6, 7, 8: run.json --------------------------------------------------------------------


def test_run_json_records_what_readers_need_and_is_strict_json(finished: Path) -> None:
    def refuse(token: str) -> None:
        raise AssertionError(f"not JSON: {token}")

    info = json.loads((finished / "run.json").read_text(), parse_constant=refuse)
    assert info["maximise"] is True and info["brain_only"] is False
    assert [segment["kind"] for segment in info["segments"]] == ["run"]


def test_readers_work_without_the_runs_plugins(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.recording.viewer._view import select_recordings

    copy = _copy(finished, tmp_path)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["task"]["fitness"] = "not_installed_here"  # as on a machine without it
    info["config"]["body"]["encoder"] = "not_installed_either"
    (copy / "run.json").write_text(json.dumps(info))
    run = load_run(copy)
    assert run.maximise is True and run.brain_only is False
    assert len(run.generations) == 2
    assert main(["report", str(copy), "--no-render"]) == 0
    assert main(["runs", str(tmp_path)]) == 0
    capsys.readouterr()
    from ariel.recording.viewer._view import ViewError

    with pytest.raises(ViewError, match="no Rerun recordings"):  # not an UnknownPluginError
        select_recordings(copy)
    assert exit_code(["replay", str(copy), "best"]) == 2
    line = one_error_line(capsys)
    assert "replay re-simulates with the run's plugins" in line and "not_installed" in line


@pytest.mark.parametrize("bad", [{"config": None}, {"run_id": None}, {"generations_done": "x"}])
def test_one_bad_run_json_shows_as_unreadable(
    finished: Path, tmp_path: Path, bad: dict, capsys: pytest.CaptureFixture[str]
) -> None:
    _copy(finished, tmp_path, "good")
    broken = _copy(finished, tmp_path, "broken")
    info = json.loads((broken / "run.json").read_text())
    info.update(bad)
    (broken / "run.json").write_text(json.dumps(info))
    statuses = {Path(r["path"]).name: r["status"] for r in list_runs(tmp_path)}
    assert statuses == {"broken": UNREADABLE, "good": "finished"}
    assert main(["runs", str(tmp_path)]) == 0
    assert UNREADABLE in capsys.readouterr().out


def test_a_resume_records_the_software_that_ran_it(finished: Path, tmp_path: Path) -> None:
    from ariel.recording.store._provenance import software_versions

    copy = _copy(finished, tmp_path, status="interrupted")
    info = json.loads((copy / "run.json").read_text())
    info["versions"]["mujoco"] = "0.0.1-edited"
    (copy / "run.json").write_text(json.dumps(info))
    assert main(["resume", str(copy), "--quiet"]) == 0
    segments = json.loads((copy / "run.json").read_text())["segments"]
    assert [s["kind"] for s in segments] == ["run", "resume"]
    assert segments[1]["versions"] == software_versions()  # read now, not copied
    assert segments[1]["from_generation"] == 2


def test_the_git_commit_of_a_run_takes_no_lock_in_the_checkout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`git status` refreshes .git/index under .git/index.lock unless told not to: a write
    outside the run folder, which a git command of the user's can fail on meanwhile."""
    from ariel.recording.store._provenance import git_commit

    source = Path(__file__).resolve().parents[3]
    if not (source / ".git").exists():
        pytest.skip("not run from a git checkout")
    calls = tmp_path / "calls"
    fake = tmp_path / "bin" / "git"
    fake.parent.mkdir()
    fake.write_text(f'#!/bin/sh\necho "$@" >> {calls}\necho 0123abc\n')
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}{os.pathsep}{os.environ['PATH']}")
    assert git_commit() == "0123abc-dirty"  # the fake's `status` output counts as changes
    lines = calls.read_text().splitlines()
    assert len(lines) == 2 and all(line.startswith("--no-optional-locks ") for line in lines)
