"""``ariel view --web`` and ``--screenshot``: the web viewer served on 127.0.0.1 only (never a
browser opened), its ports, when it is ready, the SSH tunnel that reaches it from another
machine, and a picture of it drawn in a headless Chromium.
"""

from __future__ import annotations

import dataclasses
import getpass
import math
import os
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

from ariel.errors import ViewError
from ariel.recording.rerun import write_campaign_blueprint, write_generation_blueprint
from ariel.recording.store import atomic_write_bytes, cannot_write, terminal_text, user_file
from ariel.recording.viewer._browser import BrowserError, HeadlessChromium, find_chromium
from ariel.recording.viewer._child import _run_child, _terminate, rerun_binary
from ariel.recording.viewer._select import Selection

__all__ = ["DEFAULT_GRPC_PORT", "DEFAULT_WEB_PORT", "LOCALHOST", "tunnel_command", "web_url"]

DEFAULT_WEB_PORT = 9090  # rerun's defaults: the web viewer over HTTP, and its gRPC proxy
DEFAULT_GRPC_PORT = 9876
LOCALHOST = "127.0.0.1"
READY_TIMEOUT_S = 60.0


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server will
        try:
            s.bind((LOCALHOST, port))
        except OSError:
            return False
    return True


def _any_free_port(exclude: set[int]) -> int:
    while True:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.bind((LOCALHOST, 0))
            port = int(s.getsockname()[1])
        if port not in exclude:
            return port


def _choose_port(requested: int | None, default: int, option: str, taken: set[int]) -> int:
    """``requested`` as given (0: any free port); unset: ``default``, or a free one if busy."""
    if requested:
        if requested in taken:  # --port and --grpc-port the same: it is free, but wanted twice
            raise ViewError(f"port {requested} is --port too; choose another {option}")
        if not _port_free(requested):
            raise ViewError(f"port {requested} on {LOCALHOST} is in use; choose another {option}")
        return requested
    if requested is None and default not in taken and _port_free(default):
        return default
    return _any_free_port(taken)


def _listening(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(0.5)
        return s.connect_ex((LOCALHOST, port)) == 0


def web_url(web_port: int, grpc_port: int) -> str:
    """The web viewer's address, connected to the gRPC proxy that serves the recordings."""
    proxy = f"rerun+http://{LOCALHOST}:{grpc_port}/proxy"
    return f"http://{LOCALHOST}:{web_port}/?url={quote(proxy, safe='')}"


def tunnel_command(ports: Sequence[int]) -> str:
    """The SSH command that forwards ``ports`` of this machine's 127.0.0.1 to the same ports
    on the caller's machine."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = os.environ.get("USER", "user")
    forwards = " ".join(f"-L {p}:{LOCALHOST}:{p}" for p in ports)
    return f"ssh -N {forwards} {shlex.quote(user)}@{socket.gethostname()}"


def _memory_limit(paths: Sequence[Path]) -> str:
    """The gRPC server keeps what it serves in memory and drops the oldest data beyond its
    limit (1 GiB by default): make room for three times the files."""
    total = sum(p.stat().st_size for p in paths)
    return f"{max(1024, math.ceil(3 * total / 2**20))}MiB"


def web_command(selection: Selection, web_port: int, grpc_port: int) -> list[str]:
    files = selection.files
    return [
        str(rerun_binary()),
        "--serve-web",  # serve, never open a browser
        "--bind",
        LOCALHOST,
        "--web-viewer-port",
        str(web_port),
        "--port",
        str(grpc_port),
        "--server-memory-limit",
        _memory_limit(files),
        *map(str, files),
    ]


def _wait_until_serving(proc: subprocess.Popen[bytes], web_port: int, grpc: int) -> bool:
    """Whether both ports listen (False: the server ended; its messages are above)."""
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not (_listening(web_port) and _listening(grpc)):
        if proc.poll() is not None:
            return False
        if time.monotonic() > deadline:
            raise ViewError(f"the Rerun server did not start in {READY_TIMEOUT_S:.0f} s")
        time.sleep(0.1)
    return True


def _serve_web(selection: Selection, port: int | None, grpc_port: int | None) -> int:
    web_port = _choose_port(port, DEFAULT_WEB_PORT, "--port", set())
    grpc = _choose_port(grpc_port, DEFAULT_GRPC_PORT, "--grpc-port", {web_port})
    command = web_command(selection, web_port, grpc)

    def announce(proc: subprocess.Popen[bytes]) -> None:
        if not _wait_until_serving(proc, web_port, grpc):
            return  # it failed; the exit code follows
        count = len(selection.recordings)
        print(
            f"Rerun web viewer: {selection.description} ({count} file{'s' * (count != 1)}) "
            f"of {selection.run_dir}\n"
            f"  open  {web_url(web_port, grpc)}\n"
            f"From another computer (this one being a cluster node), tunnel both ports first:\n"
            f"  {tunnel_command([web_port, grpc])}\n"
            f"  (add -J user@login-node when this node is reached through a login node)\n"
            f"The server listens on {LOCALHOST} only. Ctrl-C stops it.",
            flush=True,
        )

    code = _run_child(command, when_started=announce)
    if code not in (0, 128 + signal.SIGTERM, 128 + getattr(signal, "SIGHUP", 1)):
        print(f"ariel: the Rerun server exited with code {code}", file=sys.stderr)
    return code


def _screenshot(selection: Selection, out: Path, size: tuple[int, int], settle_s: float) -> int:
    """Serve the web viewer on free ports, draw it in a headless browser, save a PNG."""
    try:
        chromium = find_chromium()
    except BrowserError as exc:
        raise ViewError(f"--screenshot: {exc}") from None
    web_port = _any_free_port(set())
    grpc = _any_free_port({web_port})
    taken: list[str] = []
    scratch = tempfile.mkdtemp(prefix="ariel-screenshot-")  # the browser profile, the layout
    # The layout of what is shown (a generation's recording, a campaign; a run's is written by
    # `_prepared`) with the side panels collapsed: the picture shows the views.
    if selection.more_layouts:
        shared = write_generation_blueprint(Path(scratch) / "generation.rbl", panels=False)
        selection = dataclasses.replace(selection, more_layouts=(shared,))
    elif (selection.run_dir / "campaign.json").is_file():
        layout = write_campaign_blueprint(
            Path(scratch) / "views.rbl", selection.run_dir, panels=False
        )
        selection = dataclasses.replace(selection, blueprint=layout)

    def capture(proc: subprocess.Popen[bytes]) -> None:
        try:
            if not _wait_until_serving(proc, web_port, grpc):
                return
            with HeadlessChromium(Path(scratch), size=size, binary=chromium) as browser:
                browser.open(web_url(web_port, grpc))
                picture = wait_for_drawing(browser, settle_s)
        except BrowserError as exc:  # a browser that cannot start is said so, not a write
            raise ViewError(f"--screenshot: {exc}") from None
        finally:
            _terminate(proc)
        try:
            atomic_write_bytes(user_file(out), picture)
        except OSError as exc:  # full, read-only, or a folder like /proc that takes no file
            raise ViewError(f"--screenshot: {cannot_write(exc, out)}") from None
        taken.append(str(out))

    try:
        code = _run_child(web_command(selection, web_port, grpc), when_started=capture)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    if not taken:
        return code or 1
    print(terminal_text(f"wrote {out} ({selection.description} of {selection.run_dir})"))
    return 0


def wait_for_drawing(browser: HeadlessChromium, settle_s: float) -> bytes:
    """The viewer page as a PNG once it has drawn: its canvas is shown (the app started), then
    ``settle_s`` seconds for the recordings to stream in, then until two captures a second
    apart agree (or another ``settle_s`` passed)."""
    deadline = time.monotonic() + READY_TIMEOUT_S
    while browser.evaluate(_CANVAS_SHOWN) is not True:
        if time.monotonic() > deadline:
            raise ViewError(f"the web viewer did not start in {READY_TIMEOUT_S:.0f} s")
        time.sleep(0.25)
    time.sleep(settle_s)
    last, deadline = browser.png(), time.monotonic() + settle_s
    while time.monotonic() < deadline:
        time.sleep(1.0)
        now = browser.png()
        if now == last:
            break
        last = now
    return last


# The viewer's canvas is shown once its WebAssembly app runs (the loading text is hidden then).
_CANVAS_SHOWN = "document.getElementById('the_canvas_id')?.className === 'visible'"
