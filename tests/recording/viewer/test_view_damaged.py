"""Damaged or foreign files in a run folder, as `ariel view` and `ariel watch` meet them: an
evaluation's recording is re-simulated instead, any other file handed to the viewer is refused
in one line naming it, a watch of an ended run says the damage in one line (never waits for
ever), and a browser that cannot be run is said so."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

rr = pytest.importorskip("rerun")

from _helpers import TINY_QD, exit_code, one_error_line, repo_env  # noqa: E402

from ariel.errors import ArielError, BrowserError, ViewError  # noqa: E402
from ariel.evolution import run_experiment  # noqa: E402
from ariel.recording import RunLock, load_run  # noqa: E402
from ariel.recording.viewer._browser import HeadlessChromium, find_chromium  # noqa: E402
from ariel.recording.viewer._select import best_evaluations, select_recordings  # noqa: E402


@pytest.fixture(scope="module")
def qd_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("damaged") / "qd"
    run_experiment(TINY_QD, out=out, progress=False)
    return out


@pytest.fixture
def copy(qd_run: Path, tmp_path: Path) -> Path:
    shutil.copytree(qd_run, tmp_path / "qd")
    return tmp_path / "qd"


def _best(run: Path) -> Path:
    """The best evaluation's own recording."""
    table = load_run(run).evaluations
    row = best_evaluations(table, 1, maximise=True).iloc[0]
    path = run / "recordings" / f"gen-{int(row['generation']):06d}" / f"{row['eval_id']}.rrd"
    assert path.is_file()
    return path


def _damage(path: Path, how: str) -> None:
    if how == "truncated":
        os.truncate(path, path.stat().st_size // 2)
    elif how == "emptied":
        path.write_bytes(b"")
    else:
        path.write_text("not a recording\n")


@pytest.mark.parametrize("how", ["truncated", "emptied", "text"])
def test_a_damaged_evaluation_recording_is_re_simulated_with_a_note(
    copy: Path, how: str, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(copy)
    _damage(best, how)
    for chosen in (select_recordings(copy), select_recordings(copy, eval_id=best.stem)):
        shown = chosen.overview or chosen.recordings[0]
        assert shown.parent.name == "replays" and shown.stem == best.stem  # re-simulated
    err = capsys.readouterr().err
    assert best.name in err and "Rerun" in err and "Traceback" not in err
    assert "RerunWarning" not in err


def test_each_recording_is_read_once_to_choose_and_check_it(
    copy: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ariel.recording.viewer._rerun_files as rerun_files

    reads: list[str] = []
    real = rerun_files._read
    monkeypatch.setattr(
        rerun_files, "_read", lambda path, **kw: reads.append(path.name) or real(path, **kw)
    )
    chosen = select_recordings(copy)
    assert chosen.overview is not None and sorted(reads) == sorted({*reads})
    assert chosen.overview.name in reads and "run.rrd" in reads
    reads.clear()
    select_recordings(copy, eval_id=chosen.overview.stem)
    assert reads == []  # unchanged since: not read again
    os.utime(chosen.overview, ns=(1, 1))  # changed: read again
    select_recordings(copy, eval_id=chosen.overview.stem)
    assert reads == [chosen.overview.name]


def test_another_evaluation_s_recording_copied_over_is_not_shown_as_this_one(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(copy)
    other = next(p for p in best.parent.glob("b*.rrd") if p != best)
    shutil.copyfile(other, best)
    shown = select_recordings(copy).overview
    assert shown is not None and shown.parent.name == "replays"
    assert f"holds recording {other.stem!r}" in capsys.readouterr().err


def _campaign_of(run: Path) -> Path:
    """A campaign folder around ``run`` (its one run), for `ariel view CAMPAIGN`."""
    folder = run.parent / "campaign"
    shutil.copytree(run, folder / "runs" / "condition=a" / "seed=1")
    entry = {"condition": "a", "seed": 1, "path": "runs/condition=a/seed=1", "run_id": "a-1"}
    entry["config"] = {}
    info = {"format": 1, "campaign_id": "c", "conditions": [{"name": "a"}], "runs": [entry]}
    (folder / "campaign.json").write_text(json.dumps(info))
    shutil.copyfile(run / "run.rrd", folder / "campaign.rrd")
    return folder


@pytest.mark.parametrize(
    ("damaged", "how", "options"),
    [
        ("recordings/gen-000000/evaluations.rrd", "text", {"generation": 0}),
        ("recordings/gen-000000/evaluations.rrd", "truncated", {"generation": 0}),
        ("generation.rbl", "text", {"generation": 0}),
        ("campaign.rrd", "truncated", {}),
    ],
)
def test_a_damaged_file_for_the_viewer_is_refused_in_one_line_naming_it(
    copy: Path, damaged: str, how: str, options: dict
) -> None:
    folder = _campaign_of(copy) if damaged == "campaign.rrd" else copy
    _damage(folder / damaged, how)
    with pytest.raises(ViewError) as caught:
        select_recordings(folder, **options)
    line = str(caught.value)
    assert f"{damaged!r}" in line and "Rerun file" in line and "\n" not in line


def _poll_once(run: Path) -> None:
    from ariel.recording.viewer._watch_run import RunSource

    source = RunSource(run)
    rec = rr.RecordingStream("ariel", recording_id="test")  # no sink: kept in memory
    try:
        source.poll(rec)
    finally:
        source.close()


def test_watching_an_ended_run_with_a_damaged_table_is_one_line_exit_2(
    copy: Path, tmp_path: Path
) -> None:
    os.truncate(copy / "evaluations" / "gen-000000.parquet", 1000)
    command = ["watch", str(copy), "--no-viewer", "--save", str(tmp_path / "x.rrd")]
    result = subprocess.run(
        [sys.executable, "-m", "ariel.cli", *command, "--until-finished"],
        capture_output=True,
        text=True,
        env=repo_env(),
        timeout=90,  # the old watch waited for ever
    )
    assert result.returncode == 2, result.stderr
    (line,) = result.stderr.splitlines()
    assert line.startswith("ariel: error: ") and "evaluations/gen-000000.parquet" in line


def test_a_missing_manifest_of_an_ended_run_is_damage(copy: Path) -> None:
    (copy / "manifests" / "gen-000000.json").unlink()
    with pytest.raises(ArielError, match=r"manifests/gen-000000\.json is missing"):
        _poll_once(copy)


def test_a_running_run_s_unreadable_generation_is_a_note_and_the_watch_goes_on(
    copy: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import ariel.recording.viewer._unreadable as unreadable

    os.truncate(copy / "evaluations" / "gen-000000.parquet", 1000)
    info = json.loads((copy / "run.json").read_text())
    (copy / "run.json").write_text(json.dumps({**info, "status": "running"}))
    monkeypatch.setattr(unreadable, "NOTE_AFTER_S", 0.0)
    with RunLock(copy):  # its run holds the lock
        _poll_once(copy)  # no error: a running run's generation may be being written
    err = capsys.readouterr().err
    assert "generation 0" in err and "cannot be read yet" in err and len(err.splitlines()) == 1


def test_a_browser_that_cannot_be_run_is_said_so_not_a_failed_write(
    copy: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    not_executable = tmp_path / "notexec"
    not_executable.write_text("#!/bin/sh\n")
    not_executable.chmod(0o644)
    monkeypatch.setenv("ARIEL_CHROMIUM", str(not_executable))
    assert exit_code(["view", str(copy), "--screenshot", str(tmp_path / "shot.png")]) == 2
    line = one_error_line(capsys)
    assert "ARIEL_CHROMIUM" in line and "cannot be run" in line and "cannot write" not in line
    # Executable but not a program (no #! line): the start fails, said as the browser's.
    not_a_program = tmp_path / "garbage"
    not_a_program.write_bytes(b"\x00\x01 not a program\n")
    not_a_program.chmod(0o755)
    monkeypatch.setenv("ARIEL_CHROMIUM", str(not_a_program))
    with pytest.raises(BrowserError, match="cannot be run"):
        HeadlessChromium(tmp_path / "profile", binary=find_chromium())
