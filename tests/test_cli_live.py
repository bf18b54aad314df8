"""``ariel run --live``: the watcher starts as a child once the run folder is made, the run never
waits for it and writes the same records, Ctrl-C ends both, and the command waits for the view
after the run. `LiveView` is tested with a stand-in watcher; the commands with the real one,
headless (``ARIEL_WATCH_ARGS=--no-viewer --save FILE``)."""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ariel.cli._live import WATCH_ARGS_ENV, LiveView

RUN = Path(__file__).resolve().parent / "data" / "run_tiny.toml"
# A stand-in watcher: says it started (a file outside the folder), then waits to be stopped or
# for a file telling it to end (the view's window closed).
FAKE_WATCHER = (
    "import pathlib, sys, time\n"
    "flag = pathlib.Path(sys.argv[2])\n"
    "flag.write_text(sys.argv[1])\n"
    "while not flag.with_suffix('.close').exists():\n"
    "    time.sleep(0.05)\n"
)


def _wait_for(condition, timeout: float = 30.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


def _live(monkeypatch: pytest.MonkeyPatch, flag: Path) -> LiveView:
    monkeypatch.setenv(WATCH_ARGS_ENV, "--no-viewer")  # no display needed
    view = LiveView(argparse.Namespace(live=True, web=False))
    command = [sys.executable, "-c", FAKE_WATCHER]
    monkeypatch.setattr(view, "command", lambda folder: [*command, str(folder), str(flag)])
    return view


def test_the_watcher_starts_once_the_folder_is_made_and_the_command_waits_for_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    folder, flag = tmp_path / "run", tmp_path / "started"
    view = _live(monkeypatch, flag)
    view.start(folder)
    time.sleep(0.5)
    assert not flag.exists() and view.proc is not None and view.proc.poll() is None  # waiting
    folder.mkdir()
    (folder / "run.json").write_text("{}")
    assert _wait_for(flag.exists)
    assert flag.read_text() == str(folder)
    flag.with_suffix(".close").touch()  # the user closes the view's window
    assert view.finish(0) == 0
    assert "the live view stays open until you close its window" in capsys.readouterr().err
    assert view.proc.returncode == 0


def test_an_interrupted_or_failed_run_stops_the_view(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    for code, interrupted in ((130, True), (2, False)):
        flag = tmp_path / f"started-{code}"
        view = _live(monkeypatch, flag)
        view.start(folder)
        (folder / "run.json").write_text("{}")  # written (again) once it started
        assert _wait_for(flag.exists)
        view.interrupted = interrupted
        assert view.finish(code) == code
        assert view.proc is not None and view.proc.returncode is not None  # stopped, reaped


def test_no_live_view_starts_nothing_and_one_without_a_display_refuses_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    view = LiveView(argparse.Namespace(live=False, web=False))
    assert view.run_folder(None, None, []) is None
    view.start(tmp_path)
    assert view.proc is None and view.finish(0) == 0
    web = LiveView(argparse.Namespace(live=False, web=True))
    assert web.enabled and "--web" in web.command(tmp_path)
    for name in ("DISPLAY", "WAYLAND_DISPLAY", WATCH_ARGS_ENV):
        monkeypatch.delenv(name, raising=False)
    command = ["run", str(RUN), "--out", str(tmp_path / "r"), "--live"]
    result = subprocess.run(
        [sys.executable, "-m", "ariel.cli", *command],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and "--live: no display" in result.stderr
    assert not (tmp_path / "r").exists()  # refused before anything was written


# --- the commands, with the real watcher ---------------------------------------------------------


def _ariel(*args: str, env: dict[str, str] | None = None, **popen: object) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "ariel.cli", *args],
        env={**os.environ, **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,  # type: ignore[call-overload]
    )


def _watch_args(saved: Path, *more: str) -> dict[str, str]:
    return {WATCH_ARGS_ENV: f"--no-viewer --save {saved} {' '.join(more)}"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The tiny run (3 generations) with and without --live, in folders of the same name."""
    root = tmp_path_factory.mktemp("live")
    found, procs = {}, []
    saved = root / "watch.rrd"
    for kind in ("plain", "live"):  # side by side: the watcher only reads its own folder
        out = root / kind / "tiny"
        live = ["--live"] if kind == "live" else []
        procs.append(
            _ariel(
                "run",
                str(RUN),
                "--set",
                "generations=3",
                "--out",
                str(out),
                "--quiet",
                *live,
                env=_watch_args(saved, "--until-finished"),
            )
        )
        found[kind] = out
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    found["saved"] = saved
    return found


def test_live_writes_the_same_records_and_the_watcher_saw_every_generation(
    runs: dict[str, Path],
) -> None:
    from ariel.recording import load_run

    plain, live = load_run(runs["plain"]), load_run(runs["live"])
    assert live.info["status"] == "finished"
    assert live.generations.equals(plain.generations)
    columns = ["eval_id", "body_id", "generation", "fitness", "status"]
    assert live.evaluations[columns].equals(plain.evaluations[columns])
    assert sorted(p.name for p in runs["live"].iterdir()) == sorted(
        p.name for p in runs["plain"].iterdir()
    )  # nothing of the watcher's in the folder
    from rerun.chunk import RrdReader

    shown = set()  # the generations the watcher logged, from its saved recording
    for chunk in RrdReader(runs["saved"]).stream().to_chunks():
        if chunk.entity_path == "/fitness/best" and not chunk.is_static:
            shown.update(chunk.to_record_batch().column("generation").to_pylist())
    assert shown == {0, 1, 2}


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def test_ctrl_c_ends_the_run_and_its_watcher(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = _ariel(
        "run",
        str(RUN),
        "--set",
        "generations=200",
        "--out",
        str(out),
        "--quiet",
        "--live",
        env=_watch_args(tmp_path / "watch.rrd"),
        start_new_session=True,  # its own process group, as a terminal's job
    )
    try:
        assert _wait_for(lambda: (out / "manifests" / "gen-000000.json").is_file(), 120)
        saved = tmp_path / "watch.rrd"  # the watcher runs: it has logged to its file
        assert _wait_for(lambda: saved.is_file() and saved.stat().st_size > 0)
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the terminal signals the whole group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err
    assert _wait_for(lambda: not _group_alive(proc.pid), 15), "a child was left behind"
