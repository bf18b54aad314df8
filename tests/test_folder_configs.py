"""A run folder is data: run.json's config and the rows of its tables, changed by hand or
crafted, are refused by replay, export, report and gallery in one line (exit code 2) where they
rebuild a body or a brain from them, and nothing they print reaches the terminal as a control
sequence.

One tiny run for the module; every test changes a copy of it.
"""

from __future__ import annotations

import io
import json
import re
import shutil
import subprocess
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import ariel_run, exit_code, one_error_line, tiny_run_toml
from rich.console import Console

from ariel.evolution import ExperimentConfig
from ariel.evolution._config import config_hash
from ariel.recording import load_run, make_report, resim
from ariel.recording.analysis._report import print_report
from ariel.recording.store._manifest import write_manifest

ESC = "x\x1b[2J\x1b]0;pwned\x07"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("configs")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("configs", 3, generations=1))
    ariel_run(config, folder / "run")
    return folder / "run"


def _copy(run_dir: Path, tmp_path: Path) -> Path:
    return Path(
        shutil.copytree(run_dir, tmp_path / "run", ignore=shutil.ignore_patterns("gallery"))
    )


def _config_edited(run_dir: Path, tmp_path: Path, section: str, key: str, value: object) -> Path:
    """A copy whose config has ``section.key = value``, its config_hash made again to match
    (as a crafter would: ``ariel verify`` passes)."""
    copy = _copy(run_dir, tmp_path)
    info = json.loads((copy / "run.json").read_text())
    info["config"][section][key] = value
    info["config_hash"] = config_hash(ExperimentConfig.from_plain(info["config"]))
    (copy / "run.json").write_text(json.dumps(info))
    state = copy / "checkpoints" / "state.json"
    checkpoint = json.loads(state.read_text())
    checkpoint["state"]["config_hash"] = info["config_hash"]
    state.write_text(json.dumps(checkpoint))
    assert exit_code(["verify", str(copy)]) == 0
    return copy


def _commands(run: Path, out: Path, *, body: bool) -> list[list[str]]:
    commands = [["replay", str(run), "best"], ["export", str(run), "best", str(out)]]
    if body:  # report and gallery draw bodies: the body encoder and the world
        commands += [["report", str(run)], ["gallery", str(run)]]
    return commands


@pytest.mark.parametrize(
    ("section", "options", "plugin", "cause", "body"),
    [
        ("world", {"k": 1}, "world 'flat'", "unknown option 'k'", True),
        ("world", {"floor_size": "big"}, "world 'flat'", "", True),
        ("body", {"number_of_modules": -5}, "body encoder 'nde'", "number_of_modules", True),
        ("brain", {"k": 1}, "controller 'na_cpg'", "'k'", False),
        ("task", {"k": 1}, "fitness function 'xy_displacement'", "'k'", False),
    ],
)
def test_options_a_plugin_rejects_are_one_line_naming_the_run_and_the_plugin(
    run_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    section: str,
    options: dict,
    plugin: str,
    cause: str,
    body: bool,
) -> None:
    copy = _config_edited(run_dir, tmp_path, section, "options", options)
    capsys.readouterr()
    for command in _commands(copy, tmp_path / "out", body=body):
        assert exit_code(command) == 2, command
        line = one_error_line(capsys)
        assert f"run folder {str(copy)!r}" in line and f"{section}.options" in line, line
        assert f"rejected by {plugin}: " in line and cause in line, line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("value", [None, []])
def test_a_config_section_that_is_no_table_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], value: object
) -> None:
    copy = _copy(run_dir, tmp_path)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["task"] = value
    (copy / "run.json").write_text(json.dumps(info))
    capsys.readouterr()
    for command in [
        *_commands(copy, tmp_path / "out", body=False),
        ["report", str(copy), "--no-render"],
        ["gallery", str(copy)],
    ]:
        assert exit_code(command) == 2, command
        line = one_error_line(capsys)
        assert f"run folder {str(copy)!r} is damaged: " in line, line
        assert f"run.json has task {value!r} in its config, not a section (a table)" in line
    assert exit_code(["verify", str(copy)]) == 1  # said once, not once per table file
    assert capsys.readouterr().out.count(f"run.json has task {value!r} in its config") == 1


@pytest.fixture
def unbuildable(run_dir: Path, tmp_path: Path) -> Path:
    """A copy whose evaluations all hold a genotype the NDE cannot decode, statuses still ok
    (the table changed, its manifest written again as a crafter would)."""
    copy = _copy(run_dir, tmp_path)
    path = copy / "evaluations" / "gen-000000.parquet"
    table = pq.read_table(path)
    index = table.schema.get_field_index("body_genotype")
    field = table.schema.field(index)
    table = table.set_column(index, field, pa.array(["[]"] * len(table), field.type))
    pq.write_table(table, path)
    write_manifest(copy, 0)
    return copy


def test_export_of_a_genotype_that_does_not_build_is_one_line(
    unbuildable: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(["export", str(unbuildable), "best", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys)
    assert line.startswith("ariel: error: evaluation 'b0000") and str(unbuildable) in line
    assert "could not be built from the stored genotype" in line
    assert "genotype must have exactly 3 chromosomes" in line
    assert not (tmp_path / "out").exists()


def test_replay_of_a_genotype_that_does_not_build_says_why(
    unbuildable: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(["replay", str(unbuildable), "best"]) == 1  # not reproduced
    out = capsys.readouterr().out
    assert "identical: NO" in out
    assert "why: the body could not be built from the stored genotype: " in out
    assert "genotype must have exactly 3 chromosomes" in out


def test_what_replay_prints_from_the_folder_is_escaped(
    run_dir: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whatever the folder holds (ids, statuses, versions), no control character is printed."""
    replayed = resim.replay(run_dir, "best")
    replayed.run.info["run_id"] = ESC
    replayed.row = {**replayed.row, "body_id": ESC, "status": ESC}
    replayed.version_differences = {"numpy": (ESC, "2")}
    monkeypatch.setattr(resim, "replay", lambda *args: replayed)
    assert exit_code(["replay", str(run_dir), "best"]) == 1  # the statuses differ
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert out.count(r"x\x1b[2J\x1b]0;pwned\x07") == 4, out


def test_what_export_prints_of_its_folder_is_escaped(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / ESC
    assert exit_code(["export", str(run_dir), "best", str(out)]) == 0
    printed = capsys.readouterr().out
    assert (out / "body.xml").is_file()
    assert "\x1b" not in printed and "\x07" not in printed
    assert printed.startswith(f"wrote {tmp_path}/x\\x1b[2J"), printed
    # the commands it prints run as shown: bash's $'...' for a name with control characters
    (script,) = re.findall(r" (\$'.*?replay\.py')\)", printed)  # (no viewer: headless)
    shown = subprocess.run(["bash", "-c", f"printf %s {script}"], capture_output=True, text=True)
    assert shown.stdout == str(out / "replay.py")


def test_what_report_prints_of_the_config_is_escaped(run_dir: Path, tmp_path: Path) -> None:
    report = make_report(_copy(run_dir, tmp_path), render=False)
    report.run.config["generations"] = ESC
    printed = io.StringIO()
    print_report(report, Console(file=printed, width=200))
    assert "\x1b" not in printed.getvalue() and "\x07" not in printed.getvalue()
    assert load_run(report.run.path).generations_done == 1


def test_a_plugin_that_raises_while_replaying_is_one_line(
    run_dir: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A fitness option whose value the function rejects only while it scores: found when the
    replay runs it, said in one line naming the evaluation (a traceback before)."""
    from ariel import evaluation

    def rejects(task: object) -> object:
        raise ValueError("window must be > 0, got -1")

    monkeypatch.setattr(evaluation, "evaluate", rejects)
    assert exit_code(["replay", str(run_dir), "best"]) == 2
    line = one_error_line(capsys)
    assert re.search(r"re-simulating b\d+-i\d+-c\d+ raised ValueError: window must be", line)
