"""Pieces the benchmark scripts share: thread limits, options, config overrides, load average,
timing, versions and the GPU.

A benchmark runs as a script (``python experiments/benchmarks/x.py``), which puts this folder
first on ``sys.path``, so the scripts import this module as ``_common``; so do the processes a
script's pool starts (they get the script's ``sys.path``). It imports only the standard
library: the pool's workers import the script, and with it this module, and a worker should
hold no more than a worker of ``ariel run`` holds.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import math
import os
import platform
import shutil
import subprocess
import sys
from collections.abc import Callable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn

THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)


def exit_with(main: Callable[[], int]) -> NoReturn:
    """Run a benchmark's ``main`` and exit with its code; bad input that ariel refuses (a
    folder that is no run, a bad ``--set``) is one line on stderr and exit code 2, as from
    the ``ariel`` command, not a traceback."""
    from ariel.errors import ArielError

    try:
        code = main()
    except ArielError as exc:
        print(f"{Path(sys.argv[0]).name}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        raise SystemExit(2) from None
    raise SystemExit(code)


def one_blas_thread() -> None:
    """One BLAS/OpenMP thread, as in the engine's workers: call before numpy is imported.

    The pools read these variables once, when they load. A second spinning library thread
    would compete with MuJoCo's rollout threads for the same cores and make the figures noisy.
    """
    for variable in THREAD_VARIABLES:
        os.environ[variable] = "1"


def load_average() -> tuple[float, float, float] | None:
    """1, 5 and 15 minute load averages (None where the system does not keep them)."""
    try:
        return os.getloadavg()
    except (AttributeError, OSError):
        return None


# --- the machine ------------------------------------------------------------------------------


def versions(**distributions: str) -> dict[str, str | None]:
    """Python's version and each installed distribution's (``name="dist-name"``; None: absent)."""
    found: dict[str, str | None] = {"python": platform.python_version()}
    for name, distribution in distributions.items():
        try:
            found[name] = metadata.version(distribution)
        except metadata.PackageNotFoundError:
            found[name] = None
    return found


def utc_now() -> str:
    """The date and time now, UTC, ISO 8601 to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def nvidia_card(index: int = 0) -> dict[str, str] | None:
    """``nvidia-smi``'s name, memory.total and driver_version of GPU ``index`` (its order: PCI
    bus order); None where nvidia-smi is absent or fails."""
    smi = shutil.which("nvidia-smi")
    if smi is None:
        return None
    query = ["--query-gpu=name,memory.total,driver_version", "--format=csv,noheader"]
    try:
        done = subprocess.run([smi, *query], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    lines = [line for line in done.stdout.splitlines() if line.count(",") >= 2]
    if done.returncode != 0 or not lines:
        return None
    name, memory, driver = (
        part.strip() for part in lines[min(index, len(lines) - 1)].rsplit(",", 2)
    )
    return {"name": name, "memory": memory, "driver_version": driver, "source": "nvidia-smi"}


# --- timing -----------------------------------------------------------------------------------


def best_of(repeats: int, sample: Callable[[], float]) -> float:
    """The least of ``repeats`` calls of ``sample`` (seconds), each after a garbage collection."""
    times = []
    for _ in range(repeats):
        gc.collect()
        times.append(sample())
    return min(times)


def rates(prefix: str, seconds: float, worlds: int, steps: int) -> dict[str, float]:
    """``worlds`` simulations of ``steps`` steps each in ``seconds``: evaluations/s, steps/s,
    seconds and ``ns_per_world_step`` (seconds x 1e9 / (worlds x steps)), keys prefixed."""
    return {
        f"{prefix}evals_per_s": worlds / seconds,
        f"{prefix}steps_per_s": worlds * steps / seconds,
        f"{prefix}seconds": seconds,
        f"{prefix}ns_per_world_step": seconds * 1e9 / (worlds * steps),
    }


# --- options ----------------------------------------------------------------------------------


def add_quick_option(parser: argparse.ArgumentParser, quick: Mapping[str, Any]) -> None:
    parser.add_argument(
        "--quick",
        action="store_true",
        help="tiny smoke run: "
        + ", ".join(f"{k} {v}" for k, v in quick.items())
        + " (overrides those options)",
    )


def apply_quick(args: argparse.Namespace, quick: Mapping[str, Any]) -> None:
    """With ``--quick``, the smoke run's settings replace the options' values."""
    if args.quick:
        for name, value in quick.items():
            setattr(args, name, value)


def check_at_least(
    parser: argparse.ArgumentParser, args: argparse.Namespace, minimum: int, *names: str
) -> None:
    """Exits (code 2) naming the first of ``names`` set below ``minimum``; None is allowed."""
    for name in names:
        value = getattr(args, name)
        if value is not None and value < minimum:
            option = name.replace("_", "-")
            parser.error(f"--{option} must be an integer >= {minimum}, got {value}")


def check_seconds(parser: argparse.ArgumentParser, args: argparse.Namespace, *names: str) -> None:
    """Exits (code 2) naming the first of ``names`` that is not a finite number > 0."""
    for name in names:
        value = getattr(args, name)
        if value is not None and not (math.isfinite(value) and value > 0):
            parser.error(f"--{name} must be > 0 seconds, got {value}")


def check_seed(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    if args.seed is not None and args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """The size and executor of a run of ``experiments/coevolve_flat.toml`` (None: the config's)."""
    parser.add_argument("--generations", type=int, default=None, help="default: the config's")
    parser.add_argument("--population", type=int, default=None, help="body.population")
    parser.add_argument("--offspring", type=int, default=None, help="body.offspring")
    parser.add_argument("--popsize", type=int, default=None, help="brain.popsize")
    parser.add_argument("--iterations", type=int, default=None, help="brain.iterations")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds")
    parser.add_argument(
        "--bodies",
        choices=("all", "elites", "none"),
        default=None,
        help="record.bodies (default: the config's, elites)",
    )
    parser.add_argument(
        "--executor",
        choices=("serial", "local", "dask"),
        default=None,
        help="default: the config's (local)",
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes (default: one per CPU)"
    )


def run_overrides(args: argparse.Namespace) -> list[str]:
    """Config overrides (``key=value``) for the options of `add_run_options` and ``--seed``."""
    overrides = [f'record.bodies="{args.bodies}"'] if args.bodies else []
    for key, value in (
        ("seed", args.seed),
        ("generations", args.generations),
        ("body.population", args.population),
        ("body.offspring", args.offspring),
        ("brain.popsize", args.popsize),
        ("brain.iterations", args.iterations),
        ("task.duration", args.duration),
        ("executor.kind", args.executor and f'"{args.executor}"'),
    ):
        if value is not None:
            overrides.append(f"{key}={value}")
    return overrides
