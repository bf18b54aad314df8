"""A failed write of a Rerun file (file too large, disk full, quota, I/O error) is an `OSError`
naming the file, promptly, and leaves no staging file: Rerun's own blueprint writer
(``Blueprint.save``) only logged it and then waited for ever, deaf to Ctrl-C and SIGTERM, so
the layout is encoded in memory (`blueprint_bytes`) and written by ariel.

The writers run in a child process under a small ``RLIMIT_FSIZE`` (a write past it fails with
EFBIG: Python ignores SIGXFSZ), with a timeout: a hang fails the test instead of stalling it.
"""

from __future__ import annotations

import errno
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rerun")

from _helpers import repo_env, tiny_run_toml
from rerun.chunk import RrdReader

from ariel.cli import main
from ariel.recording.rerun._blueprint import (
    blueprint,
    blueprint_bytes,
    save_blueprint,
    write_blueprint,
)
from ariel.recording.store._files import remove_temporaries, written_path
from ariel.recording.viewer._rerun_files import rerun_file_problem

if not hasattr(os, "fork"):  # RLIMIT_FSIZE: POSIX
    pytest.skip("file size limits are POSIX", allow_module_level=True)

#: Runs ``python ARGS...`` (``-m MODULE ...`` or a script) under a file size limit of
#: ``sys.argv[1]`` bytes (soft: the hard limit is kept).
_LIMITED = """
import resource, runpy, sys
limit = int(sys.argv.pop(1))
hard = resource.getrlimit(resource.RLIMIT_FSIZE)[1]
soft = limit if hard == resource.RLIM_INFINITY else min(limit, hard)
resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
sys.argv.pop(0)
if sys.argv[0] == "-m":
    sys.argv.pop(0)
    runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
else:
    runpy.run_path(sys.argv[0], run_name="__main__")
"""

#: Writes a blueprint and a recording (both built before the limit applies) into
#: ``sys.argv[1]``; prints each one's outcome as JSON: null, or [errno, filename].
_WRITERS = """
import json, sys
from pathlib import Path
import numpy as np
import rerun as rr
from ariel.recording.rerun._blueprint import blueprint, save_blueprint
from ariel.recording.rerun._rerun import _write_chunks

folder = Path(sys.argv[1])
n = 20_000  # ~160 kB of scalars: far past the limit
time = [rr.TimeColumn("t", sequence=np.arange(n))]
chunks = [rr.chunk.Chunk.from_columns("/x", time, rr.Scalars.columns(scalars=np.linspace(0, 1, n)))]
layout = blueprint()  # ~130 kB encoded
writers = {
    "blueprint.rbl": lambda path: save_blueprint(path, layout, "ariel"),
    "run.rrd": lambda path: _write_chunks(path, "run", chunks, fsync=True),
}
outcome = {}
for name, write in writers.items():
    try:
        write(folder / name)
        outcome[name] = None
    except OSError as exc:
        outcome[name] = [exc.errno, exc.filename]
print(json.dumps(outcome))
"""

LIMIT = 16 * 1024  # bytes
TIMEOUT_S = 120  # a hang (the bug) ends here, not in CI's global timeout


def _limited(args: list[str], limit: int, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(repo_env(), PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run(
        [sys.executable, "-c", _LIMITED, str(limit), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=TIMEOUT_S,
        check=False,
    )


def test_a_file_too_large_is_an_oserror_from_each_rerun_writer_and_leaves_nothing(
    tmp_path: Path,
) -> None:
    script = tmp_path / "writers.py"
    script.write_text(_WRITERS)
    folder = tmp_path / "out"
    folder.mkdir()
    child = _limited([str(script), str(folder)], LIMIT, tmp_path)
    assert child.returncode == 0, child.stderr
    outcome = json.loads(child.stdout.splitlines()[-1])
    for name in ("blueprint.rbl", "run.rrd"):
        assert outcome[name] == [errno.EFBIG, str(folder / name)], (name, child.stderr)
    assert sorted(p.name for p in folder.iterdir()) == []  # no temporary, no staging file
    # Rerun's file sink no longer writes the blueprint (it logged its failure, then hung).
    assert "file_sink" not in child.stderr, child.stderr


def test_blueprint_bytes_are_what_rerun_saves(tmp_path: Path) -> None:
    """`blueprint_bytes` uses a carrier recording's memory sink (its own store info dropped):
    the file must hold what ``Blueprint.save`` writes, message for message (ids aside), or
    Rerun changed under it."""
    layout = blueprint(archive=True, fitness_unit="m")
    rerun_saved = tmp_path / "rerun.rbl"
    layout.save("ariel", str(rerun_saved))
    ours = save_blueprint(tmp_path / "ours.rbl", layout, "ariel")
    assert ours.read_bytes().startswith(b"RRF")
    assert rerun_file_problem(ours, layout=True) is None

    def stores(path: Path) -> tuple[object, ...]:
        reader = RrdReader(path)
        (store,) = reader.blueprints()
        chunks = reader.stream(store=store).to_chunks()
        columns = sorted((c.entity_path, tuple(c.to_record_batch().schema.names)) for c in chunks)
        return reader.recordings(), store.application_id, columns

    assert stores(ours) == stores(rerun_saved)
    assert stores(ours)[:2] == ([], "ariel")  # a layout alone: no (empty) recording beside it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ours.rbl", "rerun.rbl"]

    if not _has_rerun_cli():
        return
    ours_printed, rerun_printed = _messages(ours), _messages(rerun_saved)
    assert ours_printed == rerun_printed
    assert ours_printed.count("StoreInfo") >= 1
    assert ours_printed[-1] == (
        'BlueprintActivationCommand(StoreId(Blueprint, "ariel", ID), make_active: true, '
        "make_default: true)"
    )


def test_blueprint_bytes_are_one_blueprint_each_time() -> None:
    """Two encodings of one layout: each a whole file with only its own blueprint."""
    layout = blueprint()
    first, second = blueprint_bytes(layout, "ariel"), blueprint_bytes(layout, "ariel")
    assert first.startswith(b"RRF") and second.startswith(b"RRF")
    assert abs(len(first) - len(second)) < 1024  # not the first's messages again


def test_a_run_s_layouts_leave_no_threads_behind(tmp_path: Path) -> None:
    """Rerun never drops a recording made from Python: each blueprint encoded left 4 threads
    behind (its carrier's and its own stream's), 8 a run, ~500 in a campaign of 60 runs in
    one process. Each layout is encoded once per process now, with the same bytes."""
    import psutil

    from ariel.recording.rerun._generation_rrd import write_generation_blueprint

    def write_both(name: str) -> bytes:
        write_generation_blueprint(tmp_path / f"{name}.generation.rbl")
        return write_blueprint(tmp_path / f"{name}.rbl", fitness_unit="m").read_bytes()

    first = write_both("first")
    threads = psutil.Process().num_threads()
    for name in ("second", "third"):
        assert write_both(name) == first
    assert psutil.Process().num_threads() == threads
    assert rerun_file_problem(tmp_path / "third.rbl", layout=True) is None


def _has_rerun_cli() -> bool:
    try:
        import rerun_cli  # noqa: F401
    except ImportError:
        return False
    return True


def _messages(path: Path) -> list[str]:
    """``rerun rrd print``'s messages, chunk and store ids left out."""
    printed = subprocess.run(
        [sys.executable, "-m", "rerun_cli", "rrd", "print", str(path)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    messages = []
    for line in printed.splitlines():
        if line.startswith(("Showing", " ", "}")) or not line:
            continue
        line = re.sub(r"^Chunk\(\w+\)", "Chunk", line)
        line = re.sub(r'"rec_\w+"', "ID", line)
        messages.append("StoreInfo" if line.startswith("StoreInfo") else line)
    return messages


def test_the_sweep_removes_an_earlier_versions_blueprint_staging_file(tmp_path: Path) -> None:
    """Earlier versions had Rerun write ``.blueprint.rbl.TOKEN.tmp.rbl`` and left it behind
    when killed or stuck there: a temporary for ``blueprint.rbl``."""
    staging = tmp_path / ".blueprint.rbl.6a7d334d.tmp.rbl"
    staging.write_bytes(b"RRF2 cut")
    (tmp_path / "blueprint.rbl").write_bytes(b"kept")
    (tmp_path / "x.tmp.rbl").write_bytes(b"kept: not hidden, not ours")
    assert written_path(staging) == tmp_path / "blueprint.rbl"
    assert [p.name for p in remove_temporaries(tmp_path)] == [staging.name]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blueprint.rbl", "x.tmp.rbl"]


@pytest.mark.slow  # a child `ariel run` (imports: seconds), then `ariel resume`
def test_ariel_run_past_a_file_size_limit_says_one_line_and_resume_finishes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "tiny.toml"
    # No [record] table: the defaults, Rerun's files written.
    config.write_text(tiny_run_toml("fsize", 7, generations=1, record=None))
    out = tmp_path / "run"
    args = ["-m", "ariel.cli", "run", str(config), "--out", str(out), "--quiet"]
    child = _limited(args, 50 * 1024, tmp_path)  # the blueprint (~130 kB) is past it
    assert child.returncode == 2, child.stderr
    lines = child.stderr.splitlines()
    assert len(lines) == 1, child.stderr
    assert lines[0].startswith(f"ariel: error: cannot write '{out}/"), lines[0]
    assert "File too large" in lines[0] and f"resume {out}" in lines[0], lines[0]
    assert json.loads((out / "run.json").read_text())["status"] in {"failed", "interrupted"}
    assert not [p.name for p in out.rglob(".*") if p.name != ".lock"]  # no temporary left

    capsys.readouterr()
    assert main(["resume", str(out), "--quiet"]) == 0  # no limit now
    assert json.loads((out / "run.json").read_text())["status"] == "finished"
    assert rerun_file_problem(out / "blueprint.rbl", layout=True) is None
    assert not [p.name for p in out.rglob(".*") if p.name != ".lock"]


def test_a_linked_recordings_folder_is_refused_before_anything_is_recorded(
    tmp_path: Path,
) -> None:
    """A received run folder whose ``recordings`` links elsewhere: a resumed run wrote its new
    generations' recordings there, outside the run folder."""
    from ariel.evolution import ExperimentConfig
    from ariel.recording.rerun._recorder import RerunRecorder
    from ariel.recording.store import UnsafePathError

    run, outside = tmp_path / "run", tmp_path / "outside"
    run.mkdir()
    outside.mkdir()
    (run / "recordings").symlink_to(outside)
    config = ExperimentConfig.from_plain({})
    with pytest.raises(UnsafePathError, match=r"'.*/run/recordings' is a symbolic link \(to"):
        RerunRecorder(run, run_id="r", bodies="all", maximise=True, config=config)
    (run / "recordings").unlink()
    (run / "recordings").mkdir()
    RerunRecorder(run, run_id="r", bodies="all", maximise=True, config=config)  # a real one
    assert list(outside.iterdir()) == []


def test_run_rrd_keeps_a_bounded_number_of_lineage_drawings(tmp_path: Path) -> None:
    """Each generation's drawing of the lineage holds every body so far: one per generation
    made run.rrd grow with the square of the run (167 MB at 1,000 generations, probe G3)."""
    from ariel.evolution import ExperimentConfig
    from ariel.recording.rerun._lineage import LINEAGE_ENTITY
    from ariel.recording.rerun._recorder import LINEAGE_SNAPSHOTS, RerunRecorder

    run = tmp_path / "run"
    run.mkdir()
    config = ExperimentConfig.from_plain({})
    recorder = RerunRecorder(run, run_id="r", bodies="all", maximise=True, config=config)
    kept = []
    for generation in range(300):
        body = {"body_id": f"b{generation:06d}", "fitness": 1.0, "selected": True}
        recorder._run_chunks[LINEAGE_ENTITY, generation] = None  # as write_run_recording
        recorder._grow_lineage(generation, [body])
        kept.append(sorted(recorder._lineages))
    assert len(kept[63]) == 64 and kept[63] == list(range(64))  # short runs: every one
    assert len(kept[-1]) <= LINEAGE_SNAPSHOTS + 1 and kept[-1][-1] == 299  # and the last
    assert kept[-1][:-1] == list(range(0, 299, 8))  # spread over the run
    assert {g for _, g in recorder._run_chunks} == set(kept[-1])  # their chunks alone
