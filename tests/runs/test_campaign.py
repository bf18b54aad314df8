"""Campaigns: conditions x seeds on one executor, each run's records those of a lone run.

The tiny campaign (tests/data/campaign_tiny.toml): brain inheritance off / on, seeds 1 and 2,
2 generations of 2 + 2 bodies, brains of popsize 2 for 0.3 s.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import shlex
import shutil
import signal
from pathlib import Path

import pytest
from _helpers import REPO, exit_code, one_error_line, plain

from ariel.cli import main
from ariel.evolution._progress import Progress
from ariel.recording import load_campaign, load_run
from ariel.runs import resume_campaign, run_campaign
from ariel.utils import ariel_line

TINY = REPO / "tests" / "data" / "campaign_tiny.toml"
RUNS = [("fresh", 1), ("fresh", 2), ("inherit", 1), ("inherit", 2)]
_ORDER = {"evaluations": ["eval_id"], "bodies": ["body_id"], "trajectories": ["eval_id", "t"]}
_UNMEASURED = {"wall_seconds", "run_id"}  # a measured time; the run's id names its folder


def digests(run_dir: Path) -> dict[str, str]:
    """``"<table>/gen-N"`` -> SHA-256 of the table's rows, bit-exact, in id order (like
    tests/e2e/test_golden_records.py, without ``run_id`` and ``wall_seconds``)."""
    import pyarrow.parquet as pq

    found = {}
    for table, order in _ORDER.items():
        for path in sorted((run_dir / table).glob("gen-*.parquet")):
            frame = pq.read_table(path).to_pandas().sort_values(order, kind="stable")
            columns = [c for c in frame.columns if c not in _UNMEASURED]
            rows = [[plain(v) for v in row] for row in frame[columns].itertuples(False)]
            text = json.dumps([columns, rows], default=str)
            found[f"{table}/{path.stem}"] = hashlib.sha256(text.encode()).hexdigest()
    return found


def campaign_digests(folder: Path) -> dict[tuple[str, int], dict[str, str]]:
    return {key: digests(folder / f"runs/condition={key[0]}/seed={key[1]}") for key in RUNS}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny campaign on 2 local worker processes (evaluations of all runs interleave)."""
    out = tmp_path_factory.mktemp("campaign") / "tiny"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(
            [
                *("campaign", "run", str(TINY), "--out", str(out)),
                *("--executor", "local", "--workers", "2", "--quiet"),
            ]
        )
    assert code == 0
    assert "finished: campaign tiny: 4 of 4 runs finished" in printed.getvalue()
    return out


def test_every_run_is_a_normal_run_folder_in_a_hive_layout(campaign: Path) -> None:
    info = json.loads((campaign / "campaign.json").read_text())
    assert info["status"] == "finished" and info["seeds"] == [1, 2]
    assert [c["name"] for c in info["conditions"]] == ["fresh", "inherit"]
    for condition, seed in RUNS:
        run = load_run(campaign / f"runs/condition={condition}/seed={seed}")
        assert run.info["status"] == "finished" and run.generations_done == 2
        assert run.config["seed"] == seed
        assert run.config["brain"]["inherit"] == (condition == "inherit")
        assert not (run.path / ".lock").exists()  # every lock released
    # pyarrow reads all runs' evaluations as one dataset, condition and seed from the paths.
    import pyarrow as pa
    import pyarrow.dataset as ds

    files = sorted(str(p) for p in campaign.glob("runs/*/*/evaluations/*.parquet"))
    # The table's own ``seed`` (each evaluation's) has the partition's name: int64 for both.
    hive = ds.partitioning(
        pa.schema([("condition", pa.string()), ("seed", pa.int64())]), flavor="hive"
    )
    dataset = ds.dataset(
        files, format="parquet", partitioning=hive, partition_base_dir=str(campaign / "runs")
    )
    table = dataset.to_table(columns=["condition", "eval_id"])
    assert table.num_rows == len(load_campaign(campaign).evaluations)
    assert set(table["condition"].to_pylist()) == {"fresh", "inherit"}


def test_each_run_s_records_equal_a_lone_run_of_its_config_bit_for_bit(
    campaign: Path, tmp_path: Path
) -> None:
    from ariel.evolution import run_experiment

    entries = json.loads((campaign / "campaign.json").read_text())["runs"]
    for entry in entries:
        key = (entry["condition"], entry["seed"])
        lone = run_experiment(entry["config"], out=tmp_path / f"{key[0]}-{key[1]}")
        alone, within = digests(lone.run_dir), digests(campaign / entry["path"])
        assert len(within) == 6 and alone == within, key  # 3 tables x 2 generations
    # Inheritance changes the records (the two conditions are not the same run twice).
    found = campaign_digests(campaign)
    assert (
        found[("fresh", 1)]["evaluations/gen-000001"]
        != found[("inherit", 1)]["evaluations/gen-000001"]
    )


def test_load_campaign_joins_the_tables_with_condition_and_seed(campaign: Path) -> None:
    loaded = load_campaign(campaign)
    assert loaded.conditions == ["fresh", "inherit"] and loaded.seeds == [1, 2]
    # One line, as Run's (it printed all of campaign.json, every run's config included).
    assert repr(loaded) == f"<Campaign {campaign.name}: 2 conditions x 2 seeds, 4 runs loaded>"
    assert loaded.maximise is True
    for table in ("evaluations", "bodies", "generations"):
        frame = getattr(loaded, table)
        assert list(frame.columns[:2]) == ["condition", "seed"]
        for (condition, seed), run in loaded.runs.items():
            part = frame[(frame["condition"] == condition) & (frame["seed"] == seed)]
            assert len(part) == len(getattr(run, table)) > 0
    evaluations = loaded.evaluations  # each evaluation's own seed kept as eval_seed
    own = loaded.runs[("inherit", 2)].evaluations["seed"].tolist()
    assert (
        evaluations[evaluations["condition"] == "inherit"]["eval_seed"].tolist()[-len(own) :] == own
    )
    rows = loaded.status()
    assert [(r["condition"], r["seed"], r["status"]) for r in rows] == [
        (c, s, "finished") for c, s in RUNS
    ]


def test_status_prints_a_table_of_condition_seed_status_generations_best(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["campaign", "status", str(campaign)]) == 0
    out = capsys.readouterr().out
    best = load_run(campaign / "runs/condition=inherit/seed=2").info["best_fitness"]
    assert f"{best:.6g}" in out and out.count("finished") == 4 and "2/2" in out
    # Run again into it: a finished campaign has nothing to resume; the hint says compare.
    assert exit_code(["campaign", "run", str(TINY), "--out", str(campaign)]) == 2
    assert one_error_line(capsys).endswith(
        f"already exists; choose another --out, or compare its runs (it is finished): "
        f"{ariel_line('compare', campaign)}"
    )


def _curves(recording: Path) -> dict[str, list[float]]:
    """campaign.rrd's curves: entity path -> its values."""
    rr = pytest.importorskip("rerun")
    store = rr.chunk.RrdReader(recording).stream().collect()
    series = {}
    for chunk in store.stream().to_chunks():
        batch = chunk.to_record_batch()
        if not chunk.is_static and "Scalars:scalars" in batch.schema.names:
            series[chunk.entity_path] = [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    return series


def test_campaign_rrd_holds_every_run_s_best_so_far_and_view_opens_it(campaign: Path) -> None:
    from ariel.recording.store._curves import best_so_far
    from ariel.recording.viewer._view import select_recordings

    series = _curves(campaign / "campaign.rrd")
    assert sorted(series) == sorted(f"/condition/{c}/seed/{s}" for c, s in RUNS)
    run = load_run(campaign / "runs/condition=fresh/seed=2")
    _, best = best_so_far(run.evaluations, maximise=True)
    assert series["/condition/fresh/seed/2"] == best.tolist()
    selection = select_recordings(campaign)
    assert selection.recordings == (campaign / "campaign.rrd",)
    assert selection.blueprint == campaign / "campaign.rbl"


def test_a_campaign_without_its_recording_is_viewed_without_writing_into_it(
    campaign: Path, tmp_path: Path
) -> None:
    """One stopped after its last run (or running, or read-only) had campaign.rrd written
    into it by `ariel view`: a traceback where the folder could not be written."""
    import shutil

    from ariel.recording.viewer._view import _prepared, select_recordings

    copy = tmp_path / "copy"
    shutil.copytree(campaign, copy)
    (copy / "campaign.rrd").unlink()
    (copy / "campaign.rbl").unlink()
    before = sorted(p.relative_to(copy) for p in copy.rglob("*"))
    with _prepared(select_recordings(copy)) as shown:
        (recording,) = shown.recordings
        assert not recording.is_relative_to(copy) and shown.blueprint is not None
        assert _curves(recording) == _curves(campaign / "campaign.rrd")
    assert not recording.exists()  # the view's own files go with it
    assert sorted(p.relative_to(copy) for p in copy.rglob("*")) == before


def test_existing_commands_work_on_a_campaign_s_run_folders(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = campaign / "runs/condition=inherit/seed=1"
    assert main(["runs", str(campaign / "runs/condition=inherit")]) == 0
    assert "tiny-inherit-s1" in capsys.readouterr().out
    # The campaign's listing names each run by its folder (a run id is no folder to type), and
    # CAMPAIGN/runs lists them too (it said "no runs under").
    for listed in (campaign, campaign / "runs", Path(".")):
        if listed == Path("."):  # `ariel runs .` inside CAMPAIGN/runs
            os.chdir(campaign / "runs")
        try:
            assert main(["runs", str(listed)]) == 0
        finally:
            os.chdir(REPO)
        names = [line.split()[0] for line in capsys.readouterr().out.splitlines()[1:]]
        assert [Path(name).parts[-2:] for name in names] == [
            (f"condition={c}", f"seed={s}") for c, s in RUNS
        ]
    # The folder of campaign folders: "no runs under" alone, as if it were empty.
    assert main(["runs", str(campaign.parent)]) == 0
    assert capsys.readouterr().out.strip() == (
        f"no runs under {campaign.parent}; it holds 1 campaign folder (tiny): list a "
        f"campaign's runs with: {ariel_line('runs', campaign)}"
    )
    # Beside runs, the campaign folders were not named at all.
    shutil.copytree(campaign / "runs/condition=inherit/seed=1", tmp_path / "run")
    (tmp_path / "tiny").symlink_to(campaign, target_is_directory=True)
    assert main(["runs", str(tmp_path)]) == 0
    listed = capsys.readouterr().out.strip().splitlines()
    assert len(listed) == 3 and listed[1].startswith("run (run id tiny-inherit-s1)")
    assert listed[2] == (
        f"{tmp_path} also holds 1 campaign folder (tiny): list a campaign's runs with: "
        f"{ariel_line('runs', tmp_path / 'tiny')}"
    )
    assert main(["report", str(run_dir), "--no-render"]) == 0
    assert (run_dir / "report" / "fitness.png").is_file()
    assert main(["replay", str(run_dir), "best"]) == 0
    assert "identical: yes, bit for bit" in capsys.readouterr().out
    assert exit_code(["resume", str(run_dir), "--quiet"]) == 2
    assert "already finished" in one_error_line(capsys)


def test_compare_a_campaign_writes_figures_tables_and_one_page(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "compare"
    assert main(["compare", str(campaign), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "fresh" in printed and "inherit" in printed and "runs: fresh 2, inherit 2" in printed
    figures = ("best_so_far.png", "final_best.png", "morphology.png", "lineages.png")
    for name in (*figures, "stats.csv", "stats.md"):
        assert (out / name).is_file(), name
    html = (out / "compare.html").read_text()
    assert html.count('src="data:image/png;base64,') == len(figures) and "fresh" in html
    # Plain run folders: grouped by how their configs differ (brain.inherit).
    runs = [str(campaign / f"runs/condition={c}/seed={s}") for c, s in RUNS]
    assert main(["compare", *runs, "--out", str(tmp_path / "plain")]) == 0
    assert "brain.inherit=false 2, brain.inherit=true 2" in capsys.readouterr().out


def _relabelled(campaign: Path, folder: Path, shift: int) -> Path:
    """A copy of ``campaign`` whose runs stand for seeds ``seed + shift`` (campaign.json and
    the run folders' names): the same campaign file extended with more seeds, for pooling."""
    import shutil

    shutil.copytree(campaign, folder, symlinks=True)
    info = json.loads((folder / "campaign.json").read_text())
    for entry in info["runs"]:
        old = folder / entry["path"]
        entry["seed"] += shift
        entry["path"] = f"runs/condition={entry['condition']}/seed={entry['seed']}"
        old.rename(folder / entry["path"])
    info["seeds"] = [s + shift for s in info["seeds"]]
    for condition in info["conditions"]:
        condition["seeds"] = [s + shift for s in condition["seeds"]]
    (folder / "campaign.json").write_text(json.dumps(info))
    return folder


def test_folders_of_one_campaign_on_other_seeds_are_pooled_paired(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    more = _relabelled(campaign, tmp_path / "more", 2)
    out = tmp_path / "pooled"
    assert main(["compare", str(campaign), str(more), "--out", str(out)]) == 0
    assert "runs: fresh 4, inherit 4" in capsys.readouterr().out
    stats = (out / "stats.csv").read_text()
    assert "wilcoxon" in stats.lower() and "mann" not in stats.lower()
    assert "pooled from 2 folders" in (out / "README.md").read_text()
    # A seed in two folders, and a folder of another campaign, are refused in one line.
    copy = _relabelled(campaign, tmp_path / "copy", 0)
    assert exit_code(["compare", str(campaign), str(copy), "--out", str(out)]) == 2
    assert "must have different seeds" in one_error_line(capsys)
    other = _relabelled(campaign, tmp_path / "other", 4)
    info = json.loads((other / "campaign.json").read_text())
    info["conditions"][1]["set"] = {"brain.inherit": False}
    (other / "campaign.json").write_text(json.dumps(info))
    assert exit_code(["compare", str(campaign), str(other), "--out", str(out)]) == 2
    assert "is not the same campaign" in one_error_line(capsys)
    # The same file run with another --set (a campaign-wide setting): pooled silently before.
    varied = _relabelled(campaign, tmp_path / "varied", 6)
    for run_json in varied.glob("runs/*/*/run.json"):
        info = json.loads(run_json.read_text())
        info["config"]["body"]["tournament"] = 3
        run_json.write_text(json.dumps(info))
    assert exit_code(["compare", str(campaign), str(varied), "--out", str(out)]) == 2
    assert "ran with other settings in" in (line := one_error_line(capsys)), line
    assert "(body.tournament): pooled campaign folders must run one campaign file" in line


def _interrupt_at(monkeypatch: pytest.MonkeyPatch, call: int) -> None:
    """Ctrl-C in the ``call``-th generation end of the campaign (after its checkpoint)."""
    original, calls = Progress.end_generation, []

    def end_generation(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        calls.append(generation)
        if len(calls) == call:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "end_generation", end_generation)


def test_an_interrupted_campaign_resumes_to_the_records_of_an_uninterrupted_one(
    campaign: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "tiny"  # the same folder name: the same run ids
    # Serial: every run's generation 0 ends first (calls 1-4), then generation 1; the 7th
    # call comes after two runs finished and before the others did.
    _interrupt_at(monkeypatch, 7)
    with pytest.raises(KeyboardInterrupt) as caught:
        run_campaign(TINY, out=out)
    assert caught.value.__notes__[-1].endswith(f"resume_campaign({str(out)!r})")
    monkeypatch.undo()
    statuses = {(r["condition"], r["seed"]): r["status"] for r in load_campaign(out).status()}
    assert sorted(statuses.values()) == ["finished", "finished", "interrupted", "interrupted"]
    assert json.loads((out / "campaign.json").read_text())["status"] == "interrupted"
    # A campaign killed (SIGKILL) after a run finished leaves that run's .lock: resume clears it.
    finished = [key for key, status in statuses.items() if status == "finished"]
    stale = out / f"runs/condition={finished[0][0]}/seed={finished[0][1]}/.lock"
    stale.write_text("pid 999999999 on host gone\n")
    resumed = resume_campaign(out)
    assert resumed.status == "finished" and resumed.skipped == 2 and len(resumed.runs) == 2
    assert not list(out.rglob(".lock"))
    # one line in a notebook (the dataclass's own repr was 1,261 characters)
    assert repr(resumed).startswith("<CampaignResult tiny: finished, 2 runs driven, 2 finished")
    assert campaign_digests(out) == campaign_digests(campaign)
    with pytest.raises(ValueError, match="already finished"):
        resume_campaign(out)


def test_a_campaign_stopped_after_its_last_run_gets_its_own_records_on_resume(
    campaign: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import shutil

    import ariel.runs._campaign as module

    out = tmp_path / "tiny"
    shutil.copytree(campaign, out)
    info = json.loads((out / "campaign.json").read_text())
    (out / "campaign.json").write_text(json.dumps({**info, "status": "running"}))
    (out / "campaign.rrd").unlink()  # as if stopped while campaign.rrd was being written

    def stopped(path: object) -> None:
        raise KeyboardInterrupt

    with monkeypatch.context() as patched:
        patched.setattr(module.rerun, "write_campaign_recording", stopped)
        with pytest.raises(KeyboardInterrupt):
            resume_campaign(out)
    # "finished" is written after the recording, never before it
    assert json.loads((out / "campaign.json").read_text())["status"] == "interrupted"
    # status and a run into it say so, not "it is finished: compare its runs"
    assert main(["campaign", "status", str(out)]) == 0
    resume = ariel_line("campaign", "resume", out)
    assert f"says 'interrupted'): write campaign.rrd and its status with: {resume}" in (
        capsys.readouterr().out
    )
    assert exit_code(["campaign", "run", str(TINY), "--out", str(out)]) == 2
    assert one_error_line(capsys).endswith(f"continue it with: {resume}")
    # The hint printed after such an interrupt works: it writes the records, runs nothing,
    # and deletes what a killed writer of them left (kept for good before)
    left = [out / ".campaign.rbl.963bbed2.tmp", out / ".campaign.json.tmp"]
    for temporary in [*left, out / ".notes.tmp"]:
        temporary.write_text("half written")
    assert main(["campaign", "resume", str(out), "--quiet"]) == 0
    assert not any(temporary.exists() for temporary in left)
    assert (out / ".notes.tmp").exists()  # not the campaign's: the user's own
    assert "its 4 runs had finished; its recording and status are written now" in (
        capsys.readouterr().out
    )
    assert json.loads((out / "campaign.json").read_text())["status"] == "finished"
    assert _curves(out / "campaign.rrd") == _curves(campaign / "campaign.rrd")
    with pytest.raises(ValueError, match="already finished"):
        resume_campaign(out)


def test_a_second_campaign_run_into_a_folder_in_use_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It said the folder exists and to `campaign resume` it, which then said "in use"."""
    from ariel.recording.store import RunLock

    out = tmp_path / "tiny"
    with RunLock(out, create=True):  # a campaign run that has just begun
        (out / "campaign.json").write_text("{}")
        assert exit_code(["campaign", "run", str(TINY), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"ariel: error: campaign folder {str(out)!r} is in use by pid "), line
    assert sorted(p.name for p in out.iterdir()) == ["campaign.json"]


def test_a_campaign_made_in_the_folder_meanwhile_is_not_overwritten(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The folder is checked again under its lock: another `campaign run` that made it
    between the first check and the lock kept its campaign.json (it was replaced)."""
    from ariel.runs import _campaign

    out = tmp_path / "tiny"
    original = _campaign.campaign_info

    def made_meanwhile(*args, **kwargs):
        out.mkdir()
        (out / "campaign.json").write_text("theirs")
        return original(*args, **kwargs)

    monkeypatch.setattr(_campaign, "campaign_info", made_meanwhile)
    assert exit_code(["campaign", "run", str(TINY), "--out", str(out), "--quiet"]) == 2
    assert "already exists" in one_error_line(capsys)
    assert (out / "campaign.json").read_text() == "theirs" and not (out / "runs").exists()


def test_sigterm_stops_a_campaign_command_like_ctrl_c(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    original = Progress.end_generation

    def end_generation(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)  # a batch system ending the job

    monkeypatch.setattr(Progress, "end_generation", end_generation)
    out = tmp_path / "tiny"
    before = signal.getsignal(signal.SIGTERM)
    assert main(["campaign", "run", str(TINY), "--out", str(out), "--quiet"]) == 128 + 15
    assert signal.getsignal(signal.SIGTERM) is before  # the command's handler is gone again
    (line,) = capsys.readouterr().err.strip().splitlines()
    resume = rf"\S*ariel campaign resume {re.escape(str(out))}"
    assert re.fullmatch(rf"interrupted \(SIGTERM\); continue it with: {resume}", line), line
    assert json.loads((out / "campaign.json").read_text())["status"] == "interrupted"


def test_ctrl_c_without_out_names_the_campaigns_real_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def interrupt(self, generation, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    with monkeypatch.context() as patch:
        patch.setattr(Progress, "end_generation", interrupt)
        assert main(["campaign", "run", str(TINY), "--quiet"]) == 130
    (line,) = capsys.readouterr().err.strip().splitlines()
    words = shlex.split(line.split("; continue it with: ", 1)[1])
    at = words.index("campaign")
    (made,) = Path("data/campaigns").iterdir()  # data/campaigns/tiny-<time>, no placeholder
    assert words[at:] == ["campaign", "resume", str(made)], line
    assert main([*words[at:], "--quiet"]) == 0  # the pasted command, after its `ariel`
    assert json.loads((made / "campaign.json").read_text())["status"] == "finished"


def test_a_campaign_runs_on_a_dask_cluster_through_its_address(
    campaign: Path, tmp_path: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        result = run_campaign(
            TINY, out=tmp_path / "tiny", executor="dask", address=cluster.scheduler_address
        )
    assert result.status == "finished" and result.workers == 2
    assert campaign_digests(tmp_path / "tiny") == campaign_digests(campaign)
