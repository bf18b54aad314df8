"""Bad input to ``ariel``, one table: each case is one line on stderr, exit code 2, and NOTHING
written: a new output folder is never created, and an existing run folder (given with
``--overwrite``, or to ``resume`` / ``replay``) stays byte for byte as it was.

The cases are the list of issue 9: malformed TOML, wrong types, out-of-range values, unknown
plugin names, genotype files of the wrong shape or with NaN, ``resume`` of a folder that is
not a run, of a run with a changed config or of a finished run, ``replay`` of an unknown
evaluation id.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from _helpers import REPO, ariel_run, exit_code, one_error_line, snapshot, tiny_run_toml

BASE = tiny_run_toml("badinput", 1)


def _edit(text: str, section: str, line: str) -> str:
    """``BASE`` with ``line`` added to ``[section]`` ("" for the top level)."""
    if not section:
        return f"{line}\n{text}"
    return text.replace(f"[{section}]\n", f"[{section}]\n{line}\n", 1)


def _npy(array: np.ndarray) -> Callable[[Path], None]:
    return lambda path: np.save(path, array)


def _text(text: str) -> Callable[[Path], None]:
    return lambda path: path.write_text(text)


@dataclass
class RunCase:
    """``ariel run CONFIG`` of ``BASE`` changed as given; ``files`` beside the config."""

    message: str
    toml: str = BASE
    args: list[str] = field(default_factory=list)
    files: dict[str, Callable[[Path], None]] = field(default_factory=dict)


GOOD_NDE = np.full((3, 64), 0.5)
NAN_NDE = GOOD_NDE.copy()
NAN_NDE[1, 7] = np.nan

RUN_CASES: dict[str, RunCase] = {
    # malformed TOML
    "toml-unclosed-table": RunCase("malformed TOML", "[brain\npopsize = 3\n"),
    "toml-bad-value": RunCase("malformed TOML", "generations = [1,\n"),
    # wrong types
    "unknown-key": RunCase("unknown key 'generation'", _edit(BASE, "", "generation = 3")),
    "type-int": RunCase(
        "generations: must be a valid integer", BASE.replace("generations = 2", "generations = 2.5")
    ),
    "type-str-int": RunCase(
        "brain.iterations: must be a valid integer",
        BASE.replace("iterations = 1", 'iterations = "many"'),
    ),
    "type-table": RunCase(
        "world: must be a table ([world] in TOML, a dict) (got 3)", _edit(BASE, "", "world = 3")
    ),
    # pydantic's own words ("Field required", a regular expression): the config's instead
    "spawn-short": RunCase(
        "task.spawn_position: too few values (got [1])", _edit(BASE, "task", "spawn_position = [1]")
    ),
    "spawn-long": RunCase(
        "task.spawn_position: too many values, at most 3",
        _edit(BASE, "task", "spawn_position = [1, 2, 3, 4]"),
    ),
    "name-pattern": RunCase(
        "name: must be letters, digits, _ . - only (got 'a b')",
        BASE.replace('name = "badinput"', 'name = "a b"'),
    ),
    "type-spawn": RunCase("task.spawn_position", _edit(BASE, "task", 'spawn_position = "origin"')),
    "type-bool": RunCase(
        "brain.inherit: must be a valid boolean", _edit(BASE, "brain", "inherit = 7")
    ),
    # out-of-range values
    "population-0": RunCase(
        "body.population: must be greater than or equal to 1",
        BASE.replace("population = 2", "population = 0"),
    ),
    "duration-negative": RunCase(
        "task.duration: must be greater than 0", BASE.replace("duration = 0.3", "duration = -1.0")
    ),
    "control-period-0": RunCase(
        "brain.control_period: must be greater than or equal to 1",
        _edit(BASE, "brain", "control_period = 0"),
    ),
    "rate-0": RunCase(
        "record.rate_hz: must be greater than 0", _edit(BASE, "record", "rate_hz = 0")
    ),
    "sigma-0": RunCase("brain.sigma0: must be greater than 0", _edit(BASE, "brain", "sigma0 = 0")),
    "crossover-rate-2": RunCase(
        "body.crossover_rate: must be less than or equal to 1",
        _edit(BASE, "body", "crossover_rate = 2.0"),
    ),
    # unknown plugin names
    "unknown-encoder": RunCase(
        "body.encoder: unknown body encoder 'nope'", _edit(BASE, "body", 'encoder = "nope"')
    ),
    "unknown-controller": RunCase(
        "brain.controller: unknown controller 'nope'", _edit(BASE, "brain", 'controller = "nope"')
    ),
    "unknown-world": RunCase(
        "world.name: unknown world 'nope'", BASE + '\n[world]\nname = "nope"\n'
    ),
    "unknown-fitness": RunCase(
        "task.fitness: unknown fitness function 'nope'", _edit(BASE, "task", 'fitness = "nope"')
    ),
    # an option the plugin has no keyword for: named, with the ones it has (Python's own
    # "__init__() got an unexpected keyword argument" named none)
    "unknown-encoder-option": RunCase(
        "body.options: body encoder 'nde': unknown option 'colour'; allowed: number_of_modules,",
        BASE.replace("options = { number_of_modules = 10 }", "options = { colour = 1 }"),
    ),
    "unknown-fitness-option": RunCase(
        "task.options: fitness function 'xy_displacement': unknown option 'colour'; "
        "it takes no options",
        _edit(BASE, "task", "options = { colour = 1 }"),
    ),
    "unknown-prebuilt": RunCase(
        "body.genotype: 'dragon' gives no body",
        BASE.replace(
            "options = { number_of_modules = 10 }", 'encoder = "prebuilt"\ngenotype = "dragon"'
        ),
    ),
    # genotype files (a fixed NDE body: three chromosomes of genotype_size = 64 genes)
    "genotype-json-shape": RunCase(
        "body.genotype: file '{dir}/body.json': shape (2, 64), expected (3, 64)",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text(json.dumps(GOOD_NDE[:2].tolist()))},
    ),
    "genotype-json-flat": RunCase(
        "body.genotype: file '{dir}/body.json': shape (192,), expected (3, 64)",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text(json.dumps(GOOD_NDE.ravel().tolist()))},
    ),
    "genotype-json-nan": RunCase(
        "body.genotype: file '{dir}/body.json': 1 of 192 values are not finite (NaN or infinite)",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text(json.dumps(NAN_NDE.tolist()))},
    ),
    "genotype-json-ragged": RunCase(
        "body.genotype: file '{dir}/body.json': not an array of numbers",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text(json.dumps([[0.5] * 64, [0.5] * 64, [0.5] * 63]))},
    ),
    "genotype-json-words": RunCase(
        "body.genotype: file '{dir}/body.json': not an array of numbers",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text(json.dumps([["a"] * 64] * 3))},
    ),
    "genotype-json-malformed": RunCase(
        "body.genotype: file '{dir}/body.json': not valid JSON",
        _edit(BASE, "body", 'genotype = "body.json"'),
        files={"body.json": _text("[[0.5, 0.5")},
    ),
    "genotype-npy-shape": RunCase(
        "body.genotype: file '{dir}/body.npy': shape (3, 32), expected (3, 64)",
        _edit(BASE, "body", 'genotype = "body.npy"'),
        files={"body.npy": _npy(np.zeros((3, 32), np.float32))},
    ),
    "genotype-npy-inf": RunCase(
        "body.genotype: file '{dir}/body.npy': 192 of 192 values are not finite",
        _edit(BASE, "body", 'genotype = "body.npy"'),
        files={"body.npy": _npy(np.full((3, 64), np.inf))},
    ),
    "genotype-npy-pickled": RunCase(
        "body.genotype: file '{dir}/body.npy': not a numeric .npy array",
        _edit(BASE, "body", 'genotype = "body.npy"'),
        files={"body.npy": _npy(np.array([{"not": "numbers"}], dtype=object))},
    ),
    "genotype-npy-not-npy": RunCase(
        "body.genotype: file '{dir}/body.npy': not a numeric .npy array",
        _edit(BASE, "body", 'genotype = "body.npy"'),
        files={"body.npy": _text("hello")},
    ),
    "genotype-missing-file": RunCase(
        "body.genotype: file '{dir}/nowhere.json' not found",
        _edit(BASE, "body", 'genotype = "nowhere.json"'),
    ),
    "genotype-inline-nan": RunCase(
        "body.genotype: 1 of 192 values are not finite",
        _edit(BASE, "body", f"genotype = {json.dumps(NAN_NDE.tolist()).replace('NaN', 'nan')}"),
    ),
}


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("finished")
    (folder / "base.toml").write_text(BASE)
    out = folder / "run"
    ariel_run(folder / "base.toml", out)
    return out


@pytest.mark.parametrize("case", RUN_CASES.values(), ids=RUN_CASES)
def test_bad_run_input(
    case: RunCase, finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "bad.toml"
    config.write_text(case.toml)
    for name, write in case.files.items():
        write(tmp_path / name)
    message = case.message.format(dir=tmp_path)
    given = sorted(p.name for p in tmp_path.iterdir())
    # A new folder is not created ...
    out = tmp_path / "never"
    assert exit_code(["run", str(config), "--out", str(out), "--quiet", *case.args]) == 2
    assert message in one_error_line(capsys, quiet=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == given
    # ... and a run folder to be overwritten stays as it was.
    before = snapshot(finished_run)
    argv = ["run", str(config), "--out", str(finished_run), "--overwrite", "--quiet", *case.args]
    assert exit_code(argv) == 2
    assert message in one_error_line(capsys, quiet=True)
    assert snapshot(finished_run) == before


# --------------------------------------------------------------------------------------------
# resume / replay of what cannot be resumed or replayed
# --------------------------------------------------------------------------------------------


def _not_a_run(finished: Path, tmp: Path) -> Path:
    folder = tmp / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    return folder


def _copy(finished: Path, tmp: Path) -> Path:
    copy = tmp / "copy"
    shutil.copytree(finished, copy)
    return copy


def _unfinished(finished: Path, tmp: Path) -> Path:
    copy = _copy(finished, tmp)
    info = json.loads((copy / "run.json").read_text())
    info["status"] = "interrupted"
    (copy / "run.json").write_text(json.dumps(info))
    return copy


def _edited_config(finished: Path, tmp: Path) -> Path:
    copy = _unfinished(finished, tmp)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["brain"]["popsize"] = 3
    (copy / "run.json").write_text(json.dumps(info))
    return copy


def _bad_config(finished: Path, tmp: Path) -> Path:
    copy = _unfinished(finished, tmp)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["brain"]["popsize"] = "many"
    (copy / "run.json").write_text(json.dumps(info))
    return copy


def _broken_run_json(finished: Path, tmp: Path) -> Path:
    copy = _copy(finished, tmp)
    (copy / "run.json").write_text('{"format": 1, "status": ')
    return copy


def _broken_checkpoint(finished: Path, tmp: Path) -> Path:
    copy = _unfinished(finished, tmp)
    (copy / "checkpoints" / "state.json").write_bytes(b"not JSON")
    return copy


def _foreign_checkpoint(finished: Path, tmp: Path) -> Path:
    copy = _unfinished(finished, tmp)
    (copy / "checkpoints" / "state.json").write_text(json.dumps({"format": 99}))
    return copy


FOLDER_CASES: dict[str, tuple[Callable[[Path, Path], Path], list[str], str]] = {
    "resume-not-a-run": (_not_a_run, ["resume"], "is not an ariel run folder (no run.json)"),
    "resume-missing": (
        lambda f, t: t / "missing",
        ["resume"],
        "is not an ariel run folder (no such folder)",
    ),
    "resume-file": (
        lambda f, t: (t / "file.txt", (t / "file.txt").write_text("x"))[0],
        ["resume"],
        "is not an ariel run folder (a file, not a folder)",
    ),
    "resume-finished": (lambda f, t: _copy(f, t), ["resume"], "is already finished; nothing to"),
    "resume-edited-config": (_edited_config, ["resume"], "its config was edited after the run"),
    "resume-invalid-config": (_bad_config, ["resume"], "its config cannot be read (brain.popsize"),
    "resume-broken-run-json": (_broken_run_json, ["resume"], "unreadable run.json"),
    "resume-broken-checkpoint": (_broken_checkpoint, ["resume"], "unreadable checkpoint"),
    "resume-foreign-checkpoint": (
        _foreign_checkpoint,
        ["resume"],
        "checkpoint of format 99, written by a newer",
    ),
    "replay-unknown-id": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "b999999-i000-c000"],
        "no evaluation 'b999999-i000-c000'",
    ),
    "replay-malformed-id": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "../../etc/passwd"],
        "no evaluation '../../etc/passwd'",
    ),
    "replay-not-a-run": (_not_a_run, ["replay", "{run}", "best"], "is not an ariel run folder"),
    # A replay's file inside the run replaced run.json or a table (refused before simulating).
    "replay-video-over-run-json": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "best", "--video", "{run}/run.json"],
        "/run.json' is inside the run or campaign folder '",
    ),
    "replay-rrd-over-a-table": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "best", "--rrd", "{run}/sub/../evaluations/gen-000000.parquet"],
        "--rrd: '",
    ),
    # As root, the replaced "file" was /dev/null itself: a regular file from then on.
    "replay-rrd-over-a-device": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "best", "--rrd", "/dev/null"],
        "--rrd: '/dev/null' is a character device such as /dev/null, which is never replaced",
    ),
    "replay-video-a-folder": (
        lambda f, t: _copy(f, t),
        ["replay", "{run}", "best", "--video", "{run}/.."],
        "/..' is a folder; give a FILE",
    ),
    "report-not-a-run": (_not_a_run, ["report", "{run}"], "is not an ariel run folder"),
}


@pytest.mark.parametrize(("make", "command", "message"), FOLDER_CASES.values(), ids=FOLDER_CASES)
def test_bad_folder_input(
    make: Callable[[Path, Path], Path],
    command: list[str],
    message: str,
    finished_run: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    folder = make(finished_run, tmp_path)
    argv = [part.format(run=folder) for part in command]
    if "{run}" not in command:
        argv.append(str(folder))
    if argv[0] == "resume":
        argv.append("--quiet")
    listing = sorted(p.name for p in tmp_path.iterdir())
    before = snapshot(folder) if folder.is_dir() else None
    assert exit_code(argv) == 2
    assert message in one_error_line(capsys, quiet=True)
    assert (snapshot(folder) if folder.is_dir() else None) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == listing


# --------------------------------------------------------------------------------------------
# paths no file system takes: a name over 255 bytes, a loop of links
# --------------------------------------------------------------------------------------------

LONG = "L" * 300
CAMPAIGN = REPO / "tests" / "data" / "campaign_tiny.toml"


@pytest.mark.parametrize(
    ("command", "message"),
    [
        (["run", "{base}", "--out", f"sub/{LONG}", "--quiet"], "File name too long"),
        (["campaign", "run", "{long}.toml"], "File name too long"),
        (["runs", LONG], "File name too long"),
        (["runs", "{deep}"], "a whole path has at most 4096 bytes"),  # every name short
        (["view", LONG], "File name too long"),
        (["export", LONG, "best", "out"], "File name too long"),
        (["run", "{base}", "--out", "loop/x", "--quiet"], "Too many levels of symbolic links"),
        (["report", "loop"], "Too many levels of symbolic links"),
        # The folder's name is the run's (campaign's) id, which every reader checks: a name
        # it could not read back is refused up front, not written and then refused.
        (["run", "{base}", "--out", 'a"b', "--quiet"], "run id 'a\"b' (the name of the run"),
        (["campaign", "run", str(CAMPAIGN), "--out", "a\\b"], "campaign id 'a\\\\b' (the name"),
        # Bytes that are no UTF-8 (a file system takes them; Rerun's writer died on them in
        # the run's first generation, and a resume marked the run failed).
        (["run", "{base}", "--out", "bad\udcff/r", "--quiet"], "not UTF-8 (Rerun writes"),
        (["campaign", "run", str(CAMPAIGN), "--out", "bad\udcff/c"], "not UTF-8 (Rerun"),
        (["resume", "bad\udcff"], "bad\\udcff': not UTF-8 (Rerun writes recordings only"),
    ],
    ids=[
        *("run-out", "campaign-file", "runs", "runs-deep", "view", "export"),
        *("run-out-loop", "report-loop"),
        *("run-id", "campaign-id"),
        *("run-not-utf8", "campaign-not-utf8", "resume-not-utf8"),
    ],
)
def test_path_no_file_system_takes_or_no_id(
    command: list[str],
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "loop").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop")
    listing = sorted(p.name for p in tmp_path.iterdir())
    deep = "/".join(["d" * 200] * 21)
    argv = [part.format(base="base.toml", long=LONG, deep=deep) for part in command]
    assert exit_code(argv) == 2
    line = one_error_line(capsys)
    assert message in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == listing  # no folder made on the way


def test_an_error_line_is_escaped_and_cut(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every command's one error line: a folder name with ESC or a line break stays one line
    of text, and a message echoing a huge input is cut (a 3,000,000-number array made a
    15 MB line)."""
    named = tmp_path / "e\x1b]0;pwn\x07\nx"
    named.mkdir()
    assert exit_code(["view", str(named)]) == 2
    line = one_error_line(capsys)
    assert "\x1b" not in line and "\\x1b]0;pwn\\x07\\nx" in line
    config = tmp_path / "huge.toml"
    config.write_text("[task]\nspawn_position = [" + ", ".join(["0.0"] * 300_000) + "]\n")
    assert exit_code(["config", "show", str(config)]) == 2
    line = one_error_line(capsys)
    assert len(line) < 2100 and "characters in all)" in line, len(line)
    # A path of 2,000 characters cut the reason off every error: the end is kept.
    deep = tmp_path.joinpath(*["d" * 200] * 10) / "run"
    assert exit_code(["resume", str(deep)]) == 2
    line = one_error_line(capsys)
    assert "characters in all)" in line and line.endswith("(no such folder)"), line[-200:]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        # '' is the current folder to the file system: `runs ''` listed it, `gallery --out ''`
        # wrote into it, `run --out ''` said "'.' already exists".
        (["runs", ""], "ariel runs: error: an empty argument (''); give a path or value"),
        (["gallery", "r", "--out", ""], "ariel gallery: error: --out: an empty value; give a"),
        (["run", "--out="], "ariel run: error: --out: an empty value; give a path or value"),
        # An unknown flag after a command pointed at `ariel --help`.
        (["run", "--bogus"], "ariel run: error: unrecognized arguments: --bogus (see ariel run"),
        (["campaign", "run", "f.toml", "--overwrite"], "(see ariel campaign run --help)"),
    ],
)
def test_an_empty_or_unknown_argument_is_the_command_s_usage_error(
    argv: list[str],
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    assert exit_code(argv) == 2
    assert message in one_error_line(capsys, subcommand=True, quiet=True)
    assert list(tmp_path.iterdir()) == []


def test_a_file_the_user_names_may_go_through_a_linked_folder_of_theirs(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--lineage linkdir/l.csv`` was refused as if it were a run folder's file ("a run
    folder's files are written only inside it"); on macOS /tmp itself is a link."""
    real, link = tmp_path / "real", tmp_path / "link"
    real.mkdir()
    link.symlink_to(real)
    assert exit_code(["export", str(finished_run), "--lineage", str(link / "l.csv")]) == 0
    assert f"wrote {link / 'l.csv'}: the lineage of " in capsys.readouterr().out
    assert (real / "l.csv").is_file() and not (real / "l.csv").is_symlink()


def test_a_replay_s_output_is_refused_before_anything_is_simulated(
    finished_run: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--video DIR` used to fail after the whole replay, naming a temporary path."""
    from ariel.recording import resim

    def never(*args: object) -> None:
        raise AssertionError("simulated before the output was checked")

    monkeypatch.setattr(resim, "replay", never)
    assert exit_code(["replay", str(finished_run), "best", "--video", str(finished_run)]) == 2
    assert "is a folder; give a FILE" in one_error_line(capsys, quiet=True)
    # A name the file system takes, but not its temporary (14 bytes longer) beside it.
    long = str(finished_run.parent / f"{'r' * 247}.rrd")
    assert exit_code(["replay", str(finished_run), "best", "--rrd", long]) == 2
    assert "has 251 bytes; at most 241 (it is written whole beside" in one_error_line(capsys)


def test_no_output_the_user_names_lands_in_any_run_folder(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`replay A best --rrd B/run.json` replaced run B's run.json with a recording (the check
    covered the replayed run alone); `view --screenshot` replaced a FIFO."""
    other = _copy(finished_run, tmp_path)
    before = snapshot(other)
    argv = ["replay", str(finished_run), "best", "--rrd", str(other / "run.json")]
    assert exit_code(argv) == 2
    assert "is inside the run or campaign folder" in one_error_line(capsys, quiet=True)
    assert snapshot(other) == before
    fifo = tmp_path / "shot.png"
    os.mkfifo(fifo)
    assert exit_code(["view", str(finished_run), "--screenshot", str(fifo)]) == 2
    assert "is a FIFO, which is never replaced" in one_error_line(capsys, subcommand=True)
    assert stat.S_ISFIFO(fifo.lstat().st_mode)
