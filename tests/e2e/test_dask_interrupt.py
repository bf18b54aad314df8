"""Ctrl-C on a run on a Dask LocalCluster: one line and exit 130, no worker tracebacks (issue 16,
item 12). Ctrl-C reaches the whole process group: the cluster's processes ignore it and the
driver closes them."""

from __future__ import annotations

import json
import os
import re
import signal
from pathlib import Path

import pytest
from _helpers import signal_run_group

pytest.importorskip("distributed")

CONFIG = """
name = "dask_interrupt"
seed = 1
generations = 20
[body]
options = { number_of_modules = 8 }
population = 4
offspring = 4
[brain]
popsize = 4
iterations = 3
[task]
duration = 2.0
[record]
rerun = false
[executor]
kind = "dask"
workers = 2
"""


@pytest.mark.soak  # ~12 s: a Dask cluster started and interrupted
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_ctrl_c_on_a_dask_run_prints_no_worker_tracebacks(tmp_path: Path) -> None:
    config = tmp_path / "dask.toml"
    config.write_text(CONFIG)
    run_dir, log = tmp_path / "run", tmp_path / "output.txt"
    code = signal_run_group(config, run_dir, log, signal.SIGINT)  # what Ctrl-C in a terminal does
    assert code == 130, (code, log.read_text()[-3000:])
    output = log.read_text()
    assert re.search(r"interrupted; continue it with: \S*ariel resume", output), output[-3000:]
    assert "Traceback" not in output and "KeyboardInterrupt" not in output, output[-3000:]
    assert json.loads((run_dir / "run.json").read_text())["status"] == "interrupted"
