"""`drive`, the one loop of a lone run and a campaign: however the drive ends, every session
that did not finish is closed with how it ended, and the campaign's own ending is told once.
The scheduler is replaced (no physics, no folder): these tests say what `drive` does itself."""

from __future__ import annotations

import contextlib
import json
from types import SimpleNamespace
from typing import Any

import pytest

from ariel.runs import _session
from ariel.runs._session import RunSession, drive


class FakeFolder:
    def __init__(self) -> None:
        self.info: dict[str, Any] = {}

    def update_info(self, **changes: Any) -> None:
        self.info.update(changes)


def _session_of(status: str = "failed") -> RunSession:
    session = RunSession(prepared=None, folder=FakeFolder(), run_id="r")  # type: ignore[arg-type]
    session.driver = SimpleNamespace(wall_seconds=1.5)  # type: ignore[assignment]
    session.status = status
    return session


@pytest.mark.parametrize(
    ("raised", "status"), [(KeyboardInterrupt, "interrupted"), (RuntimeError, "failed")]
)
def test_an_ended_drive_closes_every_unfinished_session_with_how_it_ended(
    monkeypatch: pytest.MonkeyPatch, raised: type[BaseException], status: str
) -> None:
    def run_groups(groups: Any, settings: Any) -> int:
        raise raised()

    monkeypatch.setattr(_session, "run_groups", run_groups)
    done, left = _session_of("finished"), _session_of()
    told: list[str] = []
    with pytest.raises(raised):
        drive([done, left], None, contextlib.nullcontext(), told.append)  # type: ignore[arg-type]
    assert left.status == status and left.folder.info["status"] == status  # type: ignore[attr-defined]
    assert left.folder.info["wall_seconds"] == 1.5  # type: ignore[attr-defined]
    assert "status" not in done.folder.info  # type: ignore[attr-defined]  # finished: left alone
    assert told == [status]


def test_a_finished_drive_returns_the_capacity_and_says_finished(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def run_groups(groups: Any, settings: Any) -> int:
        for session in sessions:  # each group's end closes its session as finished
            session.close("finished")
        return 7

    monkeypatch.setattr(_session, "run_groups", run_groups)
    sessions = [_session_of(), _session_of()]
    told: list[str] = []
    assert drive(sessions, None, contextlib.nullcontext(), told.append) == 7  # type: ignore[arg-type]
    assert [s.folder.info["status"] for s in sessions] == ["finished", "finished"]  # type: ignore[attr-defined]
    assert told == ["finished"]


def test_an_interrupt_before_the_driver_runs_leaves_the_run_interrupted(
    tmp_path: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C or SIGTERM while a run's lock is held but before its driver runs (a resume's
    plugins being checked, a new run's recorder loading) left run.json at ``created``, or at a
    killed run's ``running``: `ariel runs` then said "stopped (killed?)"."""
    from _helpers import edit_json, tiny_run_toml

    from ariel.runs import resume_experiment, run_experiment

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("early", 5))
    out = tmp_path / "run"

    def interrupt(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(RunSession, "start", interrupt)  # a new run: before its first evaluation
        with pytest.raises(KeyboardInterrupt):
            run_experiment(config, out=out)
    assert json.loads((out / "run.json").read_text())["status"] == "interrupted"
    edit_json(out / "run.json", lambda info: info.update(status="running"))  # then SIGKILLed
    with monkeypatch.context() as patch:
        patch.setattr(_session, "prepare_run", interrupt)  # a resume: checking its plugins
        with pytest.raises(KeyboardInterrupt):
            resume_experiment(out)
    assert json.loads((out / "run.json").read_text())["status"] == "interrupted"
    assert not (out / ".lock").exists()
    assert resume_experiment(out).status == "finished"


def test_an_interrupt_after_the_run_finished_suggests_no_resume(
    tmp_path: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A signal the moment run.json said finished printed "continue it with: ariel resume
    RUN", which then refused ("already finished"), and exit 130 told a batch loop to retry."""
    from _helpers import tiny_run_toml

    from ariel.cli import main

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("late", 1))
    out = tmp_path / "run"

    def interrupt(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt  # as the signal coming once the run is closed as finished

    with monkeypatch.context() as patch:
        patch.setattr(RunSession, "result", interrupt)
        assert main(["run", str(config), "--out", str(out), "--quiet"]) == 130
    said = capsys.readouterr().err.strip().splitlines()[-1]
    assert said == f"interrupted after it finished: {out} is complete, nothing to resume"
    assert json.loads((out / "run.json").read_text())["status"] == "finished"
