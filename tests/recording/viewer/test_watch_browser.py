"""A real browser opens ``ariel watch RUN --web``: the page connects to the watcher's viewer and
shows the live recording. Asserted on what the page exposes, not on pixels: its connection to
the gRPC proxy (the server's sockets) and the viewer's own state (``_handle.viewer_state()`` of
Rerun's page: the recordings it holds, their timelines, the views of the layout)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

psutil = pytest.importorskip("psutil")

from ariel.recording.viewer._browser import BrowserError, HeadlessChromium, find_chromium  # noqa: E402

RUN = Path(__file__).resolve().parents[2] / "data" / "run_tiny.toml"


def _chromium() -> Path | None:
    try:
        return find_chromium()
    except BrowserError:
        return None


CHROMIUM = _chromium()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny run (2 generations, a few seconds)."""
    out = tmp_path_factory.mktemp("browser") / "tiny-watched"
    command = ["run", str(RUN), "--set", "generations=2", "--out", str(out), "--quiet"]
    subprocess.run([sys.executable, "-m", "ariel.cli", *command], check=True, capture_output=True)
    return out


def _viewer_state(browser: HeadlessChromium) -> list[str]:
    """The texts in the viewer's state (a protobuf message: each text after its length,
    which may read as a character too): recording ids, timelines, views."""
    state = browser.evaluate("window._handle ? Array.from(window._handle.viewer_state()) : null")
    return [t.decode() for t in re.findall(rb"[\x20-\x7e]{4,}", bytes(state or []))]


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium or Chrome to run headless")
@pytest.mark.soak  # a headless browser: ~20 s, with the soak tests
def test_a_browser_opens_the_live_view_and_it_shows_the_run(run_dir: Path, tmp_path: Path) -> None:
    command = ["watch", str(run_dir), "--web", "--port", "0", "--grpc-port", "0"]
    watcher = subprocess.Popen(
        [sys.executable, "-m", "ariel.cli", *command],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    browser = None
    try:
        url = None
        for line in watcher.stdout:  # type: ignore[union-attr]
            found = re.search(r"http://127\.0\.0\.1:\d+/\?url=\S+", line)
            if found:
                url = found.group(0)
                break
        assert url is not None, "the watcher printed no address"
        grpc = int(re.search(r"127\.0\.0\.1%3A(\d+)", url).group(1))  # type: ignore[union-attr]
        (server,) = psutil.Process(watcher.pid).children()  # the rerun viewer it started
        assert {c.laddr.ip for c in server.net_connections("inet") if c.status == "LISTEN"} == {
            "127.0.0.1"
        }
        browser = HeadlessChromium(tmp_path / "profile", binary=CHROMIUM)
        browser.open(url)
        # The page runs the viewer, which holds the watcher's recording (id: the folder's
        # name) with its data's timelines, laid out by the watcher's blueprint.
        expected = [
            f"Recording:ariel:{run_dir.name}",
            "generation",
            "sim_time",
            "lineage (bright: fitter)",
            "/fitness",
        ]
        deadline = time.monotonic() + 90
        missing = expected
        while missing and time.monotonic() < deadline:
            time.sleep(0.5)
            texts = _viewer_state(browser)
            missing = [e for e in expected if not any(e in text for text in texts)]
        assert not missing, f"the viewer's state lacks {missing}: {texts}"
        # ...received over its connection to the viewer's gRPC proxy.
        clients = [
            c
            for c in server.net_connections("inet")
            if c.status == psutil.CONN_ESTABLISHED and c.laddr.port == grpc
        ]
        assert len(clients) >= 2, "no browser connection to the gRPC proxy"  # the watcher's too
    finally:
        if browser is not None:
            browser.close()
        if watcher.poll() is None:
            os.killpg(watcher.pid, signal.SIGINT)  # Ctrl-C
        assert watcher.wait(timeout=60) == 0
