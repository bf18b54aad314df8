"""Bad input to the benchmarks that read a run (science.py, gallery.py) is one line, exit 2,
as from the ``ariel`` command: it was a traceback (probe Z)."""

from __future__ import annotations

from pathlib import Path

import pytest
from _helpers import run_benchmark


@pytest.mark.parametrize(
    ("script", "args", "said"),
    [
        ("gallery.py", ["missing"], "gallery.py: error: 'missing' is not an ariel run folder"),
        ("science.py", ["--set", "foo=bar"], "science.py: error: --set foo: no such key"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path: Path, script: str, args: list, said: str) -> None:
    result = run_benchmark(script, *args, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith(said) and result.stderr.count("\n") == 1, result.stderr
