"""A run folder holds no absolute path of the machine that made it, and no secret: a finished
run (with Rerun recordings) copied elsewhere, its original moved away, still loads, replays
(the stored fitness, bit for bit) and reports."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import socket
from pathlib import Path

import pytest
from _helpers import REPO, tiny_run_toml

from ariel.cli import main
from ariel.recording import Run, load_run

TOML = tiny_run_toml("portable", 9, iterations=2, record='rerun = true\nbodies = "all"')


def _needles(*paths: Path) -> dict[str, bytes]:
    """What must not appear in any file: these paths (as given and resolved), the host name,
    the home folder and values of secret-looking environment variables."""
    found: dict[str, bytes] = {}
    for path in paths:
        for form in {str(path), str(path.resolve())}:
            found[f"path {form}"] = form.encode()
    host = socket.gethostname()
    if len(host) >= 6:  # shorter names turn up by chance in compressed bytes
        found[f"host {host}"] = host.encode()
    home = os.path.expanduser("~")
    if len(home) >= 6:
        found[f"home {home}"] = home.encode()
    secret = re.compile(r"TOKEN|SECRET|PASSWORD|PASSWD|API_?KEY|CREDENTIAL", re.IGNORECASE)
    for name, value in os.environ.items():
        if secret.search(name) and len(value) >= 8:
            found[f"${name}"] = value.encode()
    return found


def test_a_copied_run_has_no_machine_paths_and_loads_replays_and_reports(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    origin = tmp_path / "made-here-3f9c1e"
    origin.mkdir()
    (origin / "portable.toml").write_text(TOML)
    out = origin / "runs" / "portable"
    monkeypatch.chdir(origin)
    with contextlib.redirect_stdout(None):
        assert main(["run", "portable.toml", "--out", str(out), "--quiet"]) == 0
    original = load_run(out)
    expected = [original.evaluations, original.bodies, original.trajectories]  # read now
    assert list(out.glob("recordings/gen-*/*.rrd")), "the run has per-evaluation recordings"
    assert (out / "run.rrd").is_file() and (out / "blueprint.rbl").is_file()

    copy = tmp_path / "elsewhere" / "copy"
    shutil.copytree(out, copy)
    shutil.move(origin, tmp_path / "moved-away")  # nothing can be read from the original
    monkeypatch.chdir(tmp_path)

    files = [p for p in copy.rglob("*") if p.is_file()]
    kinds = {p.suffix for p in files}
    assert {".json", ".parquet", ".rrd", ".rbl"} <= kinds, kinds
    assert (copy / "checkpoints" / "state.json").is_file()  # data, never a pickle
    for needle_name, needle in _needles(out, origin, REPO).items():
        holding = [str(p.relative_to(copy)) for p in files if needle in p.read_bytes()]
        assert holding == [], f"{needle_name} is in {holding}"
    assert not (copy / ".lock").exists()

    run = load_run(copy)
    assert run.info == original.info
    for table, want in zip((run.evaluations, run.bodies, run.trajectories), expected, strict=True):
        assert len(table) and table.equals(want)
    # Loaded by a relative path, read after a notebook changed directory: the same folder (its
    # tables were "missing", the run reported as damaged).
    relative = load_run(copy.relative_to(tmp_path))
    monkeypatch.chdir(copy.parent)
    assert relative.evaluations.equals(expected[0]) and relative.root == copy
    monkeypatch.chdir(tmp_path)
    # A run with no finished generation: the columns' dtypes of one that has them (not object).
    empty = Run(path=copy, info={**run.info, "generations_done": 0, "status": "interrupted"})
    assert len(empty.generations) == 0
    assert dict(empty.generations.dtypes) == dict(run.generations.dtypes)

    assert main(["replay", str(copy), "best"]) == 0
    printed = capsys.readouterr().out
    assert "identical: yes, bit for bit" in printed
    best = expected[0].loc[expected[0]["fitness"].idxmax()]
    assert f"stored fitness:   {float(best['fitness'])!r}" in printed

    assert main(["report", str(copy), "--no-render"]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {copy / 'report' / 'fitness.png'}" in printed
    assert (copy / "report" / "fitness.png").stat().st_size > 1000
