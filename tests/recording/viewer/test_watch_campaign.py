"""`ariel watch CAMPAIGN_DIR`: every run's best-so-far curve (as campaign.rrd has it), the status
table of condition x seed and each condition's best body, read from the folder only, one
complete generation at a time; read back from the watcher's ``--save`` file."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

rr = pytest.importorskip("rerun")

from ariel.recording.store._campaign import load_campaign  # noqa: E402
from ariel.recording.viewer._watch_campaign import STATUS_ENTITY, CampaignSource  # noqa: E402

CAMPAIGN = Path(__file__).resolve().parents[2] / "data" / "campaign_tiny.toml"
RUNS = [(c, s) for c in ("fresh", "inherit") for s in (1, 2)]


def curves(path: Path) -> dict[str, list[tuple[int, float]]]:
    """Entity -> its (evaluations, best so far) points, from a recording."""
    found: dict[str, list[tuple[int, float]]] = {}
    for chunk in rr.chunk.RrdReader(path).stream().to_chunks():
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names:
            continue
        points = zip(
            batch.column("evaluations").to_pylist(),
            (v[0] for v in batch.column("Scalars:scalars").to_pylist()),
        )
        found.setdefault(chunk.entity_path, []).extend(points)
    return {entity: sorted(points) for entity, points in found.items()}


def static_latest(path: Path, entity: str, column: str) -> Any:
    """The last static value of ``column`` logged at ``entity`` (None if never)."""
    value = None
    for chunk in rr.chunk.RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and chunk.is_static:
            batch = chunk.to_record_batch()
            if column in batch.schema.names:
                value = batch.column(column).to_pylist()[-1]
    return value


def status_rows(path: Path) -> dict[tuple[str, int], list[str]]:
    """The status table (the first Markdown table of ``/status``): (condition, seed) -> cells
    status, generations, evaluations, best."""
    text = static_latest(path, STATUS_ENTITY, "TextDocument:text")[0]
    rows = {}
    for line in text.split("\n\n")[0].splitlines()[2:]:
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        rows[(cells[0], int(cells[1]))] = cells[2:]
    return rows


def folder_state(folder: Path) -> dict[str, tuple[str, int]]:
    """Every file under ``folder``: its SHA-256 and mtime (what the watcher must not change)."""

    def state(path: Path) -> tuple[str, int]:
        return hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns

    return {str(p.relative_to(folder)): state(p) for p in sorted(folder.rglob("*")) if p.is_file()}


class Recorder:
    """A `CampaignSource` logging to a file, polled by hand."""

    def __init__(self, folder: Path, out: Path) -> None:
        self.source = CampaignSource(folder)
        self.rec = rr.RecordingStream("ariel", recording_id="test")
        self.rec.set_sinks(rr.FileSink(str(out)))
        self.out = out

    def poll(self) -> bool:
        return self.source.poll(self.rec)

    def close(self) -> Path:
        self.rec.flush()
        self.rec.disconnect()
        return self.out


@pytest.fixture(scope="module")
def watched(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The tiny campaign (2 conditions x 2 seeds x 3 generations, a few seconds) started in the
    background and watched until it finished (`watch`, no viewer, saved): its folder and the
    watcher's recording."""
    from ariel.recording import watch

    root = tmp_path_factory.mktemp("watch")
    folder, saved = root / "campaign", root / "watch.rrd"
    command = ["campaign", "run", str(CAMPAIGN), "--out", str(folder), "--quiet"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "ariel.cli", *command, "--set", "generations=3"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        while not (folder / "campaign.json").is_file():
            assert proc.poll() is None, proc.communicate()[1]
            time.sleep(0.05)
        with watch(folder, viewer="none", save=saved, poll_s=0.2) as watcher:
            assert watcher.follow(until_finished=True) == "finished"
        assert proc.wait(timeout=120) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return folder, saved


@pytest.fixture(scope="module")
def campaign(watched: tuple[Path, Path]) -> Path:
    """The tiny campaign's folder, finished."""
    return watched[0]


def test_a_running_campaign_watched_has_every_runs_curve_and_the_status_table(
    watched: tuple[Path, Path],
) -> None:
    folder, saved = watched
    # Every run's curve, point for point as campaign.rrd (written at the end) has it.
    assert curves(saved) == curves(folder / "campaign.rrd")
    assert set(curves(saved)) == {f"/condition/{c}/seed/{s}" for c, s in RUNS}
    rows = status_rows(saved)
    assert {key: row[:2] for key, row in rows.items()} == {key: ["finished", "3/3"] for key in RUNS}


def test_a_campaign_watch_has_every_runs_curve_the_status_table_and_best_bodies(
    campaign: Path, tmp_path: Path
) -> None:
    before = folder_state(campaign)
    recorder = Recorder(campaign, tmp_path / "watch.rrd")
    assert recorder.poll()
    assert recorder.source.finished()  # campaign.json says finished; all was read
    assert not recorder.poll()  # nothing new: nothing sent
    saved = recorder.close()
    assert folder_state(campaign) == before  # read only

    # The curves are campaign.rrd's, point for point.
    watched = curves(saved)
    assert set(watched) == {f"/condition/{c}/seed/{s}" for c, s in RUNS}
    assert watched == curves(campaign / "campaign.rrd")
    rows = status_rows(saved)
    assert set(rows) == set(RUNS)
    loaded = load_campaign(campaign)
    for key, (status, generations, evaluations, best) in rows.items():
        run = loaded.runs[key]
        assert status == "finished"
        assert generations == "3/3"
        assert int(evaluations) == len(run.evaluations)
        assert float(best) == pytest.approx(run.info["best_fitness"], rel=1e-5)
    # Each condition's best body: its graph, drawn from the bodies table's graph column.
    for condition in ("fresh", "inherit"):
        bodies = loaded.bodies[loaded.bodies["condition"] == condition]
        best = bodies.loc[bodies["fitness"].astype(float).idxmax()]
        nodes = static_latest(saved, f"/best/{condition}/graph", "GraphNodes:node_ids")
        assert nodes is not None and len(nodes) == best["num_modules"]


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_generations_show_once_complete_and_runs_once_made(campaign: Path, tmp_path: Path) -> None:
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    later = copy / "runs" / "condition=inherit" / "seed=2"
    aside = tmp_path / "aside"
    later.rename(aside)  # a run the campaign has not made yet
    table = copy / "runs" / "condition=fresh" / "seed=1" / "bodies" / "gen-000001.parquet"
    whole = table.read_bytes()
    table.write_bytes(whole[: len(whole) // 2])  # half written: not its manifest's bytes
    recorder = Recorder(copy, tmp_path / "watch.rrd")
    assert recorder.poll()
    rows = status_rows(_flushed(recorder))
    assert rows[("inherit", 2)][:2] == ["not started", "0/3"]
    assert rows[("fresh", 1)][1] == "1/3"  # generation 1 is skipped, silently
    assert rows[("fresh", 2)][1] == "3/3"

    table.write_bytes(whole)
    aside.rename(later)
    assert recorder.poll()  # the rest, now complete
    saved = recorder.close()
    rows = status_rows(saved)
    assert {key: row[:2] for key, row in rows.items()} == {key: ["finished", "3/3"] for key in RUNS}
    assert curves(saved) == curves(campaign / "campaign.rrd")  # nothing twice, nothing lost


def _flushed(recorder: Recorder) -> Path:
    recorder.rec.flush()
    return recorder.out


def test_a_running_campaign_whose_process_is_gone_is_finished_with_its_runs_stopped(
    campaign: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    for folder in [copy] + [copy / "runs" / f"condition={c}" / f"seed={s}" for c, s in RUNS]:
        marker = "campaign.json" if folder == copy else "run.json"
        info = (folder / marker).read_text().replace('"finished"', '"running"')
        (folder / marker).write_text(info)
        (folder / ".lock").write_text(f"pid {dead.pid} on host {os.uname().nodename}\n")
    recorder = Recorder(copy, tmp_path / "watch.rrd")
    recorder.poll()
    assert recorder.source.finished()
    rows = status_rows(recorder.close())
    assert {row[0] for row in rows.values()} == {"stopped (killed?)"}
