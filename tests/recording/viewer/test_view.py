"""`ariel view`: which recordings it opens, its one-line errors, and its viewer child process:
bound to 127.0.0.1 only, loaded by a real headless browser, and gone after every way the
command can end."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import psutil
import pytest
import rerun as rr
import rerun.blueprint as rrb

from ariel.evolution import run_experiment
from ariel.recording import load_run
from ariel.recording.rerun._rerun import SUMMARY_SERIES, module_colours
from ariel.recording.viewer._browser import HeadlessChromium
from ariel.recording.viewer._view import (
    ViewError,
    best_evaluations,
    recording_path,
    select_recordings,
    web_url,
)
from tests._helpers import ServedWebViewer, exit_code, x_display

CHROMIUM = Path("/usr/bin/chromium")
# A small co-evolution run (like TINY in tests/evolution/test_loop.py): 3 generations, no
# recordings of its own (the tests write stand-ins).
TINY = {
    "name": "tiny",
    "seed": 5,
    "generations": 3,
    "body": {"options": {"number_of_modules": 6}, "population": 3, "offspring": 3},
    "brain": {"popsize": 4, "iterations": 2},
    "task": {"duration": 1.0},
    "executor": {"kind": "serial"},
    "record": {"rerun": False},
}
RED, BLUE = (255, 0, 0), (0, 0, 255)


def _write_rrd(path: Path, recording_id: str, colour: tuple[int, int, int]) -> None:
    """A stand-in recording: one solid-colour image (the browser test looks for its pixels)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream("ariel", recording_id=recording_id)
    rec.save(str(path))
    rec.log("image", rr.Image(np.full((48, 64, 3), colour, dtype=np.uint8)))
    rec.flush()


@pytest.fixture(scope="module")
def bare_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished run made with record.rerun = false: tables, no recordings."""
    out = tmp_path_factory.mktemp("view") / "bare"
    run_experiment(TINY, out=out, progress=False)
    return out


@pytest.fixture(scope="module")
def recorded_run(bare_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same run with a recording per evaluation, run.rrd and blueprint.rbl."""
    out = tmp_path_factory.mktemp("view") / "recorded"
    shutil.copytree(bare_run, out)
    evaluations = load_run(out).evaluations
    best = best_evaluations(evaluations, 1, maximise=True)["eval_id"].iloc[0]
    for generation, eval_id in zip(evaluations["generation"], evaluations["eval_id"]):
        path = recording_path(out, generation, eval_id)
        _write_rrd(path, eval_id, RED if eval_id == best else (40, 40, 40))
    _write_rrd(out / "run.rrd", "run", BLUE)
    rrb.Blueprint(rrb.Spatial2DView(origin="/image")).save("ariel", str(out / "blueprint.rbl"))
    return out


def _ariel(*args: str, env: dict[str, str] | None = None, **kwargs) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "ariel.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        **kwargs,
    )


def _ariel_run(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ariel.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )


def _no_display_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}


# --- which recordings ----------------------------------------------------------------------


def test_the_best_are_ranked_by_fitness_best_first(recorded_run: Path) -> None:
    evaluations = load_run(recorded_run).evaluations
    chosen = select_recordings(recorded_run, best=3)
    ranked = evaluations[evaluations["status"] == "ok"].sort_values("fitness", ascending=False)
    expected = [
        recording_path(recorded_run, g, e)
        for g, e in zip(ranked["generation"][:3], ranked["eval_id"][:3])
    ]
    assert list(chosen.recordings) == expected
    fitness = evaluations.set_index("eval_id").loc[[p.stem for p in chosen.recordings], "fitness"]
    assert list(fitness) == sorted(fitness, reverse=True)
    assert chosen.blueprint == recorded_run / "blueprint.rbl"


def test_best_follows_the_fitness_direction_and_skips_failures() -> None:
    import pandas as pd

    table = pd.DataFrame(
        {
            "eval_id": ["a", "b", "c", "d", "e", "f"],
            "fitness": [0.5, float("inf"), 0.2, 0.5, float("nan"), 0.1],
            "status": ["ok", "ok", "ok", "ok", "ok", "unstable"],
        }
    )
    assert list(best_evaluations(table, 3, maximise=True)["eval_id"]) == ["a", "d", "c"]
    assert list(best_evaluations(table, 3, maximise=False)["eval_id"]) == ["c", "a", "d"]
    assert list(best_evaluations(table, 10, maximise=True)["eval_id"]) == ["a", "d", "c"]


def test_default_is_the_best_evaluation_then_run_rrd(recorded_run: Path) -> None:
    chosen = select_recordings(recorded_run)
    best = select_recordings(recorded_run, best=1).recordings[0]
    # The best evaluation first: the viewer opens on its robot, joints and graph.
    assert chosen.recordings == (best, recorded_run / "run.rrd")
    assert chosen.overview == best
    assert best.stem in chosen.description


def test_a_generation_and_one_evaluation(recorded_run: Path) -> None:
    evaluations = load_run(recorded_run).evaluations
    gen1 = evaluations[evaluations["generation"] == 1]["eval_id"]
    chosen = select_recordings(recorded_run, generation=1)
    assert sorted(p.stem for p in chosen.recordings) == sorted(gen1)
    assert {p.parent.name for p in chosen.recordings} == {"gen-000001"}
    one = gen1.iloc[2]
    assert select_recordings(recorded_run, eval_id=one).recordings == (
        recording_path(recorded_run, 1, one),
    )


def test_the_loop_s_own_recordings_are_found(tmp_path: Path) -> None:
    """With record.rerun on, the files the loop writes are the ones `ariel view` opens."""
    result = run_experiment({**TINY, "record": {"rerun": True}}, out=tmp_path / "run")
    chosen = select_recordings(result.run_dir)
    evaluations = load_run(result.run_dir).evaluations.set_index("eval_id")
    generation = evaluations.loc[result.best_eval_id, "generation"]
    best = recording_path(result.run_dir, generation, result.best_eval_id)
    assert result.best_eval_id.startswith(result.best_body_id)
    assert chosen.recordings == (best, result.run_dir / "run.rrd")
    assert chosen.blueprint == result.run_dir / "blueprint.rbl"
    assert all(p.is_file() for p in select_recordings(result.run_dir, best=5).recordings)
    # A generation: its recording of every evaluation alone (with the elites' replays beside
    # it the viewer would open on one of those), with that recording's own layout.
    generation_0 = select_recordings(result.run_dir, generation=0)
    assert generation_0.recordings == (result.run_dir / "recordings/gen-000000/evaluations.rrd",)
    assert generation_0.more_layouts == (result.run_dir / "generation.rbl",)
    assert generation_0.files == [*generation_0.recordings, *generation_0.more_layouts]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"eval_id": "b999999-i000-c000"}, "no evaluation b999999-i000-c000"),
        ({"eval_id": "../../etc/passwd"}, "not an evaluation id"),
        ({"generation": 7}, "no generation 7"),
        ({"best": 2, "generation": 1}, "choose one of"),
    ],
)
def test_bad_choices_are_view_errors(recorded_run: Path, options: dict, message: str) -> None:
    with pytest.raises(ViewError, match=re.escape(message)):
        select_recordings(recorded_run, **options)


def test_an_evaluation_without_its_own_recording_is_replayed_on_demand(
    recorded_run: Path, tmp_path: Path
) -> None:
    """As a non-elite evaluation of the loop (recorded in its generation's evaluations.rrd
    only): its 3D replay is re-simulated, and without its plugins that is one line."""
    from ariel.recording.resim._replay import has_body_poses

    run = tmp_path / "run"
    shutil.copytree(recorded_run, run)
    victim = select_recordings(run, best=2).recordings[1]
    victim.unlink()
    made = select_recordings(run, best=2).recordings[1]
    assert made == victim.parent / "replays" / victim.name and has_body_poses(made)
    assert select_recordings(run, eval_id=victim.stem).recordings == (made,)
    made.unlink()
    info = json.loads((run / "run.json").read_text())
    info["config"]["brain"]["controller"] = "no_such_controller"
    (run / "run.json").write_text(json.dumps(info))
    with pytest.raises(ViewError, match=r"is not recorded and cannot be replayed"):
        select_recordings(run, best=2)
    with pytest.raises(ViewError, match=rf"evaluation {victim.stem} has no recording and no 3D"):
        select_recordings(run, eval_id=victim.stem)


@pytest.mark.parametrize("link", ["one recording", "recordings folder", "run.rrd"])
def test_a_recording_linked_from_outside_the_run_is_refused(
    recorded_run: Path, tmp_path: Path, link: str
) -> None:
    """A received folder must not make the viewer read a file outside it."""
    run = tmp_path / "run"
    shutil.copytree(recorded_run, run)
    outside = tmp_path / "outside"
    outside.mkdir()
    victim = {
        "one recording": select_recordings(run, best=1).recordings[0],
        "recordings folder": run / "recordings",
        "run.rrd": run / "run.rrd",
    }[link]
    victim.rename(outside / victim.name)
    victim.symlink_to(outside / victim.name)
    with pytest.raises(ViewError, match=r"is a symbolic link \(to .*\); .* remove the link"):
        select_recordings(run)


def test_a_replay_that_cannot_be_written_is_a_view_error(
    recorded_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A run on a read-only file system: no 3D replay can be cached there, said in one line."""
    import errno

    from ariel.recording.viewer import _select

    run = tmp_path / "run"
    shutil.copytree(recorded_run, run)
    victim = select_recordings(run, best=2).recordings[1]
    victim.unlink()

    def read_only(run_dir: Path, eval_id: str) -> Path:
        replays = victim.parent / "replays"
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(replays))

    monkeypatch.setattr(_select, "on_demand_recording", read_only)
    with pytest.raises(ViewError, match=r"cannot be replayed: cannot write .*Read-only file sys"):
        select_recordings(run, best=2)
    with pytest.raises(ViewError, match=r"no 3D replay: cannot write .*Read-only file system"):
        select_recordings(run, eval_id=victim.stem)


# --- the command's one-line errors ----------------------------------------------------------


def _one_line_exit_2(result: subprocess.CompletedProcess, *needles: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for needle in needles:
        assert needle in lines[0]


def test_a_run_without_recordings_is_one_line_exit_2(bare_run: Path) -> None:
    for extra in ([], ["--web"], ["--best", "3"]):
        result = _ariel_run("view", str(bare_run), *extra)
        _one_line_exit_2(result, "no Rerun recordings", "record.rerun")
        assert result.stdout == ""


def test_no_display_without_web_is_one_line_exit_2_suggesting_web(recorded_run: Path) -> None:
    result = _ariel_run("view", str(recorded_run), env=_no_display_env())
    _one_line_exit_2(result, "no display", "--web")


def test_bad_input_is_one_line_exit_2(recorded_run: Path, tmp_path: Path) -> None:
    _one_line_exit_2(_ariel_run("view", str(tmp_path)), "ariel: error:")
    _one_line_exit_2(_ariel_run("view", str(recorded_run), "--best", "0"), "--best")
    _one_line_exit_2(
        _ariel_run("view", str(recorded_run), "b000000-i000-c000", "--best", "2"),
        "choose one of",
    )
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = str(taken.getsockname()[1])
        result = _ariel_run("view", str(recorded_run), "--web", "--port", port)
    _one_line_exit_2(result, f"port {port}", "in use")


# --- the native viewer (a stand-in binary: there is no display here) ------------------------


_DISPLAY: list[str] = []


@pytest.fixture(scope="module", autouse=True)
def _answering_display() -> Iterator[None]:
    """A DISPLAY that answers (`x_display`): the native viewer's tests stand in for one."""
    with x_display() as display:
        _DISPLAY.append(display)
        yield
        _DISPLAY.clear()


def _fake_rerun(tmp_path: Path, body: str) -> dict[str, str]:
    script = tmp_path / "fake-rerun"
    script.write_text(f'#!/bin/sh\necho $$ > {tmp_path}/pid\necho "$@" > {tmp_path}/argv\n{body}\n')
    script.chmod(0o755)
    return {**_no_display_env(), "DISPLAY": _DISPLAY[0], "RERUN_CLI_PATH": str(script)}


def test_native_viewer_gets_the_recordings_and_the_blueprint(recorded_run: Path, tmp_path):
    env = _fake_rerun(tmp_path, "exit 0")
    result = _ariel_run("view", str(recorded_run), "--best", "2", env=env)
    assert result.returncode == 0, result.stderr
    best = select_recordings(recorded_run, best=2).recordings
    argv = [Path(arg) for arg in (tmp_path / "argv").read_text().split()]
    # Copies of the two, in that order, with the run's charts beside; a layout for them.
    *copies, layout = argv
    assert [p.name for p in copies] == [p.name for p in best]
    assert layout.name == "views.rbl"
    assert all(p.parents[1] == layout.parent for p in copies)
    assert layout.parent.name.startswith("ariel-view-") and not layout.exists()  # gone


def test_the_viewer_exit_code_comes_back(recorded_run: Path, tmp_path: Path) -> None:
    result = _ariel_run("view", str(recorded_run), env=_fake_rerun(tmp_path, "exit 3"))
    assert result.returncode == 3


def _eventually(condition, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def _gone(pid: int, timeout: float = 10.0) -> bool:
    """Whether process ``pid`` ended: gone, or a zombie nobody reaped whose threads all ended
    (while other threads still exit, the leader already shows as a zombie)."""

    def ended() -> bool:
        try:
            status = psutil.Process(pid).status()
            if status == psutil.STATUS_ZOMBIE:
                return len(list(Path(f"/proc/{pid}/task").iterdir())) <= 1
            return status == psutil.STATUS_DEAD
        except (psutil.NoSuchProcess, FileNotFoundError):
            return True

    return _eventually(ended, timeout)


def _wait_for(path: Path, timeout: float = 20.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and path.read_text().strip():
            return path.read_text().strip()
        time.sleep(0.05)
    raise AssertionError(f"{path} never appeared")


def test_a_terminated_native_viewer_command_leaves_no_viewer(recorded_run, tmp_path) -> None:
    env = _fake_rerun(tmp_path, "exec sleep 60")
    proc = _ariel("view", str(recorded_run), env=env)
    child = int(_wait_for(tmp_path / "pid"))
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=20) == 128 + signal.SIGTERM
    assert _gone(child)


# --- the web viewer: the real rerun server ---------------------------------------------------


def _ports(url: str) -> tuple[int, int]:
    """The web viewer's port and the gRPC proxy's, from the printed address."""
    web, grpc = re.search(r":(\d+)/\?url=.*%3A(\d+)%2Fproxy$", url).groups()
    return int(web), int(grpc)


def _ports_closed(ports: set[int]) -> bool:
    for port in ports:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return False
    return True


@pytest.mark.parametrize(
    ("signum", "code"),
    [
        (signal.SIGINT, 0),  # Ctrl-C: the normal way to stop serving
        (signal.SIGTERM, 128 + signal.SIGTERM),
        (signal.SIGHUP, 128 + signal.SIGHUP),  # the SSH session dropped
        (signal.SIGKILL, -signal.SIGKILL),  # no handler runs: the kernel's parent-death signal
    ],
)
def test_web_serves_on_localhost_only_and_leaves_nothing_behind(recorded_run, signum, code):
    served = ServedWebViewer(["view", str(recorded_run), "--web"])
    try:
        listening = served.listening()
        ports = {c.laddr.port for c in listening}
        assert {c.laddr.ip for c in listening} == {"127.0.0.1"}
        assert len(ports) == 2
        web, grpc = _ports(served.url)
        assert ports == {web, grpc} and served.url == web_url(web, grpc)
        forwards = re.findall(r"-L (\d+):127\.0\.0\.1:(\d+)", served.tunnel)
        assert sorted(forwards) == sorted((str(p), str(p)) for p in ports)
        assert re.fullmatch(r"ssh -N( -L \S+)+ \S+@\S+", served.tunnel)
        # The recordings and the blueprint are what the server was given.
        cmdline = served.rerun.cmdline()
        assert "--serve-web" in cmdline and "--web-viewer" not in cmdline  # never a browser
        best, _run_rrd = select_recordings(recorded_run).recordings
        # The best evaluation alone (given run.rrd too, the viewer opens on that), as a
        # scratch copy with the run's fitness beside it, and a layout written for it.
        combined, layout = map(Path, cmdline[-2:])
        assert combined.name == best.name and layout.name == "views.rbl"
        assert combined.parents[1] == layout.parent
        assert layout.parent.name.startswith("ariel-view-")
        assert combined.is_file() and layout.is_file()
    finally:
        assert served.stop(signum) == code
    assert _gone(served.rerun.pid)
    if signum != 9:  # SIGKILL leaves the scratch copy in the temporary folder
        assert _eventually(lambda: not layout.parent.exists())
    assert _eventually(lambda: _ports_closed(ports))


def test_the_server_ending_by_itself_ends_the_command(recorded_run, tmp_path) -> None:
    env = {**os.environ, **_fake_rerun(tmp_path, "exit 4")}
    result = _ariel_run("view", str(recorded_run), "--web", "--port", "0", env=env)
    assert result.returncode == 4
    assert "exited with code 4" in result.stderr


# --- a real headless browser opens the served viewer -----------------------------------------


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def _share(image: np.ndarray, colour: tuple[int, int, int]) -> float:
    near = np.abs(image.astype(int) - np.array(colour)).sum(axis=-1) < 60
    return float(near.mean())


def _tinted(image: np.ndarray, colour: tuple[int, int, int]) -> float:
    """The share of pixels drawn in ``colour`` at half to full opacity over white (the viewer
    fills bars translucent)."""
    pixels, target = 255.0 - image.astype(float), 255.0 - np.array(colour, dtype=float)
    opacity = (pixels @ target) / (target @ target)  # the best fit of pixel = opacity x colour
    error = np.abs(pixels - opacity[..., None] * target).max(axis=-1)
    return float(((opacity >= 0.5) & (opacity <= 1.05) & (error < 20)).mean())


@pytest.mark.skipif(not CHROMIUM.exists(), reason=f"{CHROMIUM} missing (apt-get install chromium)")
@pytest.mark.soak  # a headless browser: ~20 s, with the soak tests
def test_a_headless_browser_loads_the_recording_from_the_served_viewer(recorded_run, tmp_path):
    best = select_recordings(recorded_run, best=1).recordings[0].stem
    served = ServedWebViewer(
        ["view", str(recorded_run), "--web"], best
    )  # EVAL_ID after the options
    browser = HeadlessChromium(tmp_path / "profile", binary=CHROMIUM)
    try:
        browser.open(served.url)
        # The viewer's wasm starts: its canvas replaces the loading text (no error shown).
        deadline = time.monotonic() + 60
        state = None
        while time.monotonic() < deadline:
            state = browser.evaluate(
                "[document.title, document.getElementById('the_canvas_id')?.className,"
                " document.getElementById('center_text')?.innerText]"
            )
            if state and state[1] == "visible":
                break
            time.sleep(0.25)
        assert state and state[0] == "Rerun Viewer" and state[1] == "visible", state
        # The browser connected to the gRPC proxy serving the recording...
        _, grpc = _ports(served.url)
        clients = [
            c
            for c in served.rerun.net_connections("inet")
            if c.status == psutil.CONN_ESTABLISHED and c.laddr.port == grpc
        ]
        assert clients, "no browser connection to the gRPC proxy"
        # ...and drew it: the evaluation's copy holds the run's best fitness per generation,
        # drawn as bars in their own colour beside the (stand-in) evaluation.
        share, bars = 0.0, SUMMARY_SERIES["best_fitness"][2][:3]
        while time.monotonic() < deadline and share < 0.003:
            time.sleep(0.5)
            share = _tinted(_pixels(browser.png()), bars)
        assert share >= 0.003, f"the best fitness bars cover {share:.1%} of the page"
    finally:
        browser.close()
        assert served.stop(signal.SIGINT) == 0
    assert _gone(served.rerun.pid)


# --- --screenshot: the viewer drawn by a headless browser, saved ----------------------------


@pytest.mark.skipif(not CHROMIUM.exists(), reason=f"{CHROMIUM} missing (apt-get install chromium)")
@pytest.mark.soak  # a headless browser: ~20 s, with the soak tests
def test_a_screenshot_shows_the_robot_drawn_in_3d(tmp_path: Path) -> None:
    result = run_experiment({**TINY, "record": {"rerun": True}}, out=tmp_path / "run")
    shot = tmp_path / "viewer.png"
    env = {**os.environ, "ARIEL_CHROMIUM": str(CHROMIUM)}
    done = _ariel_run(
        "view",
        str(result.run_dir),
        "--best",
        "1",
        "--screenshot",
        str(shot),
        "--size",
        "960x600",
        env=env,
    )
    assert done.returncode == 0, done.stderr
    assert f"wrote {shot}" in done.stdout
    image = _pixels(shot.read_bytes())
    assert image.shape == (600, 960, 3)
    # The 3D view (top left) shows the robot: its core's colour, shaded by at most ~20%.
    robot_view = image[: 600 // 2, : 960 * 2 // 3]
    assert _share(robot_view, module_colours()["CORE"][:3]) > 0.001

    # Nothing is left behind: no server (its command line names the run's files), no browser
    # (its profile is the scratch folder), no scratch folder.
    def ours(proc: psutil.Process) -> bool:
        with contextlib.suppress(psutil.Error):
            line = " ".join(proc.cmdline())
            return str(result.run_dir) in line or "ariel-screenshot-" in line
        return False

    assert _eventually(lambda: not [p for p in psutil.process_iter() if ours(p)])
    assert not list(Path(tempfile.gettempdir()).glob("ariel-screenshot-*"))


def test_screenshot_bad_input_is_one_line_exit_2(recorded_run: Path, tmp_path: Path) -> None:
    run = str(recorded_run)
    _one_line_exit_2(_ariel_run("view", run, "--screenshot", str(tmp_path / "a.jpg")), ".png")
    _one_line_exit_2(
        _ariel_run("view", run, "--screenshot", str(tmp_path / "no" / "a.png")), "does not exist"
    )
    shot = str(tmp_path / "a.png")
    small = _ariel_run("view", run, "--screenshot", shot, "--size", "10x10")
    _one_line_exit_2(small, "WIDTHxHEIGHT")
    env = {**os.environ, "ARIEL_CHROMIUM": str(tmp_path / "no-browser")}
    _one_line_exit_2(_ariel_run("view", run, "--screenshot", shot, env=env), "ARIEL_CHROMIUM")
    assert not (tmp_path / "a.png").exists()


def test_the_view_recording_is_the_best_evaluation_with_the_run_beside(tmp_path: Path) -> None:
    """`ariel view RUN` opens one recording holding the best evaluation's robot, joints and
    graph (on sim_time) and the run's fitness and diversity per generation (static charts):
    alone, since given run.rrd too the viewer opens on that."""
    from ariel.recording.viewer._view import _prepared

    result = run_experiment({**TINY, "record": {"rerun": True}}, out=tmp_path / "run")
    chosen = select_recordings(result.run_dir)
    with _prepared(chosen) as shown:
        (combined,) = shown.recordings
        assert combined != chosen.overview and combined.name == chosen.overview.name
        reader = rr.chunk.RrdReader(combined)
        (store,) = reader.recordings()
        assert store.recording_id == result.best_eval_id
        found = {c.entity_path: c for c in reader.stream().to_chunks() if c.entity_path != "/"}
        assert "sim_time" in found["/joints/angle"].timeline_names
        assert "/graph" in found and "/world/robot" in found
        best = found["/run/fitness/best"]
        assert best.is_static
        (tensor,) = best.to_record_batch().column("BarChart:values").to_pylist()[0]
        values = tensor["buffer"]
        generations = load_run(result.run_dir).generations
        assert len(values) == len(generations) == TINY["generations"]
        assert values[-1] == pytest.approx(generations["best_fitness"].iloc[-1])
        assert found["/run/diversity/distinct_morphologies"].is_static
    assert not combined.exists()  # a scratch file, gone when the viewer ends


def test_a_screenshot_s_line_is_escaped_and_a_failed_write_is_a_view_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The browser and server stood in for: what `--screenshot` says once it has drawn."""
    import errno

    from ariel.recording.viewer import _web
    from ariel.recording.viewer._select import Selection

    class Browser(contextlib.nullcontext):
        def __enter__(self) -> Browser:
            return self

        def open(self, url: str) -> None:
            pass

    monkeypatch.setattr(_web, "find_chromium", lambda: "chromium")
    monkeypatch.setattr(_web, "_wait_until_serving", lambda *args: True)
    monkeypatch.setattr(_web, "HeadlessChromium", lambda *args, **kwargs: Browser())
    monkeypatch.setattr(_web, "wait_for_drawing", lambda browser, settle: b"\x89PNG")
    monkeypatch.setattr(_web, "_terminate", lambda proc: None)
    monkeypatch.setattr(_web, "_run_child", lambda command, when_started: when_started(None))
    monkeypatch.setattr(_web, "web_command", lambda *args: [])
    folder = tmp_path / "r\x1b[2J"
    folder.mkdir()
    chosen = Selection(folder, (), None, "the best evaluation \x1b]0;t\x07")
    assert _web._screenshot(chosen, tmp_path / "s.png", (320, 240), 0.0) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "r\\x1b[2J" in out
    assert (tmp_path / "s.png").read_bytes() == b"\x89PNG"

    def read_only(path: Path, data: bytes, **kwargs: object) -> None:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))

    monkeypatch.setattr(_web, "atomic_write_bytes", read_only)
    with pytest.raises(ViewError, match=r"--screenshot: cannot write .*Read-only file system"):
        _web._screenshot(chosen, tmp_path / "t.png", (320, 240), 0.0)


def test_a_screenshot_into_a_folder_that_cannot_be_written_is_refused_first(
    recorded_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.setattr(os, "access", lambda path, mode: False)  # as on a read-only mount
    argv = ["view", str(recorded_run), "--screenshot", str(tmp_path / "s.png")]
    assert exit_code(argv) == 2
    assert "cannot be written" in capsys.readouterr().err
