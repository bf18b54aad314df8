"""The command's standard output is not its data: a closed, full or narrow (ASCII) stdout and a
deleted current folder end in one line or a finished run, never a traceback, and a failing
stdout is never blamed on the run folder."""

from __future__ import annotations

import errno
import io
import json
import os
import sys
from pathlib import Path

import pytest
from _helpers import exit_code, one_error_line, tiny_run_toml

from ariel.evolution import Progress
from ariel.recording import RunFolder


class _FullDevice(io.StringIO):
    """A stdout whose writes fail as /dev/full's do."""

    def write(self, text: str) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_run_whose_stdout_fails_finishes_and_says_its_output_was_lost(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("full", 1, generations=1))
    out = tmp_path / "run"
    capsys.readouterr()
    monkeypatch.setattr(sys, "stdout", _FullDevice())
    assert exit_code(["run", str(config), "--out", str(out)]) == 2
    line = one_error_line(capsys)
    assert "cannot write to standard output: No space left on device" in line
    assert str(out) not in line and "resume" not in line  # not the run folder's disk
    assert json.loads((out / "run.json").read_text())["status"] == "finished"
    assert exit_code(["runs", str(tmp_path)]) == 2  # a listing that goes nowhere: one line
    assert "cannot write to standard output" in one_error_line(capsys)


def test_closed_and_ascii_stdouts_and_a_deleted_current_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    RunFolder.create(tmp_path / "é 漢", {"run_id": "r", "status": "finished"}, overwrite=False)
    ascii_out = io.TextIOWrapper(io.BytesIO(), encoding="ascii", write_through=True)
    monkeypatch.setattr(sys, "stdout", ascii_out)
    assert exit_code(["runs", str(tmp_path)]) == 0  # escaped, not UnicodeEncodeError
    ascii_out.buffer.seek(0)
    assert "\\xe9 \\u6f22" in ascii_out.buffer.read().decode("ascii")
    monkeypatch.setattr(sys, "stdout", None)  # started with >&-
    assert exit_code(["runs", str(tmp_path)]) == 0
    monkeypatch.setattr(sys, "stdout", None)
    assert not Progress(total=4, stream=None).live  # the API's progress under >&-: no crash
    monkeypatch.undo()

    def gone() -> str:
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT))

    monkeypatch.setattr(os, "getcwd", gone)
    assert exit_code(["runs", str(tmp_path)]) == 2
    assert "the current folder cannot be used" in one_error_line(capsys)
