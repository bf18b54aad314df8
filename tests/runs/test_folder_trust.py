"""A run or campaign folder is data (issue 27, items 3, 4 and 11): resuming one never connects
to a Dask scheduler it names, and campaign.json's run paths are only ever
``runs/condition=<name>/seed=<n>`` inside the campaign, with no link on the way.

No evaluation runs here: the campaign is made with an executor that stops at once (its runs
are created and left ``failed``, resumable), and each resume stops where it would make its
executor, after recording what it was given.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from _helpers import REPO, StoppedError, edit_json, exit_code, one_error_line, stop_at_executor

from ariel.evolution import ConfigError
from ariel.recording import load_campaign
from ariel.recording.store._campaign import NotACampaignError
from ariel.runs import resume_campaign, resume_experiment
from ariel.runs._campaign_file import load_campaign_file

TINY = REPO / "tests" / "data" / "campaign_tiny.toml"
ROGUE = "tcp://10.0.0.1:8786"


def _name_the_rogue_scheduler(info: dict[str, Any], key: str = "address") -> None:
    """A folder that ran (or claims it ran) on the Dask scheduler ROGUE; ``key="scheduler"``:
    as folders written before ``address`` had its name."""
    info["executor"] = {"kind": "dask", "workers": None, key: ROGUE}
    for config in [info.get("config")] + [r["config"] for r in info.get("runs", [])]:
        if config is not None:
            config["executor"].pop("address")
            config["executor"].update({"kind": "dask", "workers": None, key: ROGUE})


def _name_the_rogue_scheduler_the_old_way(info: dict[str, Any]) -> None:
    _name_the_rogue_scheduler(info, "scheduler")


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``root`` (links not followed) with its size and modification time."""
    found = {}
    for parent, folders, files in os.walk(root):
        for name in folders + files:
            stat = (Path(parent) / name).lstat()
            found[os.path.join(parent, name)] = (stat.st_size, stat.st_mtime_ns)
    return found


# --- item 3: a scheduler address is never taken from a folder ---------------------------------


@pytest.mark.parametrize(
    "name_it", [_name_the_rogue_scheduler, _name_the_rogue_scheduler_the_old_way]
)
def test_resume_never_connects_to_the_scheduler_a_run_json_names(
    campaign: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    name_it: Any,
) -> None:
    run_dir = campaign / "runs/condition=fresh/seed=1"
    edit_json(run_dir / "run.json", name_it)
    given = stop_at_executor(monkeypatch)
    with pytest.raises(StoppedError):
        exit_code(["resume", str(run_dir), "--quiet"])
    (settings,) = given
    assert (settings.kind, settings.address) == ("dask", None)  # a local Dask cluster
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"note: not connecting to the Dask scheduler '{ROGUE}'"), line
    assert re.search(rf"\S*ariel resume {re.escape(str(run_dir))} --address ADDRESS$", line)
    # An address passed here is used (and implies --executor dask), without the note.
    with pytest.raises(StoppedError):
        resume_experiment(run_dir, address="tcp://127.0.0.1:8786")
    assert (given[1].kind, given[1].address) == ("dask", "tcp://127.0.0.1:8786")
    # Another executor asked for: the stored address is beside the point.
    with pytest.raises(StoppedError):
        resume_experiment(run_dir, executor="serial")
    assert (given[2].kind, given[2].address) == ("serial", None)
    assert capsys.readouterr().err == ""


def test_the_old_name_scheduler_still_gives_the_address(
    campaign: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from ariel.runs import run_campaign, run_experiment

    run_dir = campaign / "runs/condition=fresh/seed=1"
    given = stop_at_executor(monkeypatch)
    with pytest.raises(StoppedError):
        exit_code(["resume", str(run_dir), "--quiet", "--scheduler", "tcp://127.0.0.1:1"])
    with pytest.raises(StoppedError):
        resume_experiment(run_dir, scheduler="tcp://127.0.0.1:2")
    assert [(s.kind, s.address) for s in given] == [
        ("dask", "tcp://127.0.0.1:1"),
        ("dask", "tcp://127.0.0.1:2"),
    ]
    both = r"got both 'address' and its alias 'scheduler'"
    for entry, where in [
        (run_experiment, None),
        (resume_experiment, run_dir),
        (run_campaign, TINY),
        (resume_campaign, campaign),
    ]:
        with pytest.raises(TypeError, match=f"{entry.__name__}\\(\\) {both}"):
            entry(where, address="tcp://127.0.0.1:1", scheduler="tcp://127.0.0.1:1")
    capsys.readouterr()  # the flags' two names: argparse alone would take the last, unsaid
    flags = ["--address", "tcp://127.0.0.1:1", "--scheduler", "tcp://127.0.0.1:2"]
    assert exit_code(["resume", str(run_dir), "--quiet", *flags]) == 2
    assert "--address and --scheduler (its old name) name one setting" in capsys.readouterr().err


@pytest.mark.parametrize(
    "name_it", [_name_the_rogue_scheduler, _name_the_rogue_scheduler_the_old_way]
)
def test_campaign_resume_never_connects_to_the_scheduler_campaign_json_names(
    campaign: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    name_it: Any,
) -> None:
    edit_json(campaign / "campaign.json", name_it)
    for run_json in campaign.glob("runs/*/*/run.json"):
        edit_json(run_json, name_it)
    given = stop_at_executor(monkeypatch)
    with pytest.raises(StoppedError):
        exit_code(["campaign", "resume", str(campaign), "--quiet"])
    assert [(s.kind, s.address) for s in given] == [("dask", None)]
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"note: not connecting to the Dask scheduler '{ROGUE}'"), line
    assert line.endswith(f"campaign resume {campaign} --address ADDRESS")


def test_a_stored_worker_count_is_kept_only_where_this_machine_has_the_cpus() -> None:
    from ariel.evaluation._threads import default_workers
    from ariel.evolution import ExperimentConfig
    from ariel.runs._prepare import resume_settings

    config = ExperimentConfig()

    def resumed(stored: Any) -> Any:
        return resume_settings(
            config, stored, kind=None, workers=None, address=None, command=("resume", "r")
        )

    assert resumed({"kind": "local", "workers": 1}).workers == 1
    assert resumed({"kind": "local", "workers": default_workers() + 1}).workers is None
    assert resumed({"kind": "local", "workers": True}).workers is None
    assert resumed({"kind": "\x1b[2J", "workers": 10**9}).kind == config.executor.kind


# --- item 4: campaign.json's run paths ----------------------------------------------------------


def _set_first_path(path: str) -> Any:
    def change(info: dict[str, Any]) -> None:
        info["runs"][0]["path"] = path

    return change


def _refused(campaign: Path, capsys: pytest.CaptureFixture[str], expected: str) -> None:
    """Every reader and resume refuse the campaign in one line (exit 2) naming ``expected``,
    before writing anything anywhere."""
    before = _tree(campaign.parent)
    commands = (["campaign", "resume", "--quiet"], ["campaign", "status"], ["view"], ["compare"])
    for command in commands:
        assert exit_code([*command, str(campaign)]) == 2, command
        line = one_error_line(capsys, quiet=True)
        assert expected in line, (command, line)
    with pytest.raises(NotACampaignError, match=re.escape(expected)):
        load_campaign(campaign)
    with pytest.raises(NotACampaignError):
        resume_campaign(campaign)
    assert _tree(campaign.parent) == before


@pytest.mark.parametrize(
    "path",
    [
        "../x",
        "runs/condition=fresh/../../../x",
        "runs/condition=inherit/seed=2",  # another run of this campaign
        "runs/condition=fresh/seed=1/",
        "ABSOLUTE",
    ],
)
def test_a_run_path_out_of_place_is_refused_in_one_line(
    campaign: Path, path: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if path == "ABSOLUTE":
        path = str(campaign.parent / "elsewhere")
    edit_json(campaign / "campaign.json", _set_first_path(path))
    _refused(campaign, capsys, "runs[0] (condition fresh, seed 1): refusing path")
    assert not (campaign.parent / "x").exists() and not (campaign.parent / "elsewhere").exists()


def test_a_path_to_another_campaign_s_run_is_refused_and_that_run_left_alone(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = Path(shutil.copytree(campaign, campaign.parent / "other", symlinks=True))
    edit_json(campaign / "campaign.json", _set_first_path("../other/runs/condition=fresh/seed=1"))
    _refused(campaign, capsys, "refusing path '../other/runs/condition=fresh/seed=1'")
    assert json.loads((other / "runs/condition=fresh/seed=1/run.json").read_text())["status"] == (
        "failed"
    )


@pytest.mark.parametrize("link", ["runs", "runs/condition=fresh", "runs/condition=fresh/seed=1"])
def test_a_linked_runs_condition_or_run_folder_is_refused(
    campaign: Path, link: str, capsys: pytest.CaptureFixture[str]
) -> None:
    target = campaign.parent / "outside"
    (campaign / link).rename(target)
    (campaign / link).symlink_to(target)
    _refused(campaign, capsys, "a symbolic link")


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda r: r.update(seed=True), "seed True is not a seed"),
        (lambda r: r.update(seed="1"), "seed '1' is not a seed"),
        (lambda r: r.update(seed=1.0), "seed 1.0 is not a seed"),
        (lambda r: r.update(condition="../../x"), "condition '../../x' is not a condition name"),
        (lambda r: r.update(condition="\x1b[2J"), r"condition '\x1b[2J' is not"),
    ],
)
def test_a_run_entry_with_a_bad_seed_or_condition_is_refused(
    campaign: Path, change: Any, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(campaign / "campaign.json", lambda info: change(info["runs"][0]))
    _refused(campaign, capsys, expected)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            lambda info: info.update(campaign_id="x\x1b[2J\x1b]0;pwned\x07"),
            r"its campaign_id 'x\x1b[2J\x1b]0;pwned\x07' is not a campaign id (letters",
        ),
        (
            lambda info: info["runs"][1].update(run_id='../../x\n"""import os'),
            "runs[1] (condition fresh, seed 2): its run_id '../../x\\n",
        ),
        (
            lambda info: info.update(conditions=[]),
            "runs[0] (condition fresh, seed 1): its condition is not among the campaign's "
            "conditions ([])",
        ),
        (
            lambda info: info.pop("conditions"),
            "its condition is not among the campaign's conditions ([])",
        ),
    ],
)
def test_campaign_ids_and_conditions_are_checked_on_read(
    campaign: Path, change: Any, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A crafted campaign id or run id (control sequences, a path, Python) never reaches a run
    resume makes; runs of conditions the campaign does not have end no resume in a KeyError."""
    edit_json(campaign / "campaign.json", change)
    _refused(campaign, capsys, expected)


@pytest.mark.parametrize("seeds", ["[true]", '["3"]', "[2.0]"])
def test_campaign_file_seeds_are_strict_integers(seeds: str, tmp_path: Path) -> None:
    file = tmp_path / "c.toml"
    file.write_text(f'base = {{ name = "t" }}\nseeds = {seeds}\n')
    with pytest.raises(ConfigError, match=r"^seeds\.0: must be a valid integer \(got "):
        load_campaign_file(file)
    file.write_text(f'base = {{ name = "t" }}\nseed_count = {seeds[1:-1]}\n')
    with pytest.raises(ConfigError, match=r"^seed_count: must be a valid integer \(got "):
        load_campaign_file(file)


# --- a run made by an ariel whose results differ ---------------------------------------------


def _made_before_version_1(info: dict[str, Any]) -> None:
    """run.json as an ariel from before task.settle wrote it (results version 0)."""
    info.pop("results_version")
    info["config"]["task"].pop("settle")


@pytest.mark.parametrize(
    "made_by",
    [lambda info: info.update(results_version=0), _made_before_version_1],
    ids=["version-0", "before-the-key"],
)
def test_a_run_of_another_results_version_is_not_resumed(
    campaign: Path, made_by: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    """Resumed, a run killed under the old algorithm went on under the new one: generations
    of two algorithms in one run, matching neither, without a word."""
    from ariel.evolution import RESULTS_VERSION, results_version

    run = next(campaign.glob("runs/*/*"))
    assert results_version(json.loads((run / "run.json").read_text())) == RESULTS_VERSION
    edit_json(run / "run.json", made_by)
    before = _tree(run)
    assert exit_code(["resume", str(run), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert "was made by an ariel whose results differ from this one's (results version 0;" in line
    assert "would mix two algorithms" in line
    assert _tree(run) == before  # nothing written, not even a segment
    # Which ariel made it, and a way on: the config it began with, as a file to run.
    made = json.loads((run / "run.json").read_text())["created"][:10]
    assert f"(made {made}; run.json names no git commit)" in line or "(commit " in line
    assert f"config show {run} > config.toml" in line
    assert exit_code(["config", "show", str(run)]) == 0
    shown = capsys.readouterr().out
    assert f"# the config of run {run}, resolved" in shown  # (an older config: a warning)
    config = json.loads((run / "run.json").read_text())["config"]
    assert f"seed = {config['seed']}" in shown and f'name = "{config["name"]}"' in shown


def _novelty(info: dict[str, Any], version: int = 1) -> dict[str, Any]:
    info["config"]["body"]["optimizer"] = "novelty"
    return {**info, "results_version": version}


def test_a_version_raise_refuses_only_the_runs_whose_records_it_changed(campaign: Path) -> None:
    """Version 2 changed what a novelty run's table holds, and nothing else: a version-1 GA run
    resumes under it (same records), a version-1 novelty run does not (two rules in one
    table), nor does a version-0 run of any optimizer; a brain-only run has no body optimizer."""
    from ariel.evolution import RESULTS_VERSION, results_version

    info = json.loads(next(campaign.glob("runs/*/*/run.json")).read_text())
    assert RESULTS_VERSION == 2 and info["config"]["body"]["optimizer"] == "ga"
    assert results_version(info) == 2
    assert results_version({**info, "results_version": 1}) == 2
    assert results_version({**info, "results_version": 0}) == 0
    assert results_version(_novelty(json.loads(json.dumps(info)))) == 1
    assert results_version(_novelty(json.loads(json.dumps(info)), 2)) == 2
    assert results_version({**_novelty(json.loads(json.dumps(info))), "brain_only": True}) == 2
    assert results_version({**info, "results_version": True}) is True  # no version: shown


@pytest.mark.parametrize(
    ("where", "expected"),
    [
        ("run.json", "a run.json of format 7, written by a newer ariel (this one reads format 1)"),
        ("checkpoint", "a checkpoint of format 7, written by a newer ariel (this one reads"),
        ("campaign.json", "a campaign.json of format 7, written by a newer ariel (this one"),
    ],
)
def test_a_folder_of_a_newer_ariel_says_so(
    campaign: Path, where: str, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A newer format read as damage ("not a run.json of format 1") with no word of upgrading."""
    run = next(campaign.glob("runs/*/*"))
    file = {
        "run.json": run / "run.json",
        "checkpoint": run / "checkpoints" / "state.json",
        "campaign.json": campaign / "campaign.json",
    }[where]
    if not file.exists():
        file.parent.mkdir(exist_ok=True)
        file.write_text(json.dumps({"format": 7}))
    edit_json(file, lambda data: data.update(format=7))
    command = ["campaign", "resume", str(campaign)] if where == "campaign.json" else ["resume"]
    assert exit_code(command if where == "campaign.json" else [*command, str(run)]) == 2
    line = one_error_line(capsys)
    assert expected in line and line.endswith("upgrade ariel to open it")


def test_a_resume_with_other_software_says_so_where_it_resumes(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run made with another MuJoCo went on without a word; and a note of other software
    came before the refusal of a run that is not resumed at all (two lines for one)."""
    from ariel.cli._run import _note_software_change

    run = next(campaign.glob("runs/*/*"))
    edit_json(run / "run.json", lambda i: i["segments"][-1]["versions"].update(mujoco="3.0.0"))
    _note_software_change(str(run))
    assert "(mujoco 3.0.0 -> " in capsys.readouterr().err
    edit_json(run / "run.json", lambda info: info.update(results_version=0))
    _note_software_change(str(run))
    assert capsys.readouterr().err == ""  # the resume's refusal is the one line


def test_the_refusal_names_the_maker_cleanly_and_a_newer_version_says_upgrade(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The maker's date lost its last digit inside a stray quote ("made '2026-11-2"), a commit
    its -dirty; a run of a newer results version was told to go back (probe R9)."""
    run = next(campaign.glob("runs/*/*"))
    created = json.loads((run / "run.json").read_text())["created"][:10]
    edit_json(run / "run.json", lambda info: info.update(results_version=0, git_commit=None))
    assert exit_code(["resume", str(run), "--quiet"]) == 2
    assert f"(made {created}; run.json names no git commit)" in one_error_line(capsys)
    edit_json(run / "run.json", lambda info: info.update(git_commit="0123abc-dirty"))
    assert exit_code(["resume", str(run), "--quiet"]) == 2
    assert "(commit 0123abc-dirty, run.json's git_commit)" in one_error_line(capsys)
    edit_json(run / "run.json", lambda info: info.update(results_version=3))
    assert exit_code(["resume", str(run), "--quiet"]) == 2
    assert one_error_line(capsys).endswith(
        "was made by a newer ariel (results version 3; this ariel's: 2): upgrade ariel to resume it"
    )
    edit_json(run / "run.json", lambda info: info.update(results_version=2, format=True))
    assert exit_code(["resume", str(run), "--quiet"]) == 2  # true is no format 1
    assert "not a run.json of format 1" in one_error_line(capsys)


def test_config_show_of_a_run_whose_config_was_edited_warns(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Edited after the run began (verify: hash mismatch), the config was printed as "the config
    of run ..." without a word, to be pasted as the run's (probe R9)."""
    run = next(campaign.glob("runs/*/*"))
    assert exit_code(["config", "show", str(run)]) == 0
    assert "warning" not in capsys.readouterr().err
    edit_json(run / "run.json", lambda info: info["config"].update(seed=7))
    assert exit_code(["config", "show", str(run)]) == 0
    out, err = capsys.readouterr()
    assert err.startswith("warning: run.json's config does not match its config_hash")
    assert out.startswith("# warning: run.json's config") and "seed = 7" in out
    edit_json(run / "run.json", lambda info: info["config"]["body"].update(population="x"))
    assert exit_code(["config", "show", str(run)]) == 2
    assert f"{run / 'run.json'}: body.population" in one_error_line(capsys)
