"""`has_display` trusts no variable alone: a stale ``DISPLAY`` (``ssh -X`` gone, tmux, screen)
made `replay --video` try GLFW and fail with its warnings where EGL would have drawn."""

from __future__ import annotations

import socket
import sys
from pathlib import Path

import pytest
from _helpers import x_display

from ariel.utils import has_display

pytestmark = pytest.mark.skipif(sys.platform in ("darwin", "win32"), reason="X11/Wayland only")


def test_a_display_counts_only_when_it_answers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    for stale in (":4321", "unix:4321", "127.0.0.1:899.0", "nonsense", ""):
        monkeypatch.setenv("DISPLAY", stale)
        assert not has_display(), stale
    with x_display() as answering:
        monkeypatch.setenv("DISPLAY", answering)
        assert has_display()
    monkeypatch.delenv("DISPLAY")
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv("WAYLAND_DISPLAY", "wayland-7")
    assert not has_display()  # no compositor's socket
    with socket.socket(socket.AF_UNIX) as compositor:
        compositor.bind(str(tmp_path / "wayland-7"))
        assert has_display()


def test_an_image_larger_than_a_framebuffer_is_named_not_blamed_on_opengl() -> None:
    import mujoco

    from ariel.utils._gl import create_renderer

    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises(ValueError, match="at most 16384 pixels a side, got width=1000000"):
        create_renderer(model, 10**6, 10**6)  # said "no OpenGL backend available"


def test_the_no_display_line_says_which_display_does_not_answer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A stale DISPLAY (ssh -X, tmux) was said to be unset."""
    from ariel.utils import no_display_why

    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    assert no_display_why() == "DISPLAY and WAYLAND_DISPLAY are unset"
    monkeypatch.setenv("DISPLAY", ":99")
    assert no_display_why() == "DISPLAY=:99 does not answer"


def test_replay_viewer_says_which_display_does_not_answer(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ariel replay --viewer` said "DISPLAY is not set" of a DISPLAY that was set."""
    from ariel.cli import main

    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("DISPLAY", ":99")
    assert main(["replay", "no-such-run", "best", "--viewer"]) == 2
    assert "--viewer needs a display (DISPLAY=:99 does not answer)" in capsys.readouterr().err
