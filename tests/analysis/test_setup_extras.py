"""What `make setup` installs (dry runs of the Makefile, nothing installed): the analysis extra
with nbconvert (the notebooks' headless command) always; the GPU extra (MuJoCo Warp, ~0.4 GB)
only where `nvidia-smi` finds a GPU, where .venv has it already, or when asked, as CI asks."""

from __future__ import annotations

import os
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MAKE = shutil.which("make")
pytestmark = pytest.mark.skipif(MAKE is None, reason="no make on PATH")


def _dry_run(tmp_path: Path, *args: str, nvidia_smi: bool = False, stamp: bool = False) -> str:
    """`make -n setup ARGS` in a copy of the Makefile with no .venv (nothing is run)."""
    work = tmp_path / "checkout"
    work.mkdir(exist_ok=True)
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy(REPO / name, work)
    if stamp:
        (work / ".venv").mkdir(exist_ok=True)
        (work / ".venv" / ".stamp-gpu").touch()
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    fake = bin_dir / "nvidia-smi"
    fake.unlink(missing_ok=True)
    if nvidia_smi:
        fake.write_text("#!/bin/sh\necho 'GPU 0: NVIDIA H100 (UUID: GPU-0)'\n")
        fake.chmod(0o755)
    # PATH holds the fake nvidia-smi (or none, even on a machine with a GPU) and uname only.
    uname = bin_dir / "uname"
    if not uname.exists():
        uname.symlink_to(shutil.which("uname"))
    path = str(bin_dir)
    drop = ("GPU", "MAKEFLAGS", "MAKELEVEL", "TORCH_SPEC", "VENV", "PYTHON")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    done = subprocess.run(
        [MAKE, "-n", "setup", *args],
        cwd=work,
        env={**env, "PATH": path},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _installs(out: str) -> list[str]:
    return [
        line.split("install", 1)[1].split(">>")[0].strip()
        for line in out.splitlines()
        if "/pip install" in line
    ]


def test_the_default_setup_is_cpu_only_with_the_notebook_tools(tmp_path: Path) -> None:
    out = _dry_run(tmp_path)
    assert _installs(out) == [
        "--upgrade pip",
        '"torch==2.13.0"',
        '-e ".[dev,distributed,analysis,docs]"',
    ]
    assert "the GPU extra: make gpu" in out.splitlines()[0]
    assert ".stamp-gpu" not in out
    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    assert any(req.startswith("nbconvert") for req in extras["analysis"])
    assert not any(
        "warp" in req for name in ("dev", "distributed", "analysis", "docs") for req in extras[name]
    )


@pytest.mark.parametrize(
    ("args", "nvidia_smi", "stamp"),
    [(("GPU=1",), False, False), ((), True, False), ((), False, True)],
    ids=["asked", "nvidia-smi-finds-a-gpu", "installed-before"],
)
def test_the_gpu_extra_where_asked_found_or_installed_before(
    tmp_path: Path, args: tuple[str, ...], nvidia_smi: bool, stamp: bool
) -> None:
    installs = _installs(_dry_run(tmp_path, *args, nvidia_smi=nvidia_smi, stamp=stamp))
    assert installs[-1] == '-e ".[gpu]"' and len(installs) == 4


def test_gpu_0_leaves_it_out_even_with_a_gpu(tmp_path: Path) -> None:
    assert '".[gpu]"' not in _dry_run(tmp_path, "GPU=0", nvidia_smi=True)


def test_ci_installs_the_gpu_extra_so_the_warp_tests_run() -> None:
    ci = (REPO / ".ci" / "run").read_text()
    lines = [line for line in ci.splitlines() if line.startswith("make test")]
    assert lines and all("GPU=1" in line for line in lines)
    assert 'python -c "import mujoco_warp, warp"' in ci  # fails before the tests could skip


def test_make_alone_lists_the_targets_and_sets_up_nothing(tmp_path: Path) -> None:
    """`make` with no target set up .venv and said only "'.venv/.stamp-setup' is up to date"."""
    work = tmp_path / "alone"
    work.mkdir()
    shutil.copy(REPO / "Makefile", work)
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL")}
    done = subprocess.run([MAKE], cwd=work, env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0].startswith("make run ")
    assert "make test " in done.stdout and not (work / ".venv").exists()
