"""Fixtures of the campaign-folder tests: the tiny campaign made and left resumable."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from _helpers import REPO, StoppedError, stop_at_executor

from ariel.runs import run_campaign

TINY = REPO / "tests" / "data" / "campaign_tiny.toml"


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny campaign, its 4 run folders created and left resumable (none evaluated)."""
    out = tmp_path_factory.mktemp("made") / "tiny"
    with pytest.MonkeyPatch.context() as monkeypatch:
        stop_at_executor(monkeypatch)
        with pytest.raises(StoppedError):
            run_campaign(TINY, out=out)
    return out


@pytest.fixture
def campaign(made: Path, tmp_path: Path) -> Path:
    """A copy of `made` for one test to change."""
    return Path(shutil.copytree(made, tmp_path / "tiny", symlinks=True))
