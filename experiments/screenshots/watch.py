"""The README's picture of the live view: a default co-evolution run, watched while it runs.

    python experiments/screenshots/watch.py [OUT.png] [--after N]

Starts the default experiment (`experiments/coevolve_flat.toml`, with recordings) in a
temporary folder, watches it with the web viewer on free ports of 127.0.0.1, and once N
generations (default 4) are shown draws the page in a headless Chromium and saves the PNG
(default docs/images/watch.png). Then it stops the run.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from ariel.recording import load_run, watch
from ariel.recording.store._files import atomic_write_bytes
from ariel.recording.viewer._browser import HeadlessChromium, find_chromium
from ariel.recording.viewer._web import wait_for_drawing

#: The default experiment's generations: `--after` beyond them is never reached.
GENERATIONS = tomllib.loads(
    (Path(__file__).parents[1] / "coevolve_flat.toml").read_text(encoding="utf-8")
)["generations"]


def _going(proc: subprocess.Popen[bytes], what: str) -> None:
    """Stop with one line when the run ended before ``what`` (it said why on stderr): the
    waits below would otherwise go on for good."""
    if proc.poll() is not None:  # the scripts' one line, exit 2
        print(
            f"watch.py: error: the run ended (exit {proc.returncode}) before {what}",
            file=sys.stderr,
        )
        raise SystemExit(2)


def _after(text: str) -> int:
    try:
        value = int(text)
    except ValueError:  # argparse said "invalid _after value"
        raise argparse.ArgumentTypeError(f"must be a whole number, not {text!r}") from None
    if not 1 <= value <= GENERATIONS:
        raise argparse.ArgumentTypeError(f"must be from 1 to {GENERATIONS}, not {value}")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="docs/images/watch.png", type=Path)
    parser.add_argument("--after", type=_after, default=4, help="generations shown first")
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="ariel-watch-shot-"))
    run = scratch / "run"
    command = [sys.executable, "-m", "ariel.cli", "run", "--out", str(run), "--quiet"]
    proc = subprocess.Popen(command)
    try:
        while not (run / "run.json").is_file():
            _going(proc, "its folder was made")
            time.sleep(0.2)
        with watch(run, viewer="web", port=0, grpc_port=0) as watcher:
            while True:
                watcher.poll()
                try:
                    if load_run(run).generations_done >= args.after:
                        break
                except Exception:  # the run folder is still being made
                    pass
                _going(proc, f"{args.after} generations were shown")
                time.sleep(0.5)
            watcher.poll()
            with HeadlessChromium(
                scratch / "profile", size=(1600, 900), binary=find_chromium()
            ) as browser:
                browser.open(watcher.urls["web"])
                atomic_write_bytes(args.out, wait_for_drawing(browser, 8.0))
        print(f"wrote {args.out}")
    finally:
        proc.terminate()
        proc.wait(timeout=60)
        shutil.rmtree(scratch, ignore_errors=True)  # the scratch run (~50 MB) and the profile


if __name__ == "__main__":
    main()
