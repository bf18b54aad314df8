"""Helpers several test modules share: tiny run configs, the ``ariel`` command, run folders.

``tests/`` is no package; pytest puts it on ``sys.path`` for ``tests/conftest.py`` (rootdir
conftest, default import mode), so a test module anywhere below imports this as ``_helpers``.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ariel.cli import main

REPO = Path(__file__).resolve().parents[1]


def tiny_run_toml(
    name: str,
    seed: int,
    *,
    generations: int = 2,
    iterations: int = 1,
    brain: str = "",
    record: str | None = "rerun = false",
) -> str:
    """A co-evolution config of a few seconds: 2 + 2 bodies of 10 modules, brains of popsize 2
    for 0.3 s, serial. ``brain`` adds lines to ``[brain]``; ``record`` is the ``[record]``
    table's body (None: no table, the defaults)."""
    text = f"""
name = "{name}"
seed = {seed}
generations = {generations}

[body]
options = {{ number_of_modules = 10 }}
population = 2
offspring = 2

[brain]
popsize = 2
iterations = {iterations}
{brain + chr(10) if brain else ""}
[task]
duration = 0.3
"""
    if record is not None:
        text += f"\n[record]\n{record}\n"
    return text + '\n[executor]\nkind = "serial"\n'


def ariel_run(config: Path, out: Path, *extra: str) -> str:
    """``ariel run CONFIG --out OUT --quiet``, in this process; asserts it finished and returns
    what it printed."""
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["run", str(config), "--out", str(out), "--quiet", *extra]) == 0
    return printed.getvalue()


def tiny_finished_run(factory: pytest.TempPathFactory, name: str, seed: int) -> Path:
    """A finished `tiny_run_toml` run (``ariel run``, a few seconds), ``RUN`` in a new
    temporary folder: for a module's fixture; copy it before changing it."""
    folder = factory.mktemp(name)
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml(name, seed))
    ariel_run(config, folder / "run")
    return folder / "run"


def interrupt_then_resume(
    config: dict[str, Any], out: Path, monkeypatch: pytest.MonkeyPatch, *, after: int
) -> None:
    """Run ``config`` into ``out``, interrupted (Ctrl-C) once generation ``after`` has ended,
    then resume it to the end (asserted finished): compare its records with an uninterrupted
    run's. The folder name is the run id, in every row: name both folders alike."""
    from ariel.evolution._progress import Progress
    from ariel.runs import resume_experiment, run_experiment

    original = Progress.end_generation

    def stop_after(self: Progress, generation: int, *args: Any, **kwargs: Any) -> None:
        original(self, generation, *args, **kwargs)
        if generation == after:
            raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(Progress, "end_generation", stop_after)
        with pytest.raises(KeyboardInterrupt):
            run_experiment(config, out=out)
    assert resume_experiment(out).status == "finished"


def exit_code(argv: list[str]) -> int:
    """``main(argv)``'s exit code, whether it returns it or argparse exits."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)  # type: ignore[arg-type]


def one_error_line(
    capsys: pytest.CaptureFixture[str], *, subcommand: bool = False, quiet: bool = False
) -> str:
    """The one line the command wrote to stderr, checked to be ``ariel: error: ...``
    (``subcommand``: also ``ariel <command>: error: ...``, argparse's form); ``quiet``: and
    nothing on stdout."""
    captured = capsys.readouterr()
    err = captured.err
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n"), f"expected one line on stderr, got {err!r}"
    prefix = r"ariel( [a-z]+){0,2}: error: " if subcommand else r"ariel: error: "
    assert re.match(prefix, lines[0]), lines[0]
    if quiet:
        assert captured.out == ""
    return lines[0]


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file below ``folder`` (relative path -> bytes): equal snapshots, nothing changed."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def repo_env() -> dict[str, str]:
    """This environment with the repository first on ``PYTHONPATH`` (for child processes)."""
    paths = [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]
    return dict(os.environ, PYTHONPATH=os.pathsep.join(paths))


def run_replay_script(export_dir: Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``python EXPORT_DIR/replay.py`` as a user runs it (in ``cwd``), its output captured."""
    return subprocess.run(
        [sys.executable, str(export_dir / "replay.py")],
        cwd=cwd,
        env=repo_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )


def plain(value: Any) -> Any:
    """Bit-exact, comparable form of a table cell (floats as hex, arrays as tuples)."""
    if isinstance(value, np.ndarray | list | tuple):
        return tuple(plain(v) for v in list(value))
    if isinstance(value, float | np.floating):
        return float(value).hex()
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    return value


def plain_rows(frame: Any, columns: list[str], order: list[str]) -> list[tuple]:
    """``frame``'s ``columns`` as `plain` tuples, rows sorted by ``order``."""
    frame = frame.sort_values(order, kind="stable")
    return [tuple(plain(v) for v in row) for row in frame[columns].itertuples(index=False)]


def run_benchmark(name: str, *args: str, cwd: Path, timeout: float = 300) -> Any:
    """``python experiments/benchmarks/NAME.py ARGS`` in ``cwd``: the `subprocess.CompletedProcess`
    with its text output."""
    script = REPO / "experiments" / "benchmarks" / name
    return subprocess.run(
        [sys.executable, str(script), *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
    )


def benchmark_summary(result: Any, keys: tuple[str, ...]) -> tuple[dict[str, Any], str]:
    """A benchmark's JSON last line (each of ``keys`` a finite number > 0) and the text above."""
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.strip().splitlines()
    summary = json.loads(lines[-1])
    for key in keys:
        value = summary[key]
        assert isinstance(value, int | float) and not isinstance(value, bool), key
        assert math.isfinite(value) and value > 0, (key, value)
    return summary, "\n".join(lines[:-1])


class StoppedError(Exception):
    """Raised where the executor would be made (`stop_at_executor`): nothing is evaluated."""


def stop_at_executor(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """``make_executor`` records the settings it is given and stops the run there (a Dask
    scheduler's address is not asked first: nothing need listen there)."""
    import ariel.evaluation
    from ariel.evaluation import executors

    monkeypatch.setattr(executors.DaskKind, "reach", lambda self, settings: None)

    given: list[Any] = []

    def make_executor(settings: Any, *args: Any, **kwargs: Any) -> Any:
        given.append(settings)
        raise StoppedError

    monkeypatch.setattr(ariel.evaluation, "make_executor", make_executor)
    return given


def edit_json(path: Path, change: Any) -> None:
    """Apply ``change`` (a function of the data, in place) to the JSON file ``path``."""
    info = json.loads(path.read_text())
    change(info)
    path.write_text(json.dumps(info))


def with_run_id(run_dir: Path, run_id: str) -> Path:
    """Give the run in ``run_dir`` (a copy) the id ``run_id`` everywhere it is written: its
    run.json and every table's ``run_id`` column, with the manifests written again (readers
    refuse a table whose run id is not run.json's)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ariel.recording.store._manifest import write_manifest

    edit_json(run_dir / "run.json", lambda info: info.update(run_id=run_id))
    generations = set()
    for path in sorted(run_dir.glob("*/gen-*.parquet")):
        data = pq.read_table(path)
        if "run_id" in data.column_names:
            index = data.schema.get_field_index("run_id")
            column = pa.array([run_id] * data.num_rows, data.schema.field(index).type)
            pq.write_table(data.set_column(index, data.schema.field(index), column), path)
        generations.add(int(path.stem.removeprefix("gen-")))
    for generation in sorted(generations):
        write_manifest(run_dir, generation)
    return run_dir


def count_warp_module_loads(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """From now on, per Warp module load (every launch asks): True where the module was
    loaded or compiled anew, False where Warp reused one it had. Skips without Warp's
    internals."""
    context = pytest.importorskip("warp._src.context", reason="Warp's internals moved")
    fresh: list[bool] = []
    original = context.Module.load

    def load(self: Any, *args: Any, **kwargs: Any) -> Any:
        known = list(self.execs.values())
        loaded = original(self, *args, **kwargs)
        fresh.append(all(loaded is not e for e in known))
        return loaded

    monkeypatch.setattr(context.Module, "load", load)
    return fresh


class ServedWebViewer:
    """``ariel COMMAND... --port 0 --grpc-port 0 EXTRA...`` serving Rerun's web viewer (`ariel
    view --web`, `ariel watch --web`): its printed address and tunnel line, its rerun child."""

    def __init__(self, command: list[str], *extra: str) -> None:
        import queue
        import threading
        import time

        import psutil

        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "ariel.cli",
                *command,
                "--port",
                "0",
                "--grpc-port",
                "0",
                *extra,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        lines: queue.Queue[str] = queue.Queue()
        threading.Thread(
            target=lambda: [lines.put(x) for x in self.proc.stdout], daemon=True
        ).start()
        self.text = ""
        deadline = time.monotonic() + 60
        while "Ctrl-C stops it" not in self.text:
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(self.text + self.proc.stderr.read())
            with contextlib.suppress(queue.Empty):
                self.text += lines.get(timeout=0.2)
        self.url = re.search(r"open\s+(http://\S+)", self.text).group(1)
        self.tunnel = re.search(r"^\s*(ssh .*)$", self.text, re.MULTILINE).group(1)
        (self.rerun,) = psutil.Process(self.proc.pid).children(recursive=True)

    def listening(self) -> list:
        import psutil

        return [c for c in self.rerun.net_connections("inet") if c.status == psutil.CONN_LISTEN]

    def stop(self, signum: int) -> int:
        self.proc.send_signal(signum)
        return self.proc.wait(timeout=30)


# --- records, bit for bit ----------------------------------------------------------------------

_UNMEASURED = {"wall_seconds"}  # a measured time, different in every run
_ORDER = {"evaluations": ["eval_id"], "bodies": ["body_id"], "trajectories": ["eval_id", "t"]}


def table_digests(run_dir: Path) -> dict[str, str]:
    """``"<table>/gen-N"`` -> SHA-256 of that table's rows in a bit-exact, ordered form (the
    golden records' digests, tests/e2e/test_golden_records.py)."""
    import pyarrow.parquet as pq

    digests = {}
    for table, order in _ORDER.items():
        for path in sorted((run_dir / table).glob("gen-*.parquet")):
            frame = pq.read_table(path).to_pandas()
            columns = [c for c in frame.columns if c not in _UNMEASURED]
            frame = frame.sort_values(order, kind="stable")
            text = json.dumps(
                [columns, [[plain(v) for v in row] for row in frame[columns].itertuples(False)]],
                default=str,
            )
            digests[f"{table}/{path.stem}"] = hashlib.sha256(text.encode()).hexdigest()
    return digests


# --- a robot graph of two branches (joint names, the viewer's panels) ------------------------


def two_branches() -> Any:
    """Core; RIGHT: hinge 1 > hinge 2; FRONT: brick 3, with hinge 4 on its LEFT face and hinge 5
    on its RIGHT face (RIGHT, face 2, is attached before LEFT, face 3)."""
    from ariel.body_phenotypes.robogen_lite.graph_io import robot_graph

    return robot_graph(
        {
            0: ("CORE", "DEG_0"),
            1: ("HINGE", "DEG_0"),
            2: ("HINGE", "DEG_90"),
            3: ("BRICK", "DEG_0"),
            4: ("HINGE", "DEG_0"),
            5: ("HINGE", "DEG_0"),
        },
        [(0, 1, "RIGHT"), (1, 2, "FRONT"), (0, 3, "FRONT"), (3, 4, "LEFT"), (3, 5, "RIGHT")],
    )


#: A MAP-Elites run of a few seconds: one generation, a 4 x 4 archive, recordings on.
TINY_QD = {
    "name": "tiny-qd",
    "seed": 5,
    "generations": 1,
    "body": {
        "options": {"number_of_modules": 6},
        "population": 2,
        "offspring": 2,
        "optimizer": "map_elites",
        "optimizer_options": {
            "measures": ["num_limbs", "joints_ratio"],
            "bins": [4, 4],
            "ranges": [[0, 4], [0, 1]],
        },
    },
    "brain": {"popsize": 2, "iterations": 1},
    "task": {"duration": 0.3},
    "executor": {"kind": "serial"},
    "record": {"rerun": True},
}


def signal_run_group(config: Path, run_dir: Path, log: Path, signum: int, *extra: str) -> int:
    """``ariel run CONFIG --out RUN_DIR *EXTRA`` in its own process group (a terminal's job), its
    output into ``log``; once generation 0 is done, ``signum`` to the whole group, as a
    terminal sends Ctrl-C or SIGHUP. Returns the exit code."""
    with log.open("wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "ariel.cli", "run", str(config), "--out", str(run_dir), *extra],
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            env=repo_env(),
        )
        try:
            deadline = time.monotonic() + 240
            while time.monotonic() < deadline and process.poll() is None:
                info = run_dir / "run.json"
                if info.is_file() and json.loads(info.read_text()).get("generations_done", 0):
                    break  # the workers are busy with generation 1
                time.sleep(0.2)
            assert process.poll() is None, log.read_text()
            os.killpg(process.pid, signum)
            return process.wait(timeout=120)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)


@contextlib.contextmanager
def x_display() -> Any:
    """A ``DISPLAY`` value that answers as an X server's does to `has_display` (a TCP socket
    listening on 127.0.0.1, port 6000 + N), for tests of the windowed paths with stand-in
    viewers; no X server is run."""
    import socket

    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    with listener:
        for port in range(6100, 6900):
            try:
                listener.bind(("127.0.0.1", port))
                break
            except OSError:
                continue
        listener.listen(8)
        yield f"127.0.0.1:{port - 6000}"
