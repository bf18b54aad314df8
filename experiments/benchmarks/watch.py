"""Live view benchmark: how soon ``ariel watch`` shows a generation, what ``--live`` costs a run,
and whether the watcher's memory grows with the generations it follows.

Runs of ``experiments/coevolve_flat.toml`` (the default experiment; ``--generations``,
``--population``, ``--offspring``, ``--popsize``, ``--iterations``, ``--duration`` scale it
down), each ``ariel run`` in a child process into a temporary folder deleted afterwards.

(a) Latency. One run of ``--generations`` (default 50) generations, followed by a watcher in
this process (`ariel.recording.watch`, no viewer, saving to a temporary ``.rrd``) polled every
``--poll`` seconds as ``ariel watch`` polls. Before each poll the benchmark lists the
manifests there (``manifests/gen-NNNNNN.json``, written once a generation's tables are); each
generation's latency is from its manifest's mtime to the end of the first poll that started
after it was there: the moment the watcher had logged it. Median and max over the
generations, seconds; target: median <= 2 s. The saved recording is read back to check that
every generation was logged.

(c) Memory, in the same run: this process's peak RSS (``ru_maxrss``; it does nothing but watch
while the run goes) once the watcher has followed ``--memory-at`` (default 10) generations, and
at the end; growth between them, MB. The watcher keeps a few numbers per generation and per
body, and sends only what is new: the target is no growth beyond noise (reported, with the
recording's bytes for scale).

(b) Overhead. The same run (``--ratio-generations``, default 10) with ``ariel run --live``
(the watcher as a child, no viewer, saving to a temporary file: ``ARIEL_WATCH_ARGS=--no-viewer
--save FILE --until-finished``) and without; ``--repeats`` rounds (default 3), alternating
which goes first. The figure is the run's own wall time (run.json's ``wall_seconds``: the
driver's, from start to the last generation), median over rounds of with / without; target
<= 1.03. The commands' wall times (which with ``--live`` include the watcher noticing the end)
are reported too. Both runs have the same seed: their fitness columns are checked equal.

Prints a table, then as the last line one JSON object with ``latency_median_s``,
``latency_max_s``, ``live_overhead_ratio``, ``rss_growth_mb`` and context. Numbers depend on the
machine's load (its load average is printed).

    python experiments/benchmarks/watch.py [--generations 50] [--memory-at 10]
        [--ratio-generations 10] [--repeats 3] [--poll 0.5] [--population N] [--offspring N]
        [--popsize N] [--iterations N] [--duration S] [--executor serial|local] [--workers N]
        [--seed 1] [--quick]
"""

from __future__ import annotations

from _common import (
    add_quick_option,
    add_run_options,
    apply_quick,
    check_at_least,
    check_seconds,
    check_seed,
    load_average,
    one_blas_thread,
    run_overrides,
    utc_now,
    versions,
)

one_blas_thread()

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "coevolve_flat.toml"
LATENCY_TARGET = 2.0  # median seconds from a manifest's write to the watcher having logged it
RATIO_TARGET = 1.03  # run wall time with --live / without
QUICK = {
    "generations": 4,
    "memory_at": 2,
    "ratio_generations": 2,
    "repeats": 1,
    "population": 2,
    "offspring": 2,
    "popsize": 2,
    "iterations": 1,
    "duration": 0.3,
    "executor": "serial",
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_options(parser)
    parser.set_defaults(generations=50)
    parser.add_argument(
        "--memory-at",
        type=int,
        default=10,
        help="generations followed at the first memory reading (default 10)",
    )
    parser.add_argument(
        "--ratio-generations",
        type=int,
        default=10,
        help="generations of each run timed with and without --live (default 10)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="rounds of (with, without)")
    parser.add_argument("--poll", type=float, default=0.5, help="the watcher's poll, seconds")
    parser.add_argument("--seed", type=int, default=None, help="default: the config's (1)")
    add_quick_option(parser, QUICK)
    args = parser.parse_args(argv)
    apply_quick(args, QUICK)
    names = ("generations", "memory_at", "ratio_generations", "repeats", "population")
    check_at_least(parser, args, 1, *names, "offspring", "iterations", "workers")
    check_at_least(parser, args, 2, "popsize")
    check_seconds(parser, args, "duration", "poll")
    check_seed(parser, args)
    if args.memory_at > args.generations:
        parser.error("--memory-at must be at most --generations")
    return args


def start_run(
    args: argparse.Namespace, out: Path, generations: int, *, live: Path | None = None
) -> subprocess.Popen[bytes]:
    """``ariel run`` of the benchmark's experiment into ``out``; ``live``: with ``--live``,
    the watcher saving to that file."""
    overrides = [*run_overrides(args), f"generations={generations}"]
    sets = [part for value in overrides for part in ("--set", value)]
    command = [sys.executable, "-m", "ariel.cli", "run", str(CONFIG), "--out", str(out)]
    env = dict(os.environ)
    if live is not None:
        command.append("--live")
        watch = f"--no-viewer --save {live} --until-finished --poll {args.poll}"
        env["ARIEL_WATCH_ARGS"] = watch
    if args.workers:
        command += ["--workers", str(args.workers)]
    return subprocess.Popen(
        [*command, *sets, "--quiet"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )


def _ended(proc: subprocess.Popen[bytes]) -> None:
    _, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"benchmark: the run failed ({proc.returncode}): {err.decode()[-2000:]}")


def _manifests(run_dir: Path) -> dict[int, float]:
    """generation -> its manifest's mtime."""
    found = {}
    for path in (run_dir / "manifests").glob("gen-*.json"):
        try:
            found[int(path.stem[4:])] = path.stat().st_mtime
        except (OSError, ValueError):
            continue
    return found


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux


def follow(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    """(a) and (c): one run, followed by a watcher in this process."""
    from ariel.recording import watch

    out, saved = tmp / "followed", tmp / "followed.rrd"
    proc = start_run(args, out, args.generations)
    while not (out / "run.json").is_file():
        if proc.poll() is not None:
            _ended(proc)
        time.sleep(0.05)
    latency: dict[int, float] = {}
    rss_at: float | None = None
    polls: list[float] = []
    watcher = watch(out, viewer="none", save=saved, poll_s=args.poll)
    try:
        while True:
            ended = proc.poll() is not None  # before the listing: then it is the last one
            there = _manifests(out)
            started = time.perf_counter()
            watcher.poll()
            now = time.time()
            polls.append(time.perf_counter() - started)
            for generation, written in there.items():
                latency.setdefault(generation, now - written)
            if rss_at is None and len(latency) >= args.memory_at:
                rss_at = _peak_rss_mb()
            if ended:
                break
            time.sleep(args.poll)
    finally:
        watcher.close()
    _ended(proc)
    shown = _generations_logged(saved)
    if shown != args.generations or len(latency) != args.generations:
        raise RuntimeError(f"benchmark: {shown} generations logged, not {args.generations}")
    values = [latency[g] for g in sorted(latency)]
    return {
        "latency_median_s": statistics.median(values),
        "latency_max_s": max(values),
        "latency_s": [round(v, 3) for v in values],
        "poll_median_ms": statistics.median(polls) * 1e3,
        "rss_mb_at_memory_at": rss_at,
        "rss_mb_at_end": _peak_rss_mb(),
        "saved_bytes": saved.stat().st_size,
    }


def _generations_logged(saved: Path) -> int:
    """How many generations the saved recording has best fitness for."""
    from rerun.chunk import RrdReader

    found: set[int] = set()
    for chunk in RrdReader(saved).stream().to_chunks():
        batch = chunk.to_record_batch()
        if chunk.entity_path == "/fitness/best" and "generation" in batch.schema.names:
            found.update(batch.column("generation").to_pylist())
    return len(found)


def timed_run(args: argparse.Namespace, out: Path, live: Path | None) -> dict[str, Any]:
    """(b): one run, with or without --live: the command's and the run's own wall time."""
    started = time.perf_counter()
    proc = start_run(args, out, args.ratio_generations, live=live)
    _ended(proc)
    seconds = time.perf_counter() - started
    from ariel.recording import load_run

    run = load_run(out)
    return {
        "command_seconds": seconds,
        "run_seconds": float(run.info["wall_seconds"]),
        "fitness": run.evaluations["fitness"].reset_index(drop=True),
    }


def overhead(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    """(b), ``--repeats`` rounds alternating which run goes first."""
    withs: list[dict[str, Any]] = []
    withouts: list[dict[str, Any]] = []
    for round_ in range(args.repeats):
        order = [("without", withouts, None), ("with", withs, tmp / f"live-{round_}.rrd")]
        for label, samples, live in order if round_ % 2 == 0 else order[::-1]:
            samples.append(timed_run(args, tmp / f"{label}-{round_}" / "run", live))
            print(
                f"  round {round_ + 1}, {label} --live: run {samples[-1]['run_seconds']:.2f} s, "
                f"command {samples[-1]['command_seconds']:.2f} s",
                flush=True,
            )
    for a, b in zip(withs, withouts):
        if not a["fitness"].equals(b["fitness"]):
            raise RuntimeError("benchmark: the runs with and without --live differ")
    ratios = [a["run_seconds"] / b["run_seconds"] for a, b in zip(withs, withouts)]
    commands = [a["command_seconds"] / b["command_seconds"] for a, b in zip(withs, withouts)]
    return {
        "live_overhead_ratio": statistics.median(ratios),
        "live_overhead_ratios": [round(r, 4) for r in ratios],
        "command_ratio": statistics.median(commands),
        "run_seconds_without": statistics.median(b["run_seconds"] for b in withouts),
        "run_seconds_with": statistics.median(a["run_seconds"] for a in withs),
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    load_before = load_average()
    print(
        f"ARIEL live view benchmark: {CONFIG.name} ({' '.join(run_overrides(args)) or 'as is'}); "
        f"follow {args.generations} generations (memory at {args.memory_at}), poll "
        f"{args.poll:g} s; --live overhead on {args.ratio_generations} generations x "
        f"{args.repeats} rounds; load average {load_before}",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="ariel-watch-bench-") as scratch:
        tmp = Path(scratch)
        followed = follow(args, tmp)
        print(f"  followed {args.generations} generations", flush=True)
        timed = overhead(args, tmp)
    growth = followed["rss_mb_at_end"] - followed["rss_mb_at_memory_at"]

    def row(label: str, value: str, target: str = "", ok: bool | None = None) -> None:
        verdict = "" if ok is None else ("ok" if ok else "MISSED")
        print(f"{label:<56}{value:>14}  {target} {verdict}".rstrip())

    median, most = followed["latency_median_s"], followed["latency_max_s"]
    ratio = timed["live_overhead_ratio"]
    print()
    print(f"{'figure':<56}{'value':>14}  target")
    print("-" * 80)
    row("latency, manifest written -> logged (median)", f"{median:.3f} s", "<= 2 s", median <= 2)
    row("latency (max)", f"{most:.3f} s")
    row("a poll (median)", f"{followed['poll_median_ms']:.1f} ms")
    row(
        f"watcher peak RSS after {args.memory_at} generations",
        f"{followed['rss_mb_at_memory_at']:.1f} MB",
    )
    row(
        f"watcher peak RSS after {args.generations} generations",
        f"{followed['rss_mb_at_end']:.1f} MB",
    )
    row("  growth", f"{growth:+.1f} MB")
    row("run wall time without --live (median)", f"{timed['run_seconds_without']:.2f} s")
    row("run wall time with --live (median)", f"{timed['run_seconds_with']:.2f} s")
    row("live_overhead_ratio (with / without)", f"{ratio:.3f}", "<= 1.03", ratio <= RATIO_TARGET)
    row("  command wall time ratio (with the end's wait)", f"{timed['command_ratio']:.3f}")
    summary = {
        "latency_median_s": median,
        "latency_max_s": most,
        "latency_target_s": LATENCY_TARGET,
        "live_overhead_ratio": ratio,
        "live_overhead_target": RATIO_TARGET,
        "rss_growth_mb": growth,
        **{k: v for k, v in followed.items() if k not in ("latency_median_s", "latency_max_s")},
        **{k: v for k, v in timed.items() if k != "live_overhead_ratio"},
        "generations": args.generations,
        "memory_at": args.memory_at,
        "ratio_generations": args.ratio_generations,
        "repeats": args.repeats,
        "poll_s": args.poll,
        "overrides": run_overrides(args),
        "load_average_before": load_before,
        "load_average_after": load_average(),
        "cpus": os.cpu_count(),
        "versions": versions(ariel="ariel", rerun="rerun-sdk"),
        "when": utc_now(),
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
