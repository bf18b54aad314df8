"""A Dask executor that cannot start or reach its cluster, or whose terminal closes: one line,
never a traceback, never a silent wait (docs/executors.md, "dask")."""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import textwrap
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from _helpers import repo_env, signal_run_group, tiny_run_toml

from ariel.errors import ConfigError
from ariel.evaluation import make_executor

pytest.importorskip("distributed")


def _within(seconds: float, call: object) -> BaseException | None:
    """Run ``call()`` in a thread; fail the test if it has not ended in ``seconds`` (the old
    code waited for ever). Returns what it raised, None if nothing."""
    outcome: dict[str, BaseException] = {}

    def target() -> None:
        try:
            call()  # type: ignore[operator]
        except BaseException as exc:
            outcome["error"] = exc

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"still waiting after {seconds} s"
    return outcome.get("error")


@pytest.fixture
def silent_listener() -> Iterator[str]:
    """A TCP port where something that is not Dask listens: it takes connections (the
    kernel's backlog does) and never says a word."""
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"


@pytest.mark.parametrize(
    ("address", "said"),
    [
        ("garbage", "is not a Dask scheduler address"),
        ("http://127.0.0.1:80", "http:// is not a Dask transport"),
        ("tcp://127.0.0.1:99999", "the port must be 1 to 65535"),
        # Passed the form check stripped, then used as given: "not a Dask scheduler", or 30 s
        (" tcp://127.0.0.1:8786", "has spaces around it"),
        ("tcp://127.0.0.1:8786 ", "has spaces around it"),
    ],
)
def test_a_malformed_address_is_one_line_naming_what_is_allowed(address: str, said: str) -> None:
    with pytest.raises(ConfigError) as caught:
        make_executor("dask", address=address)
    message = str(caught.value)
    assert said in message and "HOST:PORT" in message and "\n" not in message


def test_a_malformed_address_or_too_many_workers_are_refused_before_a_folder_is_made(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The executor is made after the run folder: a bad address left a `failed` folder."""
    from _helpers import exit_code, one_error_line

    from ariel.evaluation import _dask_local

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("dask_refused", 1))
    out = tmp_path / "run"
    run = ["run", str(config), "--out", str(out), "--quiet", "--executor", "dask"]
    assert exit_code([*run, "--address", "garbage"]) == 2
    assert "executor.address: 'garbage' is not a Dask scheduler address" in one_error_line(capsys)
    # Read when the executor was made, after the folder: a `failed` run (a campaign) stayed.
    monkeypatch.setenv("ARIEL_NO_WORKER_TIMEOUT", "abc")
    assert exit_code(run) == 2
    assert "ARIEL_NO_WORKER_TIMEOUT: seconds to wait" in one_error_line(capsys)
    monkeypatch.delenv("ARIEL_NO_WORKER_TIMEOUT")
    # A timeout past the clocks' range failed the first generation, blaming the plugins.
    assert exit_code([*run, "--set", "executor.timeout=3e6"]) == 2
    assert "executor.timeout: must be less than or equal to 1000000" in one_error_line(capsys)
    # The old name and the new one, set one after the other: the last won without a word.
    twice = ["--set", 'executor.scheduler="tcp://a:1"', "--set", 'executor.address="tcp://b:2"']
    assert exit_code([*run, *twice]) == 2
    assert "executor.address: sets executor.scheduler too" in one_error_line(capsys)
    monkeypatch.setattr(_dask_local, "OPEN_FILES_PER_DASK_WORKER", 10**9)  # no limit fits
    assert exit_code([*run, "--workers", "2"]) == 2
    assert "executor.workers: a local Dask cluster of 2 workers needs" in one_error_line(capsys)
    assert not out.exists()


def test_an_address_where_nothing_or_no_dask_answers_is_one_line_in_bounded_time(
    silent_listener: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.evaluation import _dask_connect

    monkeypatch.setattr(_dask_connect, "CONNECT_SECONDS", 1.0)
    error = _within(20, lambda: make_executor("dask", address=silent_listener))
    assert isinstance(error, ConfigError), error
    assert f"no Dask scheduler answered at {silent_listener}" in str(error)
    with socket.socket() as closed:  # a port nothing listens on
        closed.bind(("127.0.0.1", 0))
        refused = f"tcp://127.0.0.1:{closed.getsockname()[1]}"
    error = _within(20, lambda: make_executor("dask", address=refused))
    assert isinstance(error, ConfigError), error
    # Dask retries a refused connection until its own timeout; the 1-s limit may end it first
    said = (f"cannot reach the Dask scheduler at {refused}: OSError", f"answered at {refused}")
    assert any(text in str(error) for text in said), error


def _serving(answer: Any) -> Iterator[str]:
    """A TCP port where a thread calls ``answer(peer)`` on each connection it takes."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)

    def serve() -> None:
        while True:
            try:
                answer(server.accept()[0])
            except OSError:
                return

    threading.Thread(target=serve, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()


@pytest.fixture
def banner_server() -> Iterator[str]:
    """A server of another protocol that greets first (as SSH does): Dask read the banner as
    a frame length and failed allocating 2.8 EiB ("cannot reach ...")."""
    yield from _serving(lambda peer: peer.sendall(b"SSH-2.0-OpenSSH_9.6p1 Ubuntu\r\n"))


@pytest.fixture
def hanging_up_server() -> Iterator[str]:
    """Something that takes each connection and closes it at once."""
    yield from _serving(lambda peer: peer.close())


def test_a_tls_address_without_certificates_says_so() -> None:
    """Nothing had answered, yet it was "not a Dask scheduler (... TypeError)"."""
    from ariel.evaluation._dask_connect import DaskAddressError

    with pytest.raises(DaskAddressError) as caught:
        make_executor("dask", address="tls://127.0.0.1:1")
    assert "cannot reach the Dask scheduler at tls://127.0.0.1:1: TypeError: TLS expects" in (
        str(caught.value)
    )


def test_a_server_that_hangs_up_is_not_a_dask_scheduler(hanging_up_server: str) -> None:
    """It said 'cannot reach ... CommClosedError': something had answered there."""
    error = _within(20, lambda: make_executor("dask", address=hanging_up_server))
    assert isinstance(error, ConfigError), error
    assert f"{hanging_up_server} is not a Dask scheduler" in str(error), error


def test_a_server_of_another_protocol_is_not_a_dask_scheduler(banner_server: str) -> None:
    error = _within(20, lambda: make_executor("dask", address=banner_server))
    assert isinstance(error, ConfigError), error
    assert str(error) == (
        f"address: {banner_server} is not a Dask scheduler (what answered there does not "
        "speak Dask's protocol: MemoryError)"
    )


def test_a_scheduler_that_does_not_answer_leaves_no_run_or_campaign_folder(
    tmp_path: Path,
    silent_listener: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Asked before the folder is made: a `failed` run (or a campaign of them) was left, and
    the same command then said the folder exists."""
    from _helpers import exit_code, one_error_line

    from ariel.evaluation import _dask_connect

    monkeypatch.setattr(_dask_connect, "CONNECT_SECONDS", 1.0)
    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("dask_silent", 1))
    campaign = tmp_path / "c.toml"
    campaign.write_text(f'name = "c"\nbase = "{config.name}"\nseed_count = 1\n')
    for command in (["run", str(config)], ["campaign", "run", str(campaign)]):
        out = tmp_path / "out"
        argv = [*command, "--out", str(out), "--quiet", "--executor", "dask"]
        assert exit_code([*argv, "--address", silent_listener]) == 2
        assert "no Dask scheduler answered" in one_error_line(capsys)
        assert not out.exists()


def test_resume_asks_the_scheduler_before_it_touches_the_run_folder(
    tmp_path: Path, banner_server: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """run.json said 'failed' and named the bad address after a refused resume (and a plain
    resume then went to a local Dask cluster)."""
    from _helpers import exit_code, one_error_line

    from ariel.recording.store import RunFolder

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("resume_banner", 1, generations=1))
    out = tmp_path / "run"
    assert exit_code(["run", str(config), "--out", str(out), "--quiet"]) == 0
    RunFolder(out).update_info(status="interrupted")  # as a run stopped before its end
    before = (out / "run.json").read_bytes()
    resume = ["resume", str(out), "--quiet", "--executor", "dask", "--address", banner_server]
    assert exit_code(resume) == 2
    assert "is not a Dask scheduler" in one_error_line(capsys)
    assert (out / "run.json").read_bytes() == before


def test_without_dask_the_dask_executor_is_one_line_and_no_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A traceback and a `failed` run folder before."""
    from _helpers import exit_code, one_error_line

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("no_dask", 1))
    out = tmp_path / "run"
    saved = {name: sys.modules.pop(name) for name in list(sys.modules) if name == "distributed"}
    sys.modules["distributed"] = None  # type: ignore[assignment]  # import raises ImportError
    try:
        assert exit_code(["run", str(config), "--out", str(out), "--executor", "dask"]) == 2
    finally:
        del sys.modules["distributed"]
        sys.modules.update(saved)
    line = one_error_line(capsys)
    assert line == (
        "ariel: error: executor.kind: Dask executor needs the optional extra: pip install "
        "'ariel[distributed]'"
    ), line
    assert not out.exists()


@pytest.mark.skipif(sys.platform == "win32", reason="needs RLIMIT_NOFILE")
def test_a_local_cluster_over_the_open_file_limit_is_refused_before_it_starts() -> None:
    script = textwrap.dedent(
        """
        import resource
        resource.setrlimit(resource.RLIMIT_NOFILE, (300, 300))
        from ariel.evaluation import make_executor
        if __name__ == "__main__":
            try:
                make_executor("dask", workers=40)
            except ValueError as exc:
                print(type(exc).__name__, exc)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=120,
        env=repo_env(),
    )
    assert done.stdout.startswith("ConfigError workers: a local Dask cluster of 40 workers"), (
        done.stdout + done.stderr[-2000:]
    )
    assert "use at most" in done.stdout and "ulimit -n" in done.stdout
    assert done.stderr == "", done.stderr[-2000:]  # no Dask log line, no worker started


def test_a_dask_configuration_asking_for_fork_gets_spawn() -> None:
    """Workers forked from the driver (which runs threads) hung: the run printed nothing and
    ignored SIGTERM."""
    import dask
    import distributed

    from ariel.evaluation._dask_local import never_fork

    key = "distributed.worker.multiprocessing-method"
    with dask.config.set({key: "fork"}):
        never_fork(distributed)
        assert dask.config.get(key) == "spawn"
    with dask.config.set({key: "forkserver"}):  # the user's choice, where it is not fork
        never_fork(distributed)
        assert dask.config.get(key) == "forkserver"


@pytest.mark.soak  # ~10 s: a Dask cluster started and hung up on
@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="needs POSIX signals")
def test_sighup_to_a_dask_run_group_is_one_line(tmp_path: Path) -> None:
    config = tmp_path / "dask.toml"
    toml = tiny_run_toml("dask_hup", 1, generations=200).replace('"serial"', '"dask"')
    config.write_text(toml + "workers = 2\n")
    run_dir, log = tmp_path / "run", tmp_path / "output.txt"
    code = signal_run_group(config, run_dir, log, signal.SIGHUP, "--quiet")  # a closing terminal
    output = log.read_text()
    assert code == 128 + signal.SIGHUP, (code, output[-3000:])
    lines = output.strip().splitlines()
    assert len(lines) == 1 and re.match(r"interrupted \(SIGHUP\); continue it with", lines[0]), (
        output[-3000:]
    )
    assert json.loads((run_dir / "run.json").read_text())["status"] == "interrupted"


def test_a_local_cluster_whose_worker_cannot_start_is_one_line_and_no_folder(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """A Dask configuration value the worker cannot use: its process printed Dask's
    traceback, the error had no message ("MemoryError:") and a `failed` folder (a campaign's
    folders) stayed behind."""
    import dask

    from ariel.cli import main

    config = tmp_path / "tiny.toml"
    config.write_text(tiny_run_toml("dask_no_worker", 1))
    campaign = tmp_path / "c.toml"
    campaign.write_text(f'name = "c"\nbase = "{config.name}"\nseed_count = 1\n')
    out = tmp_path / "out"
    with dask.config.set({"distributed.worker.memory.target": "lots"}):  # the workers get it
        for command in (["run", str(config)], ["campaign", "run", str(campaign)]):
            argv = [*command, "--out", str(out), "--quiet", "--executor", "dask"]
            assert main([*argv, "--workers", "1"]) == 2
            err = capfd.readouterr().err
            assert err.count("\n") == 1 and "Traceback" not in err, err
            assert err.startswith("ariel: error: the local Dask cluster could not start its 1")
            assert "first error: MemoryError (raised in distributed/worker_memory.py" in err
            assert not out.exists()


def test_an_inproc_address_with_no_scheduler_here_says_what_inproc_reaches() -> None:
    """`--address inproc://x` passed the form check and then failed inside Dask: "ValueError:
    not enough values to unpack (expected 3, got 1)" (probe G6)."""
    from ariel.evaluation._dask_connect import DaskAddressError, check_scheduler

    with pytest.raises(DaskAddressError, match=r"inproc:// reaches one made in this Python"):
        check_scheduler("inproc://x")
