"""Bad input to the benchmarks that read a run (science.py, gallery.py) is one line, exit 2,
as from the ``ariel`` command: it was a traceback (probe Z)."""

from __future__ import annotations

from pathlib import Path

import pytest
from _helpers import run_benchmark


@pytest.mark.parametrize(
    ("script", "args", "said"),
    [
        ("gallery.py", ["missing"], "gallery.py: error: 'missing' is not an ariel run folder"),
        ("science.py", ["--set", "foo=bar"], "science.py: error: --set foo: no such key"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path: Path, script: str, args: list, said: str) -> None:
    result = run_benchmark(script, *args, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith(said) and result.stderr.count("\n") == 1, result.stderr


@pytest.fixture(scope="module")
def brain_only(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny brain-only run of one CMA-ES iteration per generation (no learning gain)."""
    from ariel.evolution import run_experiment

    config = {
        "name": "one-body",
        "generations": 1,
        "body": {"encoder": "prebuilt", "genotype": "gecko"},
        "brain": {"popsize": 2, "iterations": 1},
        "task": {"duration": 0.3, "settle": 0.0},
        "record": {"rerun": False},
        "executor": {"kind": "serial"},
    }
    out = tmp_path_factory.mktemp("benchmarks") / "run"
    run_experiment(config, out=out, progress=False)
    return out


def test_gallery_of_a_brain_only_run_is_the_scripts_one_line(brain_only: Path, tmp_path: Path):
    """It was a bare 'RUN: fewer than 2 bodies that were built', exit 1."""
    result = run_benchmark("gallery.py", str(brain_only), cwd=tmp_path)
    assert result.returncode == 2
    assert (
        result.stderr.startswith("gallery.py: error: ") and "fewer than 2 bodies" in result.stderr
    )


def test_science_prints_strict_json_without_nan(brain_only: Path, tmp_path: Path) -> None:
    """A learning gain of NaN was printed as a bare NaN, which JSON.parse refuses."""
    import json

    result = run_benchmark("science.py", str(brain_only), cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    last = result.stdout.strip().splitlines()[-1]
    figures = json.loads(last, parse_constant=lambda name: pytest.fail(f"{name} in {last}"))
    assert None in figures.values()  # the gains that need a second iteration: null


def test_gpu_benchmark_without_cuda_names_its_own_options(tmp_path: Path) -> None:
    """It said to add --set executor.device=cpu, an option of ariel run, not of gpu.py."""
    pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
    from ariel.evaluation._warp_runtime import cuda_available

    if cuda_available():
        pytest.skip("a CUDA device is here")
    result = run_benchmark("gpu.py", cwd=tmp_path)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert (
        result.stderr.startswith("gpu.py: error: no CUDA device")
        and "--device cpu" in result.stderr
    )
    assert "--set" not in result.stderr


def test_the_watch_screenshot_stops_when_its_run_fails(tmp_path: Path) -> None:
    """Its run ended at once (here: a GL backend that does not exist) and the script waited
    for the run's folder for good, leaving its scratch folder behind."""
    import os
    import subprocess
    import sys

    script = Path(__file__).parents[2] / "experiments" / "screenshots" / "watch.py"
    env = {**os.environ, "MUJOCO_GL": "bogus", "TMPDIR": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "shot.png")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    assert done.stderr.strip().endswith(
        "watch.py: error: the run ended (exit 2) before its folder was made"
    )
    assert not list(tmp_path.glob("ariel-watch-shot-*"))


def test_gpu_benchmark_names_the_coevolution_form(tmp_path: Path) -> None:
    """It said "invalid literal for int() with base 10: 'foo'"."""
    result = run_benchmark("gpu.py", "--coevolution", "foo", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == (
        "gpu.py: error: --coevolution takes KxP, e.g. 32x1024, not 'foo'"
    )
