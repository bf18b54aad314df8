"""A headless Chromium driven over the DevTools protocol, for pictures of the web viewer.

The Rerun web viewer is a WebAssembly app that draws with WebGL: a plain
``chromium --headless --screenshot`` captures its loading text, because the page only draws
once the app runs in real time. So the browser is driven over its DevTools pipe (file
descriptors 3 and 4, no port to expose), and the page is captured when it has drawn.

Used by ``ariel view --screenshot`` and by the test that opens the served viewer.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import select
import shutil
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

from ariel.errors import BrowserError

__all__ = ["BrowserError", "HeadlessChromium", "find_chromium"]

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
CALL_TIMEOUT_S = 30.0


def find_chromium() -> Path:
    """Chromium or Google Chrome: ``ARIEL_CHROMIUM`` if set, else the first one on PATH."""
    override = os.environ.get("ARIEL_CHROMIUM")
    if override:
        if not Path(override).is_file():
            raise BrowserError(f"ARIEL_CHROMIUM={override} is not a file")
        if not os.access(override, os.X_OK):
            raise BrowserError(
                f"ARIEL_CHROMIUM {override!r} cannot be run (Permission denied: not "
                "executable); point it at Chromium or Google Chrome"
            )
        return Path(override)
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return Path(found)
    raise BrowserError(
        "no headless browser found (looked for " + ", ".join(CANDIDATES) + " on PATH); "
        "install one (Debian/Ubuntu: apt-get install chromium) or set ARIEL_CHROMIUM"
    )


class HeadlessChromium:
    """One headless Chromium with one page, driven over the DevTools protocol on a pipe.

    Use as a context manager; leaving it kills the browser's whole process group.
    """

    def __init__(
        self, profile: Path, *, size: tuple[int, int] = (1280, 800), binary: Path | None = None
    ) -> None:
        to_chrome, self._write = os.pipe()
        self._read, from_chrome = os.pipe()

        def fds() -> None:  # the pipe ends become the child's fds 3 and 4, inheritable
            a, b = os.dup(to_chrome), os.dup(from_chrome)
            os.dup2(a, 3)
            os.dup2(b, 4)

        browser = str(binary or find_chromium())
        try:
            self.proc = self._start(browser, profile, size, fds)
        except OSError as exc:  # not executable, not a program (ENOEXEC), gone
            for fd in (to_chrome, self._write, self._read, from_chrome):
                os.close(fd)
            reason = exc.strerror or type(exc).__name__
            raise BrowserError(f"the browser {browser!r} cannot be run ({reason})") from None
        os.close(to_chrome)
        os.close(from_chrome)
        self._buffer = b""
        self._id = 0
        try:
            target = self.call("Target.createTarget", url="about:blank")["targetId"]
            attached = self.call("Target.attachToTarget", targetId=target, flatten=True)
        except BaseException:
            self.close()
            raise
        self.session = attached["sessionId"]
        # The page itself gets the size (--window-size would include the browser's frame).
        self.page(
            "Emulation.setDeviceMetricsOverride",
            width=size[0],
            height=size[1],
            deviceScaleFactor=1,
            mobile=False,
        )

    @staticmethod
    def _start(
        browser: str, profile: Path, size: tuple[int, int], fds: Callable[[], None]
    ) -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            [
                browser,
                "--headless",
                "--no-sandbox",  # root in containers; the page is our own localhost viewer
                "--disable-gpu",  # WebGL falls back to software rendering
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                f"--user-data-dir={profile}",
                f"--window-size={size[0]},{size[1]}",
                "--remote-debugging-pipe",
                "about:blank",
            ],
            preexec_fn=fds,
            close_fds=False,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )

    def __enter__(self) -> HeadlessChromium:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def call(self, method: str, session: str | None = None, **params: object) -> dict:
        """Send one DevTools command and return its result (events in between are dropped)."""
        self._id += 1
        message: dict[str, object] = {"id": self._id, "method": method, "params": params}
        if session:
            message["sessionId"] = session
        os.write(self._write, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + CALL_TIMEOUT_S
        while True:
            while b"\0" not in self._buffer:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise BrowserError(f"the browser did not answer {method} in {CALL_TIMEOUT_S} s")
                if select.select([self._read], [], [], left)[0]:
                    chunk = os.read(self._read, 1 << 20)
                    if not chunk:
                        raise BrowserError("the browser closed its DevTools pipe (it crashed?)")
                    self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error'].get('message', reply)}")
                return reply["result"]

    def page(self, method: str, **params: object) -> dict:
        """A DevTools command to the page."""
        return self.call(method, session=self.session, **params)

    def open(self, url: str) -> None:
        self.page("Page.enable")
        self.page("Page.navigate", url=url)

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page."""
        result = self.page("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")

    def png(self) -> bytes:
        """The page as PNG bytes."""
        return base64.b64decode(self.page("Page.captureScreenshot", format="png")["data"])

    def close(self) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
        for fd in (self._write, self._read):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._write = self._read = -1
