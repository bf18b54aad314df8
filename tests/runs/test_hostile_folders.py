"""Folders crafted to hurt (a hostile probe): each is refused or reported in one line, never a
traceback, and never holds up what is sound beside it.

1. JSON nested 100,000 deep in run.json, a manifest, the checkpoint or campaign.json;
2. condition (and campaign) names too long for a folder name;
3. campaign.json run entries without what resume needs;
4. rich markup and terminal control sequences in what `ariel campaign status` shows;
5. one damaged run of a campaign: `ariel campaign resume` resumes the others;
6. run.json's ``"manifests": 1`` flipped to 0 (run.json is in no manifest): verification is not
   switched off; what never changes in run.json is checked.

Run folders are made by hand here (tables of a few bytes, their manifests written by
`write_manifest`); the campaign is made with an executor that stops at once, as in
test_folder_trust.py. Only item 5 evaluates (the tiny campaign's runs, a few seconds).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import REPO, edit_json, exit_code, one_error_line, snapshot, tiny_run_toml

from ariel.evolution import ConfigError, ExperimentConfig
from ariel.evolution._config import config_hash
from ariel.recording import DamagedRunError, NotARunError, load_campaign, load_run, verify_run
from ariel.recording.store._campaign import NotACampaignError
from ariel.recording.store._lock import in_use_error
from ariel.recording.store._manifest import write_manifest
from ariel.recording.store._run_folder import MAX_JSON_BYTES, MAX_JSON_DEPTH, RunFolder, json_data
from ariel.recording.store._tables import body_schema, evaluation_schema, write_table
from ariel.recording.store._verify import MAX_LISTED
from ariel.runs import resume_campaign
from ariel.runs._campaign_file import MAX_CONDITION_NAME, load_campaign_file

TINY = REPO / "tests" / "data" / "campaign_tiny.toml"
DEEP = "[" * 100_000 + "]" * 100_000


def _run(folder: Path, *, generations: int = 2, run_id: str = "hostile-s3") -> Path:
    """A finished run folder made by hand: run.json as `ariel run` writes it (a real config and
    its hash), ``generations`` generations of evaluations and bodies tables (one row each), their
    manifests, and a checkpoint."""
    config = ExperimentConfig.from_plain({"name": "hostile", "seed": 3})
    digest = config_hash(config)
    for generation in range(generations):
        for table in ("evaluations", "bodies"):
            write_table(folder, table, generation, _one_row(table, run_id, generation))
        write_manifest(folder, generation)
    RunFolder(folder).write_info(
        {
            "format": 1,
            "run_id": run_id,
            "name": "hostile",
            "status": "finished",
            "seed": 3,
            "config": config.to_plain(),
            "config_hash": digest,
            "generations_done": generations,
            "evaluations_done": generations,
            "maximise": True,
            "brain_only": False,
            "manifests": 1,
            "segments": [{"kind": "run", "from_generation": 0}],
        }
    )
    RunFolder(folder).save_checkpoint({"config_hash": digest, "generation": generations - 1})
    return folder


def _one_row(table: str, run_id: str, generation: int) -> dict[str, list[object]]:
    """One row of ``table`` with every column (a run's file has them all): its ids and flags
    filled (a run never leaves them null), the rest null."""
    schema = evaluation_schema() if table == "evaluations" else body_schema()
    filled = {
        "run_id": run_id,
        "generation": generation,
        "body_id": "b000000",
        "eval_id": "b000000-i000-c000",
        "status": "ok",
        "is_new": True,
        "selected": True,
    }
    return {f.name: [filled.get(f.name)] for f in schema}


def _flip_a_bit(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x04
    path.write_bytes(bytes(data))


# --- 1: JSON nested 100,000 deep ----------------------------------------------------------------


def test_json_nested_deeper_than_any_reader_goes_is_a_value_error() -> None:
    nested = lambda depth: "[" * depth + "]" * depth  # noqa: E731
    assert json_data(nested(MAX_JSON_DEPTH)) == json.loads(nested(MAX_JSON_DEPTH))
    for text in (nested(MAX_JSON_DEPTH + 1), DEEP, '{"a": ' * 5000 + "1" + "}" * 5000):
        with pytest.raises(ValueError, match=f"^JSON nested more than {MAX_JSON_DEPTH} deep$"):
            json_data(text)
    assert json_data("3") == 3 and json_data(b'{"a": [1, {"b": []}]}') == {"a": [1, {"b": []}]}


def test_a_deep_run_json_is_one_line_and_runs_lists_the_others(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sound = _run(tmp_path / "a-sound")
    deep = _run(tmp_path / "b-deep", run_id="deep-s3")
    (deep / "run.json").write_text(DEEP)
    with pytest.raises(NotARunError, match=r"unreadable run\.json .*nested more than 100 deep"):
        load_run(deep)
    for command in (["verify"], ["report", "--no-render"], ["resume", "--quiet"]):
        assert exit_code([*command, str(deep)]) == 2, command
        assert "unreadable run.json" in one_error_line(capsys), command
    assert exit_code(["runs", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "hostile-s3" in out and "finished" in out  # the sound run is listed
    (line,) = [line for line in out.splitlines() if line.startswith("b-deep")]
    assert "unreadable" in line  # the damaged one is named
    assert len(load_run(sound).evaluations) == 2


def test_a_deep_manifest_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _run(tmp_path / "run")
    (run / "manifests" / "gen-000001.json").write_text(DEEP)
    expected = "manifests/gen-000001.json is unreadable (ValueError: JSON nested more than 100"
    with pytest.raises(DamagedRunError, match=expected.replace("(", r"\(")):
        load_run(run)
    assert exit_code(["verify", str(run)]) == 1
    assert f"damaged: {expected}" in capsys.readouterr().out


def test_a_deep_checkpoint_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _run(tmp_path / "run")
    edit_json(run / "run.json", lambda info: info.update(status="interrupted"))
    RunFolder(run).checkpoint.write_text(DEEP)
    with pytest.raises(NotARunError, match=r"unreadable checkpoint .*nested more than 100 deep"):
        RunFolder(run).load_checkpoint()
    before = snapshot(run)
    assert exit_code(["resume", str(run), "--quiet"]) == 2
    assert "unreadable checkpoint (ValueError: JSON nested" in one_error_line(capsys)
    assert snapshot(run) == before
    assert exit_code(["verify", str(run)]) == 1
    assert "damaged: checkpoints/state.json unreadable checkpoint" in capsys.readouterr().out


def test_a_deep_campaign_json_is_one_line(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (campaign / "campaign.json").write_text(DEEP)
    commands = (["campaign", "status"], ["campaign", "resume", "--quiet"], ["compare"], ["runs"])
    for command in commands:  # `runs` listed the runs of a campaign.json refused elsewhere
        assert exit_code([*command, str(campaign)]) == 2, command
        assert "unreadable campaign.json (JSON nested more than 100" in one_error_line(capsys)


# --- 2: names too long for a folder ---------------------------------------------------------------


def _campaign_file(tmp_path: Path, text: str) -> Path:
    file = tmp_path / "c.toml"
    file.write_text('base = { name = "t", generations = 1 }\nseeds = [1]\n' + text)
    return file


def test_a_condition_name_too_long_for_a_folder_is_refused_before_anything_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert MAX_CONDITION_NAME == 245  # condition=<name>: 255 bytes
    fits = _campaign_file(tmp_path, f'[[condition]]\nname = "{"a" * 245}"\n')
    assert [c.name for c in load_campaign_file(fits).conditions] == ["a" * 245]
    file = _campaign_file(tmp_path, f'[[condition]]\nname = "{"a" * 246}"\n')
    with pytest.raises(ConfigError, match=r"^condition\.0: name 'a{20}'\.\.\. has 246 characters"):
        load_campaign_file(file)
    out = tmp_path / "out"
    assert exit_code(["campaign", "run", str(file), "--out", str(out), "--quiet"]) == 2
    assert "at most 245 (its runs' folder is condition=<name>" in one_error_line(capsys)
    assert not out.exists()
    file = _campaign_file(tmp_path, f'name = "{"n" * 240}"\n')
    with pytest.raises(
        ConfigError, match=r"^name: name 'n{20}'\.\.\. has 240 characters; at most 239"
    ):
        load_campaign_file(file)


def test_grid_condition_names_are_cut_to_fit_and_stay_distinct(tmp_path: Path) -> None:
    long_a, long_b = "a" * 300 + "1", "a" * 300 + "2"  # the names differ past 245 characters
    file = _campaign_file(tmp_path, f'[grid]\ndescription = ["{long_a}", "{long_b}", "short"]\n')
    names = [c.name for c in load_campaign_file(file).conditions]
    assert [len(name) for name in names] == [245, 245, len("description-short")]
    assert len(set(names)) == 3 and names[0].startswith("description-aaaa")
    assert names[2] == "description-short"  # a name that fits is kept as it is
    named = _campaign_file(
        tmp_path,
        f'[[condition]]\nname = "{"c" * 200}"\n[grid]\ndescription = ["{"d" * 50}", "e"]\n',
    )
    names = [c.name for c in load_campaign_file(named).conditions]
    assert [len(name) for name in names] == [245, 200 + len("_description-e")]


def test_a_campaign_json_condition_too_long_for_a_folder_is_refused(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def rename(info: dict[str, Any]) -> None:
        info["runs"][0]["condition"] = "c" * 246
        info["runs"][0]["path"] = f"runs/condition={'c' * 246}/seed=1"

    edit_json(campaign / "campaign.json", rename)
    before = snapshot(campaign)
    assert exit_code(["campaign", "resume", str(campaign), "--quiet"]) == 2
    assert "is not a condition name (letters, digits, _ . -; at most 245" in one_error_line(capsys)
    assert snapshot(campaign) == before


# --- 3: campaign.json run entries without what resume needs -----------------------------------


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda info: info.pop("runs"), "lists no runs (its 'runs' is None)"),
        (lambda info: info.update(runs=[]), "lists no runs (its 'runs' is [])"),
        (
            lambda info: info["runs"][0].pop("config"),
            "runs[0] (condition fresh, seed 1): its config",
        ),
        (
            lambda info: info["runs"][1].update(config=[]),
            "runs[1] (condition fresh, seed 2): its con",
        ),
        (
            lambda info: info["runs"][2].pop("run_id"),
            "runs[2] (condition inherit, seed 1): its run_id",
        ),
        (lambda info: info.pop("campaign_id"), "its campaign_id None is not a campaign id"),
    ],
)
def test_a_campaign_json_run_entry_without_what_resume_needs_is_one_line(
    campaign: Path, change: Any, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(campaign / "campaign.json", change)
    before = snapshot(campaign)
    for command in (["campaign", "resume", "--quiet"], ["campaign", "status"]):
        assert exit_code([*command, str(campaign)]) == 2, command
        assert expected in one_error_line(capsys), command
    with pytest.raises(NotACampaignError):
        resume_campaign(campaign)
    assert snapshot(campaign) == before


def test_a_first_run_config_that_does_not_validate_names_the_entry(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(campaign / "campaign.json", lambda info: info["runs"][0]["config"].update(surprise=1))
    assert exit_code(["campaign", "resume", str(campaign), "--quiet"]) == 2
    assert "campaign.json: runs[0]: its config: " in one_error_line(capsys)


# --- 4: what campaign status shows is text -------------------------------------------------------


def test_campaign_status_shows_markup_and_control_sequences_as_text(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    hostile = "[/bold]\x1b[2J\x1b]0;pwned\x07[red]x"
    edit_json(
        campaign / "runs/condition=fresh/seed=1/run.json", lambda info: info.update(status=hostile)
    )
    edit_json(
        campaign / "campaign.json",
        lambda info: info["runs"][1]["config"].update(generations=hostile),
    )
    moved = Path(shutil.move(campaign, tmp_path / "[/bold]camp"))
    assert exit_code(["campaign", "status", str(moved)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert out.count("[/bold]\\x1b[2J\\x1b]0;pwn") == 2  # status, generations: cut to fit
    assert "[/bold]camp" in out  # the title: the folder as given


# --- 5: one damaged run does not hold up the others --------------------------------------------


def test_campaign_resume_resumes_the_others_and_names_the_damaged_run(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    damaged = campaign / "runs/condition=fresh/seed=1"
    RunFolder(damaged).checkpoint.parent.mkdir(exist_ok=True)
    RunFolder(damaged).checkpoint.write_text(DEEP)
    before = snapshot(damaged)
    assert exit_code(["campaign", "resume", str(campaign), "--quiet"]) == 1
    captured = capsys.readouterr()
    assert "3 of 3 runs finished" in captured.out
    (line,) = captured.err.splitlines()
    assert line.startswith("ariel: error: condition fresh seed 1 not resumed: ")
    assert "unreadable checkpoint (ValueError: JSON nested more than 100 deep)" in line
    assert snapshot(damaged) == before  # left alone
    rows = {(r["condition"], r["seed"]): r["status"] for r in load_campaign(campaign).status()}
    assert rows == {
        ("fresh", 1): "failed",
        ("fresh", 2): "finished",
        ("inherit", 1): "finished",
        ("inherit", 2): "finished",
    }
    # Nothing left but the damaged run: one line, exit 2, nothing written.
    before = snapshot(campaign)
    assert exit_code(["campaign", "resume", str(campaign), "--quiet"]) == 2
    line = one_error_line(capsys, quiet=True)
    assert "no run resumed: condition fresh seed 1 not resumed: " in line
    assert snapshot(campaign) == before


def test_campaign_status_names_a_run_that_does_not_load(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (campaign / "runs/condition=inherit/seed=2/run.json").write_text(DEEP)
    rows = {(r["condition"], r["seed"]): r["status"] for r in load_campaign(campaign).status()}
    assert rows[("inherit", 2)] == "damaged" and rows[("fresh", 1)] == "failed"
    edit_json(
        campaign / "runs/condition=fresh/seed=1/run.json",
        lambda info: info.update(generations_done="x", evaluations_done=[1]),
    )
    assert exit_code(["campaign", "status", str(campaign)]) == 0
    assert "damaged" in capsys.readouterr().out
    # The campaign's gallery named nothing it left out.
    from ariel.recording.analysis._gallery import _campaign_gallery

    notes = _campaign_gallery(campaign)[0].notes
    assert any(note.startswith("condition inherit seed 2: left out (") for note in notes)
    # A folder with tables but no run.json was "not started", left out of compare unnamed.
    (campaign / "runs/condition=inherit/seed=1/run.json").unlink()
    loaded = load_campaign(campaign)
    assert loaded.status()[2]["status"] == "not started"  # nothing of it there: none made
    (campaign / "runs/condition=inherit/seed=1/checkpoints").mkdir(exist_ok=True)
    (campaign / "runs/condition=inherit/seed=1/evaluations").mkdir(exist_ok=True)
    loaded = load_campaign(campaign)
    rows = {(r["condition"], r["seed"]): r["status"] for r in loaded.status()}
    assert rows[("inherit", 1)] == "damaged"
    assert "holds tables but no run.json" in loaded.damaged[("inherit", 1)]


def test_compare_names_a_damaged_run_of_a_campaign_instead_of_leaving_it_out(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (campaign / "runs/condition=fresh/seed=1/run.json").write_text("[[[")
    assert "('fresh', 1)" in repr(load_campaign(campaign).damaged)
    assert exit_code(["compare", str(campaign)]) == 2
    line = one_error_line(capsys, quiet=True)
    assert "run 'fresh' seed 1 of campaign" in line and "unreadable run.json" in line, line
    (campaign / "runs/condition=fresh/seed=1/run.json").unlink()  # not made yet: no damage
    assert load_campaign(campaign).damaged == {}


def test_a_campaign_json_seeding_no_campaign_writes_is_one_line(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(campaign / "campaign.json", lambda info: info.update(seeding="<junk>"))
    assert exit_code(["compare", str(campaign)]) == 2
    assert "seeding '<junk>' is not one of shared, independent" in one_error_line(capsys)


# --- 6: run.json's "manifests" does not switch verification off ---------------------------------


def test_a_flipped_manifests_flag_does_not_switch_verification_off(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run")
    text = (run / "run.json").read_text()
    assert text.count('"manifests": 1') == 1
    (run / "run.json").write_text(text.replace('"manifests": 1', '"manifests": 0'))  # one bit
    _flip_a_bit(run / "bodies" / "gen-000001.parquet")  # still the same size
    assert exit_code(["verify", str(run)]) == 1
    out = capsys.readouterr().out
    assert "damaged: run.json has 'manifests': 0, a value no ariel writes" in out
    assert "damaged: bodies/gen-000001.parquet has other bytes than when it was written" in out
    assert out.splitlines()[-1].startswith("2 damaged file(s): ")
    with pytest.raises(DamagedRunError, match=r"run\.json has 'manifests': 0"):
        load_run(run)
    for value in ('"no"', "2", "true"):  # truthy, but not what a run writes either
        (run / "run.json").write_text(text.replace('"manifests": 1', f'"manifests": {value}'))
        with pytest.raises(DamagedRunError, match=rf"run\.json has 'manifests': {value}, a"):
            load_run(run)


#: The keys of run.json that came with manifests (``results_version`` came later; ``plugins`` was
#: there before them).
_WITH_MANIFESTS = ("segments", "maximise", "brain_only")


def test_a_missing_manifests_flag_with_keys_that_came_with_manifests_is_damage(
    tmp_path: Path,
) -> None:
    run = _run(tmp_path / "run")
    edit_json(run / "run.json", lambda info: info.pop("manifests"))
    shutil.rmtree(run / "manifests")
    result = verify_run(run)
    assert result.checked
    assert result.problems[0].startswith("run.json has no 'manifests' but has 'segments'")
    assert "manifests/gen-000000.json is missing (generation 0 is finished)" in result.problems[1]
    with pytest.raises(DamagedRunError, match=r"run\.json has no 'manifests' but has 'segments'"):
        load_run(run)
    # The keys that came later than manifests count too (the three above deleted as well,
    # verification was off and a changed table loaded).
    edit_json(run / "run.json", lambda info: info.update(results_version=1))  # as a run's
    edit_json(run / "run.json", lambda info: [info.pop(k) for k in _WITH_MANIFESTS])
    with pytest.raises(DamagedRunError, match=r"has no 'manifests' but has 'results_version'"):
        load_run(run)


def test_a_run_made_before_manifests_is_checked_against_a_manifest_it_has(
    tmp_path: Path,
) -> None:
    """An old run (no flag, no keys that came with manifests) whose resume was killed while it
    wrote the manifests: what it wrote is checked; the rest as before manifests, not damage."""
    run = _run(tmp_path / "run")
    old_keys = ("manifests", "segments", "maximise", "brain_only")
    edit_json(run / "run.json", lambda info: [info.pop(k) for k in old_keys])
    (run / "manifests" / "gen-000001.json").unlink()
    result = verify_run(run)
    assert result.ok and not result.checked and result.files == 4
    assert result.manifested == 1  # said so, not "presence and readability ... only"
    _flip_a_bit(run / "evaluations" / "gen-000000.parquet")
    assert verify_run(run).problems == [
        "evaluations/gen-000000.parquet has other bytes than when it was written (SHA-256)"
    ]


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            lambda info: info["config"]["brain"].update(popsize=99),
            "run.json has a config_hash that is not its config's (SHA-256)",
        ),
        (
            lambda info: info.update(config_hash="0" * 64),
            "run.json has a config_hash that is not its config",
        ),
        (lambda info: info.update(seed=4), "run.json has seed 4, its config 3"),
        (
            lambda info: info.update(run_id="other-s3"),
            "evaluations/gen-000000.parquet has run_id 'hostile-s3' in its rows, run.json "
            "'other-s3'",
        ),
        (lambda info: info.update(config="x"), "run.json has no config (its 'config' is 'x')"),
        (lambda info: info.update(maximise="yes"), "run.json has maximise 'yes', not true or"),
        (
            lambda info: info.update(maximise=not info["maximise"]),
            "run.json has maximise false, but its fitness function 'xy_displacement' "
            "(installed here) says higher is better",
        ),
    ],
)
def test_verify_checks_what_never_changes_in_run_json(
    tmp_path: Path, change: Any, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run")
    assert verify_run(run).ok and verify_run(run).run_id_checked
    edit_json(run / "run.json", change)
    assert exit_code(["verify", str(run)]) == 1
    assert f"damaged: {expected}" in capsys.readouterr().out


@pytest.mark.parametrize("config", [None, "x", [1, 2]], ids=["missing", "text", "list"])
def test_load_run_refuses_a_run_json_without_its_config(tmp_path: Path, config: object) -> None:
    """Without its config, load_run loaded every table with the row-limit check off, which
    records.md says a crafted run.json cannot do; verify and report refused (probe G2)."""
    run = _run(tmp_path / "run")
    edit_json(
        run / "run.json",
        lambda info: info.pop("config") if config is None else info.update(config=config),
    )
    with pytest.raises(DamagedRunError, match=r"is damaged: run.json has no config \(its 'config'"):
        load_run(run)


def test_verify_checks_the_checkpoint_s_config_hash_and_notes_a_config_it_cannot_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run")
    RunFolder(run).save_checkpoint({"config_hash": "0" * 64})
    assert verify_run(run).problems == [
        "checkpoints/state.json has a config_hash that is not run.json's"
    ]
    run = _run(tmp_path / "newer")
    edit_json(run / "run.json", lambda info: info["config"].update(added_later=1))
    assert exit_code(["verify", str(run)]) == 0  # a newer ariel's config: not damage
    out = capsys.readouterr().out
    assert "note: run.json's config is not one this ariel reads (" in out
    assert out.splitlines()[-1].startswith("ok: ")


# --- 7: run.json's generations_done is checked, and so is every manifest there is ---------------


@pytest.mark.parametrize("done", [-1, None, "2", 2.5, True, 11, 100_000, 10**30])
def test_a_generations_done_no_run_writes_is_damage_in_one_line(
    tmp_path: Path, done: object, capsys: pytest.CaptureFixture[str]
) -> None:
    """It was trusted: 0, -1, null, "2" or 2.5 verified a damaged run "ok: 0 finished
    generation(s)", 100,000 printed 99,999 lines, 10**30 ran for ever."""
    run = _run(tmp_path / "run")  # 2 generations of a config of 10
    _flip_a_bit(run / "bodies" / "gen-000001.parquet")
    edit_json(run / "run.json", lambda info: info.update(generations_done=done))
    expected = f"run.json has generations_done {done!a}, not a whole number from 0 to 10"
    with pytest.raises(DamagedRunError, match=re.escape(expected)):
        load_run(run)
    assert exit_code(["verify", str(run)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[:2] == [
        f"damaged: {expected} (its config's generations)",
        "damaged: bodies/gen-000001.parquet has other bytes than when it was written (SHA-256)",
    ]  # every manifest there is is checked
    assert len(lines) == 3 and lines[-1].startswith("2 damaged file(s): ")


def test_a_finished_run_s_later_generations_and_unlisted_tables_are_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run")
    edit_json(run / "run.json", lambda info: info.update(generations_done=0))
    with pytest.raises(DamagedRunError, match=r"manifests/gen-000000\.json is of a generation aft"):
        load_run(run)  # it read as a run of no generation
    assert verify_run(run).problems == [
        "manifests/gen-000000.json is of a generation after the run's 0 finished one(s) "
        "(run.json's generations_done; the run is finished); 1 more such file(s)"
    ]
    edit_json(run / "run.json", lambda info: info.update(generations_done=2))
    generation_2 = pa.table({"run_id": ["hostile-s3"], "generation": [2]})
    pq.write_table(generation_2, run / "bodies" / "gen-000002.parquet")
    (run / "archive").mkdir()
    shutil.copy(run / "bodies" / "gen-000001.parquet", run / "archive" / "gen-000001.parquet")
    assert verify_run(run).problems == [
        "bodies/gen-000002.parquet is of a generation after the run's 2 finished one(s) "
        "(run.json's generations_done; the run is finished)",
        "archive/gen-000001.parquet is in no manifest (its generation's manifest does not list it)",
    ]
    # An unfinished run: generation 2 was being written when it stopped (resume discards it).
    (run / "archive" / "gen-000001.parquet").unlink()
    edit_json(run / "run.json", lambda info: info.update(status="interrupted"))
    pq.write_table(generation_2, run / "evaluations" / "gen-000002.parquet")
    write_manifest(run, 2)
    assert verify_run(run).ok


def test_a_running_run_s_generations_in_flight_are_no_damage(tmp_path: Path) -> None:
    """`ariel verify` while a run writes: run.json (updated last) lags the tables and manifests
    of the next generations, which were called damage ("the run is finished") before."""
    from ariel.recording import RunLock

    run = _run(tmp_path / "run", generations=4)
    edit_json(run / "run.json", lambda info: info.update(status="running", generations_done=2))
    with RunLock(run):
        result = verify_run(run)
    assert result.ok and result.generations == 2
    assert result.notes == [
        f"the run is running (pid {os.getpid()} on host {os.uname().nodename}): its generations "
        "from generation 2 on are being written and were not checked; verify it again when it "
        "has stopped"
    ]
    # No process runs it: the generations after the one in flight are strays again.
    assert verify_run(run).problems == [
        "manifests/gen-000003.json is of a generation after the run's 2 finished one(s) "
        "(run.json's generations_done; only generation 2 was in flight)"
    ]


def _generations(run: Path, total: int) -> Path:
    """``run`` with a config of ``total`` generations, its hash recomputed (as the probe did)."""

    def change(info: dict[str, Any]) -> None:
        info["config"]["generations"] = total
        info["config_hash"] = config_hash(ExperimentConfig.from_plain(info["config"]))

    edit_json(run / "run.json", change)
    digest = json.loads((run / "run.json").read_text())["config_hash"]
    RunFolder(run).save_checkpoint({"config_hash": digest})
    return run


def test_a_huge_generations_done_is_one_line_for_the_missing_manifests(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A config of 10**6 generations (its hash recomputed) makes 10**6 a count run.json may
    hold: still one line, and load_run stops at the first missing manifest."""
    run = _generations(_run(tmp_path / "run"), 10**6)
    edit_json(run / "run.json", lambda info: info.update(generations_done=10**6))
    assert exit_code(["verify", str(run)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (
        "damaged: manifests/gen-000002.json is missing (generation 2 is finished); "
        "999,997 more finished generation(s) have no manifest either"
    )
    assert len(lines) == 2
    with pytest.raises(DamagedRunError, match=r"manifests/gen-000002\.json is missing"):
        load_run(run)


def test_verify_lists_a_bounded_number_of_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _generations(_run(tmp_path / "run", generations=MAX_LISTED + 10), 100)
    for path in (run / "bodies").iterdir():
        _flip_a_bit(path)
    result = verify_run(run)
    assert len(result.problems) == MAX_LISTED and result.unlisted == 10
    assert exit_code(["verify", str(run)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[-2] == "damaged: ... and 10 more problem(s), not listed"
    assert lines[-1].startswith(f"{MAX_LISTED + 10} damaged file(s): ")


# --- 8: a folder's JSON files are regular files of a bounded size --------------------------------


@pytest.fixture
def no_hang() -> Iterator[None]:
    """Fail, rather than hang, where a FIFO blocks a reader."""

    def hung(*_: object) -> None:
        raise TimeoutError("blocked on a FIFO")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def _fifo(path: Path) -> None:
    path.unlink()
    os.mkfifo(path)


def _sparse(path: Path, size: int = MAX_JSON_BYTES + 1) -> None:
    with open(path, "r+b") as file:
        file.truncate(size)  # sparse: nothing written, nothing read


def _padded(path: Path) -> None:
    """run.json with 2 million ``{}``: 4 MB that would take about 300 MB to parse."""
    edit_json(path, lambda info: info.update(pad=[{}] * 2_000_000))


@pytest.mark.usefixtures("no_hang")
@pytest.mark.parametrize(
    ("make", "expected"),
    [
        (_fifo, "a FIFO, not a regular file"),
        (
            lambda p: (p.unlink(), p.symlink_to("/dev/zero")),
            "a symbolic link out of the run folder",  # not opened at all
        ),
        (_sparse, "67,108,865 bytes, more than the 64 MiB such a file may have"),
        (_padded, "2,000,0"),  # and a few more: run.json's own objects
    ],
)
def test_a_run_json_that_is_no_regular_file_or_too_large_is_one_line(
    tmp_path: Path, make: Any, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    sound = _run(tmp_path / "a-sound")
    bad = _run(tmp_path / "b-bad", run_id="bad-s3")
    make(bad / "run.json")
    for command in (["verify"], ["report", "--no-render"]):
        assert exit_code([*command, str(bad)]) == 2, command
        assert f"unreadable run.json ({expected}" in one_error_line(capsys), command
    assert exit_code(["runs", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "hostile-s3" in out and re.search(r"b-bad +unreadable +\? +\? +-", out)
    assert len(load_run(sound).evaluations) == 2


@pytest.mark.usefixtures("no_hang")
def test_a_manifest_checkpoint_or_campaign_json_that_is_a_fifo_is_one_line(
    tmp_path: Path, campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run")
    _fifo(run / "manifests" / "gen-000001.json")
    _fifo(RunFolder(run).checkpoint)
    assert exit_code(["verify", str(run)]) == 1
    out = capsys.readouterr().out
    assert (
        "damaged: manifests/gen-000001.json is unreadable (ValueError: a FIFO, not a regular file)"
        in out
    )
    assert "damaged: checkpoints/state.json unreadable checkpoint (ValueError: a FIFO, not a" in out
    _fifo(campaign / "campaign.json")
    commands = (["campaign", "status"], ["campaign", "resume", "--quiet"], ["compare"], ["runs"])
    for command in commands:  # `runs` listed the runs of a campaign.json refused elsewhere
        assert exit_code([*command, str(campaign)]) == 2, command
        assert "unreadable campaign.json (a FIFO, not a regular file)" in one_error_line(capsys)


def test_a_checkpoint_that_is_a_folder_is_not_taken_for_none(tmp_path: Path) -> None:
    """Before, anything but a file read as "no generation finished": resume restarted the
    run, discarding its generations."""
    run = _run(tmp_path / "run")
    RunFolder(run).checkpoint.unlink()
    RunFolder(run).checkpoint.mkdir()
    with pytest.raises(
        NotARunError, match=r"unreadable checkpoint \(ValueError: a folder, not a regular file\)"
    ):
        RunFolder(run).load_checkpoint()


# --- 9: ids are checked where run.json is read ---------------------------------------------------


HOSTILE_ID = 'x\x1b[2J\x1b]0;pwned\x07\n"""import os'


def test_a_crafted_run_id_is_refused_where_run_json_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run", run_id=HOSTILE_ID)
    for command in (["report", str(run)], ["replay", str(run), "best"]):
        assert exit_code(command) == 2, command
        assert f"holds a run id that is not one: {HOSTILE_ID!r}"[:60] in one_error_line(capsys)
    # verify: damage found (exit 1, as for any other changed file), not "no run folder" (2)
    assert exit_code(["verify", str(run)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("damaged: run.json: ") and "\x1b" not in lines[0]
    refused = "run.json refused, no table read (they are found through it)"
    assert lines[-1] == f"1 damaged file(s): {run}: {refused}"
    with pytest.raises(DamagedRunError, match="holds a run id that is not one"):
        load_run(run)


def test_a_table_s_run_id_must_be_run_json_s(tmp_path: Path) -> None:
    run = _run(tmp_path / "run")
    for generation in range(2):  # the tables say another run, their manifests rewritten
        rows = pa.table({"run_id": ["../../x"], "generation": [generation]})
        pq.write_table(rows, run / "evaluations" / f"gen-{generation:06d}.parquet")
        write_manifest(run, generation)
    with pytest.raises(DamagedRunError, match=r"evaluations/gen-000000\.parquet has run_id '\.\./"):
        load_run(run).evaluations  # noqa: B018
    line = "has run_id '../../x' in its rows, run.json 'hostile-s3': changed by hand or crafted"
    assert any(line in problem for problem in verify_run(run).problems)


@pytest.mark.parametrize(
    ("table", "column", "value", "said"),
    [
        ("evaluations", "eval_id", "b000003-i000-c001+x", "has eval_id 'b000003-i000-c001+x', not"),
        ("bodies", "best_eval_id", "../x", "has best_eval_id '../x', not an id"),
        ("bodies", "body_id", "b1", "has body_id 'b1', not an id"),
        ("bodies", "status", "=HYPERLINK(1)", "has status '=HYPERLINK(1)', not one a run writes"),
        ("bodies", "parent_ids", ["b000001", "=1+1"], "has parent_ids '=1+1', not a body id"),
    ],
)
def test_a_table_s_ids_and_statuses_must_be_what_a_run_writes(
    tmp_path: Path, table: str, column: str, value: str, said: str
) -> None:
    """A crafted id (manifest rewritten) passed verify and load: report printed it, the
    lineage CSV carried a formula; only export, replay and view refused it, one by one."""
    run = _run(tmp_path / "run")
    rows = pa.table({"run_id": ["hostile-s3"], "generation": [1], column: [value]})
    pq.write_table(rows, run / table / "gen-000001.parquet")
    write_manifest(run, 1)
    with pytest.raises(DamagedRunError, match=re.escape(said)):
        getattr(load_run(run), table)
    assert any(said in problem for problem in verify_run(run).problems)


def test_a_table_s_generation_column_must_be_its_file_s(tmp_path: Path) -> None:
    """Before, rows claiming generation 5 in gen-000000.parquet passed verify and load, and the
    report said the run kept no trajectories (it looked for them in gen-000005)."""
    run = _run(tmp_path / "run")
    rows = pa.table({"run_id": ["hostile-s3"], "generation": [5]})
    pq.write_table(rows, run / "bodies" / "gen-000001.parquet")
    write_manifest(run, 1)
    with pytest.raises(DamagedRunError, match=r"bodies/gen-000001\.parquet has generation 5 in"):
        load_run(run).bodies  # noqa: B018
    assert verify_run(run).problems == [
        "bodies/gen-000001.parquet has generation 5 in its rows, its name 1: changed by hand or "
        "crafted, not loaded"
    ]


# --- 10: names shown on the terminal; the output folder ------------------------------------------


def test_verify_and_runs_show_a_folder_name_as_text(
    tmp_path: Path, campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "r\x1b[2J\x1b]0;t\x07")
    assert exit_code(["verify", str(run)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "r\\x1b[2J\\x1b]0;t\\x07: " in out
    RunFolder(campaign / "runs/condition=fresh/seed=1").update_info(status="finished")
    assert exit_code(["runs", str(campaign)]) == 0  # a campaign: its runs
    out = capsys.readouterr().out
    assert "no runs under" not in out
    assert len([line for line in out.splitlines() if "condition=fresh/seed=1 " in line]) == 1
    assert len(out.splitlines()) == 5  # the heading and 4 runs


def test_an_output_that_is_a_dangling_link_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    link = tmp_path / "dangl"
    link.symlink_to(tmp_path / "missing")
    with pytest.raises(FileExistsError, match="is a symbolic link to a missing target"):
        RunFolder.check_new(link, overwrite=False)
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("dangl", 1))
    assert exit_code(["run", str(config), "--out", str(link), "--quiet"]) == 2
    assert "is a symbolic link to a missing target" in one_error_line(capsys)
    assert not (tmp_path / "missing").exists() and link.is_symlink()


def test_an_output_that_links_to_a_run_is_never_replaced_through_the_link(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ariel run --out LINK --overwrite` emptied the run LINK led to, then refused."""
    victim = tmp_path / "victim"
    (victim / "evaluations").mkdir(parents=True)
    (victim / "run.json").write_text('{"format": 1}')
    (victim / "evaluations" / "gen-000000.parquet").write_bytes(b"a finished generation")
    link = tmp_path / "alias"
    link.symlink_to("victim")
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("alias", 1))
    before = sorted(str(p) for p in victim.rglob("*"))
    for overwrite in (["--overwrite"], []):
        assert exit_code(["run", str(config), "--out", str(link), "--quiet", *overwrite]) == 2
        assert "is a symbolic link to a folder ('victim')" in one_error_line(capsys)
        assert sorted(str(p) for p in victim.rglob("*")) == before
    assert (victim / "run.json").read_text() == '{"format": 1}'


def test_a_campaign_folder_in_use_is_called_a_campaign_folder(campaign: Path) -> None:
    assert "campaign folder " in str(in_use_error(campaign, "pid 1 on host h"))
    assert str(in_use_error(campaign / "runs", "x")).startswith("run folder ")


def test_a_leading_tilde_is_the_home_folder_for_every_file_of_a_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """pyarrow and pandas expand a leading "~" and ariel did not: run.json went to ./~/r, the
    tables to $HOME/r. Now every path a command is given is expanded as a shell would."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(tmp_path)
    run = REPO / "tests" / "data" / "run_tiny.toml"
    assert exit_code(["run", str(run), "--out", "~/r", "--quiet", "--set", "generations=1"]) == 0
    assert exit_code(["verify", "~/r"]) == 0
    assert exit_code(["report", "~/r", "--no-render"]) == 0
    assert (home / "r" / "evaluations" / "gen-000000.parquet").stat().st_size > 0
    assert (home / "r" / "run.json").is_file() and (home / "r" / "report" / "fitness.png").is_file()
    # Every command: `runs "~"` said "'~' does not exist", export wrote into ./~/
    assert exit_code(["runs", "~"]) == 0
    assert exit_code(["export", "~/r", "--lineage", "~/lineage.csv"]) == 0
    assert (home / "lineage.csv").is_file()
    shutil.copy(run, home / "tiny.toml")
    assert exit_code(["config", "show", "~/tiny.toml"]) == 0
    from ariel.cli._view import _png_path  # checked as --screenshot is parsed

    assert _png_path("~/shot.png") == home / "shot.png"
    # ~user of no such user: left as it is, as a shell leaves it (a traceback before)
    assert exit_code(["config", "show", "~nosuchuser0/x.toml"]) == 2
    assert not (tmp_path / "~").exists()


@pytest.mark.parametrize("linked", ["evaluations", "manifests", "checkpoints", "run.json"])
def test_a_folder_or_run_json_linked_out_of_the_run_is_not_read(
    tmp_path: Path, linked: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A link on a table file was refused, one on its folder followed: verify said ok and
    report drew another run's tables."""
    elsewhere = _run(tmp_path / "elsewhere")
    run = _run(tmp_path / "run")
    target = run / linked
    shutil.rmtree(target) if target.is_dir() else target.unlink()
    target.symlink_to(elsewhere / linked)
    assert exit_code(["verify", str(run)]) != 0
    said = capsys.readouterr()
    assert "symbolic link" in said.out + said.err
    if linked != "checkpoints":  # report reads no checkpoint (resume does: refused as well)
        assert exit_code(["report", str(run), "--no-render"]) == 2
        assert "a symbolic link" in one_error_line(capsys)
    else:
        with pytest.raises(NotARunError, match="a symbolic link out of the run folder"):
            RunFolder(run).load_checkpoint()


def test_a_campaign_json_condition_listed_twice_is_one_line(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(
        campaign / "campaign.json", lambda info: info["conditions"].append(info["conditions"][0])
    )
    assert exit_code(["campaign", "status", str(campaign)]) == 2
    assert "is listed twice" in one_error_line(capsys)


def test_verify_of_a_finished_run_being_replaced_says_it_is_in_use(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """During `ariel run --overwrite` of a finished run, verify read its files as they were
    deleted: "gen-000007.parquet is missing", a damaged run that was none (probe G1)."""
    from ariel.recording.store import RunInUseError, RunLock

    run = _run(tmp_path / "run")
    with RunLock(run):
        with pytest.raises(RunInUseError):
            verify_run(run)
        assert exit_code(["verify", str(run)]) == 2
        assert "is in use by pid" in one_error_line(capsys)
    assert verify_run(run).ok
