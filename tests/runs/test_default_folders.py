"""Default folders (``data/runs/<id>``, ``data/campaigns/<id>``, ``compare-<time>``) are claimed
by making them: two runs, campaigns or comparisons started in the same second named one folder,
and the second stopped as "in use" (probe G1)."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest
from _helpers import REPO, StoppedError, stop_at_executor, tiny_run_toml

from ariel.utils import free_path, new_folder

TINY_CAMPAIGN = REPO / "tests" / "data" / "campaign_tiny.toml"


def test_new_folder_gives_each_caller_its_own(tmp_path: Path) -> None:
    made: list[Path] = []
    start = threading.Barrier(8)

    def claim() -> None:
        start.wait()
        made.append(new_folder(tmp_path / "runs", "r-20261128-101500-s1"))

    threads = [threading.Thread(target=claim) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    names = sorted(p.name for p in made)
    expected = ["r-20261128-101500-s1", *(f"r-20261128-101500-s1-{n}" for n in range(2, 9))]
    assert names == sorted(expected)
    (tmp_path / "runs" / "r-20261128-101500-s1-9").symlink_to("elsewhere")  # taken, dangling
    assert free_path(tmp_path / "runs", "r-20261128-101500-s1").name == "r-20261128-101500-s1-10"


def _taken(monkeypatch: pytest.MonkeyPatch, module: object, root: Path, name: str) -> Path:
    """``root/name`` made by "another" run after this one named it (the race)."""
    monkeypatch.setattr(module, "free_path", lambda parent, name_: parent / name)
    other = root / name
    other.mkdir(parents=True)
    (other / "run.json").write_text("{}")
    return other


@pytest.fixture
def config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A tiny run's config, the current folder an empty one (where data/runs goes)."""
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("tiny", 1))
    return config


def test_a_run_whose_default_folder_was_taken_meanwhile_takes_the_next(
    config: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.runs import _experiment, run_experiment

    other = _taken(monkeypatch, _experiment, Path("data/runs"), "tiny-20261128-101500-s1")
    stop_at_executor(monkeypatch)
    with pytest.raises(StoppedError):
        run_experiment(config)
    mine = Path("data/runs/tiny-20261128-101500-s1-2")
    assert json.loads((mine / "run.json").read_text())["run_id"] == mine.name
    assert (other / "run.json").read_text() == "{}"  # the other run's, untouched


def test_a_run_refused_after_claiming_its_folder_leaves_none(
    config: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.runs import _experiment, run_experiment

    def refuse(*args: object, **kwargs: object) -> None:
        raise ValueError("refused")

    monkeypatch.setattr(_experiment.RunSession, "create", refuse)
    with pytest.raises(ValueError, match="refused"):
        run_experiment(config)
    assert list(Path("data/runs").iterdir()) == []


def test_a_campaign_whose_default_folder_was_taken_meanwhile_takes_the_next(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.runs import _campaign_folder, run_campaign

    monkeypatch.chdir(tmp_path)
    name = "tiny-20261128-101500"
    other = _taken(monkeypatch, _campaign_folder, Path("data/campaigns"), name)
    stop_at_executor(monkeypatch)
    with pytest.raises(StoppedError):
        run_campaign(TINY_CAMPAIGN)
    mine = Path(f"data/campaigns/{name}-2")
    info = json.loads((mine / "campaign.json").read_text())
    assert info["campaign_id"] == mine.name
    assert all(run["run_id"].startswith(f"{name}-2-") for run in info["runs"])
    assert (other / "run.json").read_text() == "{}"


def test_a_file_where_the_runs_folder_goes_is_said_so(tmp_path: Path) -> None:
    """``data/runs`` a file: "[Errno 17] File exists: 'data/runs'" (probe R9)."""
    (tmp_path / "runs").write_text("a file")
    with pytest.raises(FileExistsError, match=r"'.*runs' is not a folder: new folders are made"):
        new_folder(tmp_path / "runs", "r-20261128-101500-s1")
