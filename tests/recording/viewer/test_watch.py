"""`ariel watch`: a live view of a run read from its folder alone. What the watcher's stream
holds (read back from its ``--save`` file) while it follows a run started in the background,
a run killed mid-generation, nothing written in the run folder, the web viewer bound to
127.0.0.1 and stopped by Ctrl-C, and one-line bad input."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import time
from collections import defaultdict
from datetime import UTC
from pathlib import Path

import numpy as np
import psutil
import pytest
import rerun as rr

from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES
from ariel.cli import main
from ariel.recording import load_run, watch
from ariel.recording.rerun._recorder import archive_grid
from ariel.recording.rerun._rerun import RUN_SERIES
from ariel.recording.store._manifest import manifest_file
from ariel.recording.viewer._view import best_evaluations, recording_path
from ariel.utils import ariel_line
from tests._helpers import ServedWebViewer

# Like TINY in tests/analysis/test_notebooks.py: 3 + 3 bodies, a generation in well under 1 s.
TINY = """
name = "watchtiny"
seed = 5
generations = 4
[body]
options = { number_of_modules = 6 }
population = 3
offspring = 3
[brain]
popsize = 4
iterations = 2
[task]
duration = 1.0
[executor]
kind = "serial"
[record]
rerun = false
"""
QD = TINY.replace(
    "[brain]",
    'optimizer = "map_elites"\noptimizer_options = { measures = ["num_limbs", "joints_ratio"], '
    "bins = [4, 4], ranges = [[0, 8], [0, 1]] }\n[brain]",
)
TIMEOUT_S = 180.0


def _start_run(folder: Path, toml: str, *sets: str) -> tuple[subprocess.Popen[bytes], Path]:
    """``ariel run`` of ``toml`` in a background process; returns it and its run folder, once
    run.json is there."""
    config = folder / "config.toml"
    config.write_text(toml)
    out = folder / "run"
    overrides = [word for item in sets for word in ("--set", item)]
    command = [sys.executable, "-m", "ariel.cli", "run", str(config), "--out", str(out)]
    proc = subprocess.Popen(
        [*command, "--quiet", *overrides], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    _until(lambda: (out / "run.json").is_file() or proc.poll() is not None)
    assert (out / "run.json").is_file(), f"the run ended with {proc.returncode} before starting"
    return proc, out


def _until(condition, timeout: float = TIMEOUT_S) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def _follow(run: Path, save: Path) -> tuple[list[float], bool]:
    """Watch ``run`` (no viewer, saving to ``save``) until it is finished, as
    ``follow(until_finished=True)`` does; returns, per generation, the seconds from its
    manifest being written to the watcher having logged it, and whether the scratch folder of
    3D replays was removed on closing."""
    latencies = []
    with watch(run, viewer="none", save=save) as watcher:
        source = watcher.source
        deadline = time.monotonic() + TIMEOUT_S
        while True:
            started, before = time.monotonic(), source.shown
            watcher.poll()
            now = time.time()
            latencies += [
                now - manifest_file(run, g).stat().st_mtime for g in range(before, source.shown)
            ]
            if source.finished():
                break
            assert time.monotonic() < deadline, "the watcher never saw the run finish"
            time.sleep(max(0.0, watcher.poll_s - (time.monotonic() - started)))
    return latencies, source.best._scratch is None


def _chunks(path: Path) -> dict[tuple[str, bool], list]:
    """(entity, static) -> its chunks' record batches, in the order they were written."""
    found: dict[tuple[str, bool], list] = defaultdict(list)
    for chunk in rr.chunk.RrdReader(path).stream().to_chunks():
        found[(chunk.entity_path, chunk.is_static)].append(chunk.to_record_batch())
    return found


def _series(chunks: dict, entity: str) -> tuple[list[int], np.ndarray]:
    """The generations and values (a row each) of a scalar entity on the generation
    timeline."""
    rows = [
        (g, v)
        for batch in chunks[(entity, False)]
        for g, v in zip(
            batch.column("generation").to_pylist(), batch.column("Scalars:scalars").to_pylist()
        )
    ]
    rows.sort(key=lambda row: row[0])
    return [g for g, _ in rows], np.array([v for _, v in rows], dtype=float)


def _last(chunks: dict, entity: str, column: str, static: bool = False):
    return chunks[(entity, static)][-1].column(column).to_pylist()[-1]


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A co-evolution run with recordings (the best body's own .rrd) started in the background
    and watched live until it finished."""
    folder = tmp_path_factory.mktemp("watch")
    proc, run = _start_run(folder, TINY, "record.rerun=true")
    try:
        latencies, _ = _follow(run, folder / "live.rrd")
    finally:
        proc.wait(timeout=TIMEOUT_S)
    median = statistics.median(latencies)
    print(f"\nmanifest -> logged: median {median:.3f} s over {len(latencies)} generations")
    return {"run": run, "rrd": folder / "live.rrd", "latencies": latencies, "code": proc.returncode}


@pytest.fixture(scope="module")
def qd(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A tiny MAP-Elites run without recordings (its best body is replayed on demand), started
    in the background and watched live until it finished."""
    folder = tmp_path_factory.mktemp("watchqd")
    proc, run = _start_run(folder, QD)
    try:
        _, cleaned = _follow(run, folder / "live.rrd")
    finally:
        proc.wait(timeout=TIMEOUT_S)
    return {"run": run, "rrd": folder / "live.rrd", "cleaned": cleaned, "code": proc.returncode}


def test_the_stream_holds_every_generation_the_best_body_and_the_lineage(live: dict) -> None:
    assert live["code"] == 0
    run = load_run(live["run"])
    table = run.generations
    chunks = _chunks(live["rrd"])
    for column, entity in RUN_SERIES.items():
        generations, values = _series(chunks, entity)
        assert generations == list(range(len(table))) == list(table["generation"])
        if column in table:
            np.testing.assert_allclose(values[:, 0], table[column], equal_nan=True)
    generations, values = _series(chunks, "/morphology")
    means = table[[f"mean_{name}" for name in DESCRIPTOR_NAMES]].to_numpy(dtype=float)
    assert generations == list(table["generation"])
    np.testing.assert_allclose(values, means, equal_nan=True)
    # The best body so far: the run's best evaluation, its own recording's poses.
    best = best_evaluations(run.evaluations, 1, maximise=run.maximise).iloc[0]
    own = _chunks(recording_path(run.path, int(best["generation"]), best["eval_id"]))
    assert chunks[("/best/world/robot", False)][-1].column("Boxes3D:centers").to_pylist() == (
        own[("/world/robot", False)][0].column("Boxes3D:centers").to_pylist()
    )
    info = _last(chunks, "/best/info", "TextDocument:text", static=True)
    assert f"evaluation {best['eval_id']} " in info[0] and "its own recording" in info[0]
    # The lineage: every body, an edge from each parent.
    bodies = run.bodies.drop_duplicates("body_id")
    edges = {(str(p), b) for b, ps in zip(bodies["body_id"], bodies["parent_ids"]) for p in ps}
    assert len(_last(chunks, "/lineage", "GraphNodes:node_ids")) == len(bodies)
    assert set(_last(chunks, "/lineage", "GraphNodes:node_ids")) == set(bodies["body_id"])
    drawn = _last(chunks, "/lineage", "GraphEdges:edges")
    assert {(e["first"], e["second"]) for e in drawn} == edges
    assert len(_last(chunks, "/lineage", "GraphEdges:edges")) == len(edges) > 0
    progress = _last(chunks, "/progress", "TextDocument:text", static=True)[0]
    assert "**finished**" in progress and f"evaluations {len(run.evaluations)}" in progress
    # A new generation is shown within 2 s of its manifest (polling every 0.5 s).
    assert len(live["latencies"]) == len(table)
    assert statistics.median(live["latencies"]) < 2.0


def test_a_run_that_ended_during_a_poll_is_read_again_to_say_how(
    live: dict, tmp_path: Path
) -> None:
    """run.json read as running, then the run wrote "finished" and let go of its lock: the
    watch reads it again and polls once more, so its last progress says finished."""
    from ariel.recording.viewer._watch_run import RunSource

    run = tmp_path / "run"
    shutil.copytree(live["run"], run)
    assert not (run / ".lock").exists()  # the run has let go of it
    source = RunSource(run)
    source.info = {**source.info, "status": "running"}  # as a poll read it, just before
    assert not source.finished()  # ended, but not yet logged how
    assert source.info["status"] == "finished"


def test_a_killed_run_shows_as_stopped_and_a_removed_one_ends_the_watch(
    live: dict, tmp_path: Path
) -> None:
    """A killed run (run.json says running, no process holds its lock) stayed "running" with
    an ETA in the view; a folder removed while watched was polled for ever without a word."""
    import rerun as rr

    from ariel.errors import ViewError
    from ariel.recording.viewer._watch_run import RunSource

    run = tmp_path / "run"
    shutil.copytree(live["run"], run)
    info = json.loads((run / "run.json").read_text())
    (run / "run.json").write_text(json.dumps({**info, "status": "running", "wall_seconds": 0}))
    source = RunSource(run)
    rec = rr.RecordingStream("ariel-test", recording_id="killed")
    source.poll(rec)
    assert "**stopped (killed?)**" in source._progress and "ETA" not in source._progress
    shutil.rmtree(run)
    with pytest.raises(ViewError, match=r"run is gone \(moved or removed\); stopped watching$"):
        source.poll(rec)


def test_the_rate_leaves_out_the_start_up_once_two_generations_are_done(
    live: dict, tmp_path: Path
) -> None:
    """Counted from the segment's start, the start-up (seconds before any evaluation) made
    the first ETAs about five times too long."""
    import os
    from datetime import datetime

    import rerun as rr

    from ariel.recording.store import manifest_file
    from ariel.recording.viewer._watch_run import RunSource

    run = tmp_path / "run"
    shutil.copytree(live["run"], run)
    info = json.loads((run / "run.json").read_text())
    start = 1_700_000_000.0
    info["segments"][-1]["started"] = datetime.fromtimestamp(start, UTC).isoformat()
    (run / "run.json").write_text(json.dumps({**info, "status": "running"}))
    done = info["generations_done"]
    for generation in range(done):  # 60 s of start-up, then one generation a second
        os.utime(manifest_file(run, generation), (start, start + 60 + generation))
    source = RunSource(run)
    source.poll(rr.RecordingStream("ariel-test", recording_id="rate"))
    rate, _ = source._rate(sum(source._rows.values()))
    per_generation = sum(source._rows[g] for g in range(1, done)) / (done - 1)
    assert rate == pytest.approx(per_generation)  # evaluations a second: one generation's


def test_a_map_elites_run_s_archive_is_there_per_generation(qd: dict) -> None:
    assert qd["code"] == 0
    run = load_run(qd["run"])
    chunks = _chunks(qd["rrd"])
    grids = [
        (g, np.asarray(b.column("Tensor:data").to_pylist()[k][0]["buffer"], dtype=float))
        for b in chunks[("/archive", False)]
        for k, g in enumerate(b.column("generation").to_pylist())
    ]
    assert [g for g, _ in grids] == list(range(len(run.generations)))
    for generation, grid in grids:
        rows = run.archive[run.archive["generation"] == generation].to_dict("records")
        np.testing.assert_array_equal(grid, archive_grid(rows).ravel())
    _, coverage = _series(chunks, "/qd/coverage")
    np.testing.assert_allclose(coverage[:, 0], run.generations["coverage"])
    # No recording of its own: the best body is a 3D replay made in a scratch folder.
    assert chunks[("/best/world/robot", False)][-1].num_rows > 1
    info = _last(chunks, "/best/info", "TextDocument:text", static=True)[0]
    assert "3D replay" in info and qd["cleaned"]


def _snapshot(folder: Path) -> dict[str, tuple]:
    """Every entry under ``folder`` (hidden ones too): its size, mtime and SHA-256."""
    found = {}
    for path in sorted(folder.rglob("*")):
        stat = path.lstat()
        digest = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
        found[str(path.relative_to(folder))] = (stat.st_size, stat.st_mtime_ns, digest)
    return found


def test_the_watcher_writes_nothing_in_the_run_folder(qd: dict, tmp_path: Path) -> None:
    before = _snapshot(qd["run"])
    _follow(qd["run"], tmp_path / "again.rrd")  # its best body replayed again
    assert _snapshot(qd["run"]) == before


def test_a_run_killed_mid_generation_shows_its_last_complete_generation(tmp_path: Path) -> None:
    proc, run = _start_run(tmp_path, TINY, "generations=30")
    try:
        _until(lambda: manifest_file(run, 1).is_file() or proc.poll() is not None)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    complete = len(list((run / "manifests").glob("gen-*.json")))
    assert 2 <= complete < 30
    _follow(run, tmp_path / "killed.rrd")  # ends: the run's process is gone
    generations, values = _series(_chunks(tmp_path / "killed.rrd"), "/fitness/best")
    assert generations == list(range(complete)) and np.isfinite(values).all()


def _non_loopback_address() -> str | None:
    """An address of this machine other than 127.0.0.1 (None: none known)."""
    with contextlib.suppress(OSError), socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect(("10.255.255.255", 1))  # no packet is sent: it picks the outgoing interface
        address = s.getsockname()[0]
        return None if address.startswith("127.") else address
    return None


def test_web_listens_on_localhost_only_and_ctrl_c_ends_it_cleanly(live: dict) -> None:
    watching = ServedWebViewer(["watch", str(live["run"]), "--web"])
    try:
        listening = watching.listening()
        ports = {c.laddr.port for c in listening}
        assert {c.laddr.ip for c in listening} == {"127.0.0.1"} and len(ports) == 2
        web, grpc = (
            int(p) for p in re.search(r":(\d+)/\?url=.*%3A(\d+)%2Fproxy$", watching.url).groups()
        )
        assert ports == {web, grpc}
        assert sorted(re.findall(r"-L (\d+):127\.0\.0\.1:(\d+)", watching.tunnel)) == sorted(
            (str(p), str(p)) for p in ports
        )
        ours = psutil.Process(watching.proc.pid).net_connections("inet")
        assert not [c for c in ours if c.status == psutil.CONN_LISTEN]  # no server of ours
        address = _non_loopback_address()
        for port in ports if address else ():
            with socket.socket() as s:
                assert s.connect_ex((address, port)) != 0
        cmdline = watching.rerun.cmdline()
        assert "--serve-web" in cmdline and cmdline[cmdline.index("--bind") + 1] == "127.0.0.1"
    finally:
        watching.proc.send_signal(signal.SIGINT)
        assert watching.proc.wait(timeout=30) == 0
    _until(lambda: not psutil.pid_exists(watching.rerun.pid), timeout=10)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["{tmp}"], "is not an ariel run or campaign folder"),
        (["{tmp}/missing"], "does not exist"),
        (["{run}", "--no-viewer"], "--save"),
        (["{run}", "--no-viewer", "--save", "{run}/live.rrd"], "in the watched folder"),
        # named as given, not made absolute (every other path printed is relative)
        (["{run}", "--no-viewer", "--save", "nope/x.rrd"], "--save: folder 'nope' does not"),
        # another run's recording was written over (verify said ok: run.rrd is in no manifest)
        (["{run}", "--no-viewer", "--save", "{tmp}/other/run.rrd"], "is inside the run or"),
        (["{run}", "--no-viewer", "--save", "{tmp}/linked.rrd"], "has other names (hard links)"),
        (["{run}", "--web", "--port", "45555", "--grpc-port", "45555"], "45555 is --port too"),
    ],
)
def test_bad_input_is_one_line_exit_2(
    live: dict, tmp_path: Path, capsys, args, message, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "other").mkdir()
    shutil.copy(live["run"] / "run.json", tmp_path / "other" / "run.json")
    shutil.copy(live["run"] / "run.rrd", tmp_path / "other" / "run.rrd")
    os.link(tmp_path / "other" / "run.rrd", tmp_path / "linked.rrd")  # the same file
    words = [a.format(tmp=tmp_path, run=live["run"]) for a in args]
    assert main(["watch", *words]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and err.startswith("ariel: error:")


def test_the_notebook_viewer_follows_in_the_background(live: dict, tmp_path: Path) -> None:
    pytest.importorskip("rerun_notebook", reason="rerun-sdk[notebook] is not installed")
    import psutil

    from ariel.recording import watch

    saved = tmp_path / "notebook.rrd"
    watcher = watch(live["run"], viewer="notebook", grpc_port=0, save=saved, poll_s=0.2)
    try:
        assert watcher.widget is not None and watcher._thread is not None
        # The widget's data comes from a gRPC server of Rerun's own, on 127.0.0.1 only.
        assert watcher.urls["grpc"] == f"rerun+http://127.0.0.1:{watcher.ports[0]}/proxy"
        listening = {
            c.laddr
            for c in psutil.Process(watcher._child.pid).net_connections()
            if c.status == psutil.CONN_LISTEN
        }
        assert listening and {address.ip for address in listening} == {"127.0.0.1"}
        watcher._thread.join(timeout=TIMEOUT_S)  # the run has finished: it stops by itself
        assert not watcher._thread.is_alive()
    finally:
        watcher.close()
    generations, best = _series(_chunks(saved), "/fitness/best")
    assert generations == list(range(len(load_run(live["run"]).generations)))
    assert len(best) == len(generations)


def test_without_a_display_the_hint_is_the_web_command_to_paste(
    live: dict, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before, it said "(--web)" where `ariel view` gives the whole command line."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["watch", str(live["run"])]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.endswith(
        f"serve it to a browser instead: {ariel_line('watch', live['run'], '--web')}\n"
    )
    # the user's other options are kept (they were dropped, and a Python aside was added)
    save = tmp_path / "live.rrd"
    assert (
        main(["watch", str(live["run"]), "--poll", "2", "--save", str(save), "--until-finished"])
        == 2
    )
    expected = ariel_line(
        "watch", live["run"], "--web", "--save", save, "--poll", "2", "--until-finished"
    )
    assert capsys.readouterr().err.endswith(f"instead: {expected}\n")


def test_a_save_file_that_cannot_be_written_is_one_line(
    live: dict, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A full disk under --save: Rerun's RuntimeError from set_sinks, a traceback, exit 1."""
    import rerun as rr

    def full(self: object, *sinks: object) -> None:
        raise RuntimeError("Failed to encode LogMsg: Failed to write: No space left on device")

    monkeypatch.setattr(rr.RecordingStream, "set_sinks", full)
    save = tmp_path / "w.rrd"
    assert main(["watch", str(live["run"]), "--no-viewer", "--save", str(save)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"ariel: error: cannot write --save {str(save)!r}: Failed to encode LogMsg: Failed to "
        "write: No space left on device\n"
    )
