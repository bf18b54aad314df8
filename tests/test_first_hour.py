"""A researcher's first hour (issue 17): every command the CLI prints works when pasted into a
fresh shell, ``ariel quickstart`` takes the script's options, ``ariel runs`` on a missing
folder, ``ariel config show``, and a quiet ``make`` setup."""

from __future__ import annotations

import ast
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from _helpers import REPO, ariel_run, exit_code, one_error_line, repo_env, tiny_run_toml

from ariel.cli import main


def _fresh_shell_env() -> dict[str, str]:
    """A new shell's environment: no virtual environment on PATH, not activated."""
    env = repo_env()
    env.pop("VIRTUAL_ENV", None)
    env["PATH"] = "/usr/bin:/bin"
    env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("MPLBACKEND", "Agg")
    return env


@pytest.fixture(scope="module")
def printed_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A tiny finished run made by ``ariel run`` with a folder like the repository root as the
    current folder (data/runs/<id> relative), and what it printed."""
    root = tmp_path_factory.mktemp("root")
    (root / "tiny.toml").write_text(tiny_run_toml("firsthour", 3, record=None))
    cwd = Path.cwd()
    os.chdir(root)
    try:
        printed = ariel_run(Path("tiny.toml"), Path("data/runs/firsthour"))
    finally:
        os.chdir(cwd)
    return root, printed


def _printed_commands(printed: str) -> list[str]:
    after = printed.split("look at the results:\n", 1)[1]
    commands = []
    for line in after.splitlines():
        line = line.strip()
        if not line or line.startswith("("):
            continue
        commands.append(re.sub(r"\s+# .*$", "", line))  # the comment after the command
    return commands


def test_every_printed_command_works_in_a_fresh_shell(printed_run) -> None:
    root, printed = printed_run
    commands = _printed_commands(printed)
    verbs = [shlex.split(c)[1] if "-c" not in shlex.split(c) else "python" for c in commands]
    assert verbs == ["report", "view", "replay", "runs", "python"], commands
    for command in commands:
        if shlex.split(command)[1] == "view":  # opens a window: check the command exists
            command = f"{shlex.split(command)[0]} view --help"
        if shlex.split(command)[1] == "report":
            command += " --no-render"  # the rendered image is the report's business, not ours
        done = _pasted(command, root)
        assert done.returncode == 0, f"{command}\n{done.stderr[-2000:]}"
        if "load_run" in command:  # the generations, with best_fitness shown, not behind "..."
            header = done.stdout.splitlines()[0].split()
            assert "best_fitness" in header and "..." not in done.stdout
            assert len(done.stdout.splitlines()) == 1 + 2  # a header, two generations


def _pasted(command: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``command`` pasted into a fresh shell in ``cwd``."""
    return subprocess.run(
        ["/bin/sh", "-c", command],
        cwd=cwd,
        env=_fresh_shell_env(),
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_hints_in_error_messages_work_when_pasted(
    printed_run, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The commands in the recording code's one-line errors (`ariel.utils._commands`)."""
    root, _ = printed_run
    monkeypatch.chdir(root)
    run_dir = "data/runs/firsthour"
    # an unknown evaluation: the line that lists the ids
    assert main(["replay", run_dir, "b999999-i000-c000"]) == 2
    listing = one_error_line(capsys).split("list them with ", 1)[1]
    done = _pasted(listing, root)
    assert done.returncode == 0, f"{listing}\n{done.stderr[-2000:]}"
    assert "b000000-i000-c000" in done.stdout and "..." not in done.stdout
    # an unfinished run in the way of a new one: the line that continues it
    info = json.loads((root / run_dir / "run.json").read_text())
    unfinished = root / "data" / "runs" / "unfinished"
    shutil.copytree(root / run_dir, unfinished)
    (unfinished / "run.json").write_text(json.dumps({**info, "status": "interrupted"}))
    assert main(["run", "tiny.toml", "--out", "data/runs/unfinished", "--quiet"]) == 2
    resume = one_error_line(capsys, subcommand=True).split("continue it with: ", 1)[1]
    assert shlex.split(resume)[-2:] == ["resume", "data/runs/unfinished"]
    done = _pasted(f"{resume.rsplit(' ', 1)[0]} --help", root)  # it would run: the command only
    assert done.returncode == 0 and "usage:" in done.stdout, done.stderr[-2000:]
    # a finished run there: no resume offered
    assert main(["run", "tiny.toml", "--out", run_dir, "--quiet"]) == 2
    assert "resume" not in one_error_line(capsys, subcommand=True)
    # a damaged run: the line that lists every damaged file
    damaged = root / "data" / "runs" / "damaged"
    shutil.copytree(root / run_dir, damaged)
    table = next((damaged / "evaluations").glob("*.parquet"))
    table.write_bytes(table.read_bytes()[:-10])
    assert main(["report", "data/runs/damaged", "--no-render"]) == 2
    verify = one_error_line(capsys).split("copy (", 1)[1].split(" lists every damaged file")[0]
    done = _pasted(verify, root)
    assert done.returncode == 1 and "damaged: " in done.stdout, done.stdout + done.stderr
    # `ariel export`: the line that runs the exported replay script
    assert main(["export", run_dir, "best", "data/exported it"]) == 0
    replay = capsys.readouterr().out.rsplit("replay.py (", 1)[1].strip().removesuffix(")")
    done = _pasted(replay, root)
    assert done.returncode == 0, f"{replay}\n{done.stderr[-2000:]}"


def test_printed_commands_name_the_environments_ariel(printed_run) -> None:
    _, printed = printed_run
    commands = _printed_commands(printed)
    program = shlex.split(commands[0])[0]
    assert program == "ariel" or Path(program).name == "ariel" or "-m ariel.cli" in commands[0]
    assert shlex.split(commands[-1])[0] in {sys.executable, os.path.relpath(sys.executable)}


def test_ariel_command_is_the_venv_script_relative_to_the_current_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.utils import _commands as _cli_commands

    scripts = tmp_path / ".venv" / "bin"
    scripts.mkdir(parents=True)
    (scripts / "ariel").write_text("#!/bin/sh\n")
    (scripts / "python").write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "prefix", str(tmp_path / ".venv"))
    monkeypatch.setattr(sys, "executable", str(scripts / "python"))
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    monkeypatch.delenv("VIRTUAL_ENV", raising=False)
    assert _cli_commands.ariel_command() == ".venv/bin/ariel"
    assert _cli_commands.python_command() == ".venv/bin/python"
    # elsewhere: absolute paths
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert _cli_commands.ariel_command() == str(scripts / "ariel")
    # activated in this shell (on PATH here, not in a new shell): still the path
    monkeypatch.setenv("PATH", f"{scripts}:/usr/bin:/bin")
    monkeypatch.setenv("VIRTUAL_ENV", str(tmp_path / ".venv"))
    (scripts / "ariel").chmod(0o755)
    assert _cli_commands.ariel_command() == str(scripts / "ariel")
    # on PATH for good (not activated): plain ariel
    monkeypatch.delenv("VIRTUAL_ENV")
    assert _cli_commands.ariel_command() == "ariel"
    # no environment script and no ariel on PATH: python -m ariel.cli
    monkeypatch.setattr(sys, "prefix", sys.base_prefix)
    monkeypatch.setenv("PATH", "/nonexistent")
    assert _cli_commands.ariel_command() == f"{scripts / 'python'} -m ariel.cli"


def test_a_printed_path_starting_with_equals_or_a_dash_is_pasteable() -> None:
    """zsh reads ``=ls`` as the path of the command ls (probe G4): ``./=ls``."""
    from ariel.utils import shell_path

    assert shell_path("=ls") == "./=ls" and shell_path("-x") == "./-x"
    assert shell_path("a=b") == "a=b" and shell_path("it's") == "'it'\"'\"'s'"


def test_load_run_command_quotes_an_odd_path() -> None:
    from ariel.utils._commands import load_run_command

    line = load_run_command("data/runs/it's $HOME", what="r")
    words = shlex.split(line)
    assert words[1] == "-c"
    assert words[2] == (
        'from ariel.recording import load_run; r = load_run("data/runs/it\'s $HOME"); print(r)'
    )
    # An emoji in the path: JSON wrote it as two surrogates, which Python cannot encode.
    code = shlex.split(load_run_command("runs/emoji\N{GRINNING FACE}/r"))[2]
    literal = code.split("load_run(")[1].split("); print")[0]
    assert ast.literal_eval(literal) == "runs/emoji\N{GRINNING FACE}/r"


# --------------------------------------------------------------------------------------------
# ariel quickstart, ariel runs
# --------------------------------------------------------------------------------------------


def test_quickstart_takes_the_scripts_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["quickstart", "--seed", "1", "--duration", "0.5", "--no-video", "--out", "q"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "simulated 0.50 s (8 actuators, CPG seed 1)" in out
    assert (tmp_path / "q" / "quickstart_trajectory_seed1.png").is_file()


def test_quickstart_help_is_the_scripts(capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(["quickstart", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: ariel quickstart") and "--duration" in out
    out = " ".join(out.split("options:", 1)[1].split())  # argparse wraps at the terminal width
    for option, default in (
        ("--duration SECONDS", "15.0"),
        ("--seed N", "42"),
        ("--out DIR", "data/quickstart"),
        ("--video-seconds SECONDS", "5.0"),
    ):
        help_text = out.split(option, 1)[1].split(" --", 1)[0]
        assert f"(default: {default})" in help_text, (option, help_text)


def test_other_commands_still_refuse_unknown_options(capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(["runs", "--seed"]) == 2
    assert "unrecognized arguments: --seed" in one_error_line(capsys, subcommand=True)


def test_runs_on_a_folder_that_does_not_exist(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["runs", str(tmp_path / "nope")]) == 2
    assert "does not exist" in one_error_line(capsys, quiet=True)
    (tmp_path / "file").write_text("")
    assert main(["runs", str(tmp_path / "file")]) == 2
    assert "is not a folder" in one_error_line(capsys, quiet=True)
    assert main(["runs", str(tmp_path)]) == 0  # a folder without runs: said so, exit 0
    assert "no runs under" in capsys.readouterr().out


# --------------------------------------------------------------------------------------------
# ariel config show
# --------------------------------------------------------------------------------------------


def test_config_show_prints_every_key_as_toml(capsys: pytest.CaptureFixture[str]) -> None:
    from ariel.evolution import load_config

    assert main(["config", "show", "--set", "brain.popsize=12", "--set", "seed=7"]) == 0
    text = capsys.readouterr().out
    data = tomllib.loads(text)
    expected = load_config(None, ["brain.popsize=12", "seed=7"]).to_plain()
    assert data["brain"]["popsize"] == 12 and data["seed"] == 7
    # every key with a value is there; the unset ones (None) are comments
    for table, values in expected.items():
        if not isinstance(values, dict):
            assert data[table] == values
            continue
        for key, value in values.items():
            if value is None:
                assert f"# {key}: not set" in text
            elif (table, key) == ("executor", "device"):  # the local executor has no device
                assert "device" not in data[table]
                assert '# device = "cuda"  (not used: only the gpu executor' in text
            else:
                assert data[table][key] == value, (table, key)
    assert load_config(data).to_plain() == expected  # it reads back as the same experiment


@pytest.mark.parametrize(
    ("sets", "line"),
    [
        (["executor.kind=gpu"], 'device = "cuda"\n'),  # the gpu executor: a plain key
        (  # another kind with a device set: kept (it reads back the same), said to be unused
            ["executor.kind=serial", "executor.device=cpu"],
            'device = "cpu"  # not used: only the gpu executor has a device, and '
            'executor.kind is "serial"\n',
        ),
    ],
)
def test_config_show_says_when_the_device_is_not_used(
    capsys: pytest.CaptureFixture[str], sets: list[str], line: str
) -> None:
    from ariel.evolution import load_config

    assert main(["config", "show", *[arg for s in sets for arg in ("--set", s)]]) == 0
    text = capsys.readouterr().out
    assert line in text
    assert load_config(tomllib.loads(text)).to_plain() == load_config(None, sets).to_plain()


def test_config_show_of_a_file_and_a_bad_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = REPO / "experiments" / "gecko_gait.toml"
    assert main(["config", "show", str(config)]) == 0
    data = tomllib.loads(capsys.readouterr().out)
    assert data["body"]["genotype"] == tomllib.loads(config.read_text())["body"]["genotype"]
    assert main(["config", "show", str(tmp_path / "nope.toml")]) == 2
    assert "not found" in one_error_line(capsys, quiet=True)
    assert main(["config", "show", "--set", "brain.nope=1"]) == 2
    assert "brain.nope" in one_error_line(capsys, quiet=True)


def test_to_toml_writes_inline_tables_lists_and_odd_keys() -> None:
    from ariel.cli._config import to_toml

    config = {
        "name": 'a "quoted" name',
        "x": 1.5,
        "t": {"options": {"a b": [1, 2.0, "s"], "nested": {"k": True}}, "none": None},
    }
    data = tomllib.loads(to_toml(config))
    assert data == {
        "name": 'a "quoted" name',
        "x": 1.5,
        "t": {"options": {"a b": [1, 2.0, "s"], "nested": {"k": True}}},
    }


def test_run_help_says_where_the_keys_are_documented(capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(["run", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "docs/evolution.md, 'Configuration keys'" in out and "ariel config show" in out


# --------------------------------------------------------------------------------------------
# make setup: quiet, and pyproject.toml without setuptools' deprecation warning
# --------------------------------------------------------------------------------------------


def test_make_setup_logs_pip_instead_of_printing_it() -> None:
    makefile = (REPO / "Makefile").read_text()
    recipe = makefile.split("$(VENV)/.stamp-setup:", 1)[1].split("\n\n", 1)[0]
    installs = [line for line in recipe.splitlines() if "$(PIP) install" in line]
    assert len(installs) == 3 and all("$(LOGGED)" in line for line in installs)


def test_license_is_an_spdx_string() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT"  # a TOML table is deprecated by setuptools >= 77
