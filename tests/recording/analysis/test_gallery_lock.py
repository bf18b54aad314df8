"""Two galleries writing into one folder at once: one waits for the other (its lock), so the
folder holds one gallery's PNG and page, never one's PNG with the other's page."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
from _helpers import tiny_run_toml

import ariel
from ariel.recording import RunInUseError, RunLock, make_gallery


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("gallery-lock")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("lock", 2, generations=1))
    out = folder / "run"
    ariel.run_experiment(config, out=out, progress=False)
    return out


def test_a_gallery_waits_for_another_writing_into_its_folder(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "sheets"
    lock = RunLock(out, create=True, kind="gallery").acquire()  # another gallery, writing
    threading.Timer(0.5, lock.release).start()
    gallery = make_gallery(run_dir, out=out, render=False)  # waits, then writes
    assert gallery.png == out / "final.png" and gallery.png.is_file()
    assert sorted(p.name for p in out.iterdir()) == ["final.html", "final.png"]

    import ariel.recording.analysis._gallery as module

    monkeypatch.setattr(module, "_WAIT_S", 0.0)
    with RunLock(out, kind="gallery"), pytest.raises(RunInUseError, match="gallery folder"):
        make_gallery(run_dir, out=out, render=False)  # one that never lets go: one line


def test_a_killed_gallery_s_temporaries_are_removed_by_the_next(
    run_dir: Path, tmp_path: Path
) -> None:
    """A gallery killed with SIGKILL leaves ``.final.png.<token>.tmp``; a later gallery into
    the folder used to leave it there for ever."""
    import os

    out = tmp_path / "sheets"
    (out / "thumbnails").mkdir(parents=True)
    (out / ".final.png.0123abcd.tmp").write_bytes(b"half")
    old = out / "thumbnails" / ".b000001-256.png.0123abcd.tmp"
    new = out / "thumbnails" / ".b000002-256.png.4567cdef.tmp"  # another gallery's, drawing
    old.write_bytes(b"half")
    new.write_bytes(b"half")
    os.utime(old, (0, 0))
    make_gallery(run_dir, out=out, render=False)
    assert sorted(p.name for p in out.iterdir()) == ["final.html", "final.png", "thumbnails"]
    assert [p.name for p in (out / "thumbnails").iterdir()] == [new.name]
