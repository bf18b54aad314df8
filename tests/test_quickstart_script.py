"""Smoke test of experiments/quickstart.py (the quick-start tutorial flow as a script)."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import pytest
from PIL import Image

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "quickstart.py"


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    if sys.platform == "linux":
        env.setdefault("MUJOCO_GL", "egl")
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=300,
    )


def test_quickstart_script_writes_plot_and_video(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = _run("--duration", "2", "--video-seconds", "0.5", "--out", str(out), cwd=tmp_path)
    if result.returncode != 0 and "no OpenGL backend" in result.stderr:
        pytest.skip("no OpenGL backend for the video on this machine")
    assert result.returncode == 0, result.stderr[-3000:]
    stdout = result.stdout
    assert "quick-start tutorial flow" in stdout
    assert "simulated 2.00 s (8 actuators, CPG seed 42)" in stdout
    displacement = float(re.search(r"displacement of the core: ([\d.]+) m", stdout).group(1))
    assert math.isfinite(displacement)

    plot = Path(re.search(r"trajectory plot: (\S+)", stdout).group(1))
    if not plot.is_absolute():
        plot = tmp_path / plot
    assert plot.parent == out and plot.is_file()
    with Image.open(plot) as image:
        assert image.width > 400 and image.height > 400

    video = Path(re.search(r"video \(15 frames, 0.5 s\): (\S+)", stdout).group(1))
    assert video.parent == out and video.suffix == ".mp4"
    reader = imageio_ffmpeg.read_frames(str(video))
    meta = next(reader)
    assert meta["size"] == (640, 480) and meta["codec"] == "h264"
    assert sum(1 for _ in reader) == 15


def test_quickstart_script_is_seeded(tmp_path: Path) -> None:
    runs = [
        _run("--duration", "1", "--no-video", "--seed", "7", "--out", "o", cwd=tmp_path)
        for _ in range(2)
    ]
    assert all(run.returncode == 0 for run in runs), runs[0].stderr[-3000:]
    lines = [re.search(r"displacement of the core: .*", run.stdout).group(0) for run in runs]
    assert lines[0] == lines[1]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--duration", "-1"], "--duration must be above 0 and at most 3600 seconds, not -1.0"),
        (["--duration", "1e20"], "--duration must be above 0 and at most 3600 seconds, not 1e"),
        (["--seed", "x"], "argument --seed: invalid int value: 'x'"),
        (["--out", ""], "argument --out: an empty path; give a folder such as data/quickstart"),
        (["--out", "a-file"], "--out 'a-file' is a file, not a folder"),
    ],
)
def test_quickstart_script_refuses_bad_options_in_one_line(
    tmp_path: Path, args: list[str], message: str
) -> None:
    """Each was one line and exit 2 (not a usage block, a FileExistsError traceback or an
    unbounded run), before anything is simulated."""
    (tmp_path / "a-file").write_text("")
    result = _run("--no-video", "--out", "o", *args, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and message in result.stderr, result.stderr


def test_quickstart_never_writes_into_a_run_folder(tmp_path: Path) -> None:
    """`--out RUN` put its PNG and MP4 among a run's records."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text("{}")
    result = _run("--no-video", "--out", str(run / "sub"), cwd=tmp_path)
    assert result.returncode == 2 and "is inside the run or campaign" in result.stderr
    assert sorted(p.name for p in run.iterdir()) == ["run.json"]
