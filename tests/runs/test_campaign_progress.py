"""A campaign's progress (one campaign-wide line, each run's generation lines under it) and
`campaign run --dry-run`."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from _helpers import REPO, exit_code, one_error_line

from ariel.cli import main
from ariel.runs._campaign_progress import CampaignProgress, RunProgress

TINY = REPO / "tests" / "data" / "campaign_tiny.toml"


def _display(interval: float) -> tuple[io.StringIO, CampaignProgress, list[RunProgress]]:
    stream = io.StringIO()
    campaign = CampaignProgress(runs=2, total=20, live=False, stream=stream, interval=interval)
    runs = [
        RunProgress(label=f"default seed {seed}", campaign=campaign, total=10, stream=stream)
        for seed in (1, 2)
    ]
    return stream, campaign, runs


def test_runs_report_to_one_campaign_line_with_their_generations_under_it() -> None:
    stream, campaign, (first, second) = _display(interval=1e9)
    with campaign:
        first.start_generation(0, 4)
        second.start_generation(0, 4)
        first.advance(4, 0.25)
        second.advance(3)
        first.end_generation(0, 0.25, 0.1, morphs=(3, 4))
        campaign.run_finished()
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("campaign: evaluations 0/20 (0%), runs finished 0/2, ")
    assert lines[1] == "  default seed 1: gen 0: evaluations 4/10, best 0.25, mean 0.1, morphs 3/4"
    assert lines[2].startswith("campaign: evaluations 7/20 (35%), runs finished 1/2, ")
    assert len(lines) == 3 and (first.done, second.done, campaign.done) == (4, 3, 7)


def test_the_campaign_line_comes_back_while_no_generation_ends() -> None:
    stream, campaign, (first, _) = _display(interval=0.0)
    with campaign:
        first.advance(2)
        first.advance(1)
    lines = stream.getvalue().splitlines()
    assert [line.split(",")[0] for line in lines] == [
        "campaign: evaluations 0/20 (0%)",
        "campaign: evaluations 2/20 (10%)",
        "campaign: evaluations 3/20 (15%)",
        "campaign: evaluations 3/20 (15%)",
    ]


def test_a_quiet_campaign_prints_nothing_and_still_counts() -> None:
    stream = io.StringIO()
    campaign = CampaignProgress(runs=1, total=5, enabled=False, stream=stream, interval=0.0)
    run = RunProgress(label="x seed 1", campaign=campaign, total=5, stream=stream)
    with campaign:
        run.advance(5)
        run.end_generation(0, 1.0, 0.5)
    assert stream.getvalue() == "" and campaign.done == 5


def test_a_dry_run_says_what_the_campaign_will_do_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("os.getloadavg", lambda: (0.0, 0.0, 0.0))
    args = ["campaign", "run", str(TINY), "--dry-run", "--executor", "local", "--workers", "2"]
    args += ["--set", "generations=3"]
    assert main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "campaign tiny: 2 conditions, 4 runs (dry run)"
    # 3 generations of 2 + 2 bodies, brains of popsize 2 x 1 iteration: (2 + 2 * 2) * 2 = 12
    assert lines[1].startswith("  fresh: seeds 1..2 (2 runs) x 12 evaluations of 0.3 s, ")
    assert lines[3] == "total: 48 evaluations on 2 workers"
    assert lines[4].startswith("estimate: about ") and len(lines) == 5  # an idle machine
    assert list(tmp_path.iterdir()) == []
    # A bad file is refused as a real run would refuse it.
    assert exit_code(["campaign", "run", str(TINY), "--dry-run", "--set", "brain.popsize=0"]) == 2
    assert "brain.popsize" in one_error_line(capsys)


def test_the_campaign_line_prints_a_folder_name_with_control_sequences_as_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.runs import run_campaign

    out = tmp_path / "d\x1b[2J" / "camp"  # the campaign id is its folder's name: no such id
    run_campaign(TINY, out=out, progress=True, overrides=["generations=1"])
    printed = capsys.readouterr().out
    assert "\x1b" not in printed and "d\\x1b[2J/camp" in printed


def test_a_busy_machine_s_estimate_is_scaled_to_its_load(monkeypatch: pytest.MonkeyPatch) -> None:
    """The estimate was for idle cores only: 2 min said, 7 taken at a load of 5 on 2 cores."""
    from ariel.runs import _campaign_plan
    from ariel.runs._campaign_plan import CampaignPlan, plan_text

    row = {"condition": "a", "seeds": [1], "evaluations": 60, "simulated_seconds": 1.0}
    plan = CampaignPlan("c", workers=2, rows=[{**row, "seconds_per_evaluation": 2.0}])
    monkeypatch.setattr(_campaign_plan, "default_workers", lambda: 2)
    monkeypatch.setattr("os.getloadavg", lambda: (4.0, 4.0, 4.0))
    lines = plan_text(plan)
    assert lines[-2].startswith("estimate: about 1 min with the cores to itself")
    busy = "  this machine is busy now (load 4.0 on 2 cores): at this load, about 3 min"
    assert lines[-1] == busy
    plan.local = False  # a cluster's workers: this machine's load says nothing of them
    assert plan_text(plan)[-1].startswith("estimate: about 1 min")
    plan.local = True
    monkeypatch.setattr("os.getloadavg", lambda: (0.1, 0.1, 0.1))  # room for the 2 workers
    assert plan_text(plan)[-1].startswith("estimate: about 1 min")
    plan.workers = 8  # more workers than cores on an idle machine: not "busy"
    monkeypatch.setattr("os.getloadavg", lambda: (0.0, 0.0, 0.0))
    assert plan_text(plan)[-1].startswith("estimate: about ")


def test_a_dry_run_of_many_conditions_times_a_few(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A grid of 1,000 conditions was still being timed after minutes, a second each."""
    from ariel.runs import _campaign_plan

    timed = []
    monkeypatch.setattr(_campaign_plan, "MOST_TIMED", 2)
    monkeypatch.setattr(
        _campaign_plan,
        "_seconds_per_evaluation",
        lambda run: timed.append(run) or 0.1 * run.config.task.duration,
    )
    file = tmp_path / "grid.toml"
    file.write_text(
        'base = { name = "g", generations = 1, executor = { kind = "serial" } }\nseeds = [1]\n'
        '[grid]\n"task.duration" = [1.0, 3.0, 5.0, 7.0, 10.0]\n'
    )
    plan = _campaign_plan.campaign_plan(file)
    assert len(timed) == 2 and len(plan.rows) == 5
    # The mean per simulated second, times each condition's own duration.
    assert plan.rows[4]["seconds_per_evaluation"] == pytest.approx(1.0)
    lines = _campaign_plan.plan_text(plan)
    assert lines[5].endswith("ms per evaluation here (the timed conditions' mean)")
    assert "  (the first 2 of 5 conditions timed; the others counted at their mean)" in lines


def test_a_tiny_campaigns_estimate_reads_as_time() -> None:
    """It said 'estimate: about 0 s'."""
    from ariel.runs._campaign_plan import _duration

    assert [_duration(s) for s in (0.2, 12, 600, 9000)] == ["a second", "12 s", "10 min", "2.5 h"]
