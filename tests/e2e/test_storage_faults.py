"""A run folder that cannot be written: disk full, read-only, a path below a regular file.

Each is one line on stderr and exit code 2 naming the file and the problem; the generations
finished before it stay intact (loadable, equal to an uninterrupted run's), and `ariel resume`
finishes the run, to the uninterrupted run's records, once there is room again.

Disk full is injected (every write from a chosen one on fails with ENOSPC, as on a full
disk) and, where this machine lets the tests mount file systems (root with CAP_SYS_ADMIN),
real: a small tmpfs filled to the last byte, and a tmpfs remounted read-only.
"""

from __future__ import annotations

import contextlib
import errno
import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pandas as pd
import pytest
from _helpers import ariel_run, one_error_line, snapshot, tiny_run_toml

from ariel.cli import main
from ariel.recording import list_runs, load_run
from ariel.utils._commands import ariel_line

TOML = tiny_run_toml(
    "diskfull", 5, generations=3, iterations=2, brain="inherit = true", record='bodies = "elites"'
)

COLUMNS = ["eval_id", "generation", "fitness", "status", "controller_params", "body_genotype"]


@pytest.fixture(scope="module")
def config(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("config") / "diskfull.toml"
    path.write_text(TOML)
    return path


@pytest.fixture(scope="module")
def reference(config: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same run, never interrupted."""
    out = tmp_path_factory.mktemp("runs") / "reference"
    ariel_run(config, out)
    return out


def _records(run_dir: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    run = load_run(run_dir)
    bodies = run.bodies.drop(columns=["run_id"])
    return run.evaluations[COLUMNS].reset_index(drop=True), bodies.reset_index(drop=True)


def _assert_finished_part_intact(out: Path, reference: Path, generations: int) -> None:
    """``out`` holds exactly the reference's first ``generations`` generations, loadable."""
    assert list(out.rglob("*.tmp")) == [], "no half-written file is left"
    run = load_run(out)
    assert run.generations_done == generations
    evaluations, bodies = _records(out)
    want_evaluations, want_bodies = _records(reference)
    assert evaluations.equals(
        want_evaluations[want_evaluations["generation"] < generations].reset_index(drop=True)
    )
    assert bodies.equals(
        want_bodies[want_bodies["generation"] < generations].reset_index(drop=True)
    )


def _assert_resumes_to_reference(out: Path, reference: Path, capsys) -> None:
    assert main(["resume", str(out), "--quiet"]) == 0
    assert "finished: " in capsys.readouterr().out
    for mine, want in zip(_records(out), _records(reference), strict=True):
        pd.testing.assert_frame_equal(mine, want)
    assert sorted(p.name for p in (out / "recordings").iterdir()) == [
        p.name for p in sorted((reference / "recordings").iterdir())
    ]


# --------------------------------------------------------------------------------------------
# Injected: from one write on, the disk is full
# --------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _disk_full_from(target: Callable[[Path], bool]) -> Iterator[None]:
    """Every atomic write fails with ENOSPC once one whose path matches ``target`` starts:
    half the file written, then the error, as a full disk does."""
    import ariel.recording.rerun._rerun as rerun_files
    import ariel.recording.store._files as files
    import ariel.recording.store._tables as tables

    original = files.atomic_write
    full = False

    def atomic_write(path, write, **options):
        nonlocal full
        full = full or target(Path(path))
        if not full:
            return original(path, write, **options)

        def half_then_full(temporary: Path) -> None:
            write(temporary)
            data = temporary.read_bytes()
            temporary.write_bytes(data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")

        return original(path, half_then_full, **options)

    with pytest.MonkeyPatch.context() as patch:
        for module in (files, tables, rerun_files):
            patch.setattr(module, "atomic_write", atomic_write)
        yield


_CHECKPOINTS: list[Path] = []


def _third_checkpoint(path: Path) -> bool:
    if path.name == "state.json":
        _CHECKPOINTS.append(path)
    return len(_CHECKPOINTS) == 3


FULL_AT = {
    # What fills the disk in generation 2 (the third): its Parquet table, its first Rerun
    # recording, or its checkpoint (written after its tables).
    "table": (lambda p: p.as_posix().endswith("evaluations/gen-000002.parquet"), "evaluations"),
    "recording": (lambda p: "recordings/gen-000002/" in p.as_posix(), "recordings/gen-000002"),
    "checkpoint": (_third_checkpoint, "checkpoints/state.json"),
}


@pytest.mark.parametrize(("target", "named"), FULL_AT.values(), ids=FULL_AT)
def test_a_full_disk_stops_the_run_with_one_line_and_resume_finishes_it(
    config: Path,
    reference: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    target: Callable[[Path], bool],
    named: str,
) -> None:
    _CHECKPOINTS.clear()
    out = tmp_path / "run"
    with _disk_full_from(target):
        assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert f"cannot write '{out}/{named}" in line and "No space left on device" in line, line
    assert "its 2 finished generation(s) are kept" in line, line
    # the environment's ariel, pasteable (`ariel.utils._commands.ariel_line`)
    assert line.endswith(f"continue with: {ariel_line('resume', out)}"), line
    _assert_finished_part_intact(out, reference, generations=2)
    # Even run.json could not say "failed": `ariel runs` sees that nothing runs it.
    assert [r["status"] for r in list_runs(tmp_path)] == ["stopped (killed?)"]
    # Space is back.
    _assert_resumes_to_reference(out, reference, capsys)


def test_an_output_path_below_a_regular_file_is_one_line_and_writes_nothing(
    config: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "results"
    blocker.write_text("a file, not a folder")
    out = blocker / "run"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert f"cannot write '{out}': Not a directory; the run did not start" in line, line
    assert blocker.read_text() == "a file, not a folder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


# --------------------------------------------------------------------------------------------
# Real: a tiny tmpfs (needs the right to mount)
# --------------------------------------------------------------------------------------------


@pytest.fixture
def tmpfs(tmp_path: Path) -> Iterator[Callable[..., None]]:
    """A 16 MiB tmpfs at ``tmp_path / "disk"``; calling the fixture remounts it with options
    (e.g. ``"ro"``). Skipped where mounting is not allowed."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if os.name != "posix" or os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(disk)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip() or done.returncode}")

    def remount(options: str) -> None:
        subprocess.run(["mount", "-o", f"remount,{options}", str(disk)], check=True)

    try:
        yield remount
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def _fill(folder: Path) -> Path:
    """Write zeros into ``folder`` until its file system is full; returns the filler file."""
    filler = folder / "filler"
    with open(filler, "wb", buffering=0) as file:
        for block in (bytes(1 << 16), b"\0"):  # big blocks, then the last bytes one by one
            with contextlib.suppress(OSError):
                while file.write(block):
                    pass
    return filler


def _run_calling(after_generation: Callable[[int], None], config: Path, out: Path) -> int:
    """`ariel run` calling ``after_generation(g)`` as each generation ends; its exit code."""
    from ariel.evolution._progress import Progress

    original = Progress.end_generation

    def end_generation(self: Progress, generation: int, *args: object, **kwargs: object) -> None:
        original(self, generation, *args, **kwargs)
        after_generation(generation)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Progress, "end_generation", end_generation)
        return main(["run", str(config), "--out", str(out), "--quiet"])


def test_a_really_full_tmpfs(
    tmpfs: Callable[..., None],
    config: Path,
    reference: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    disk = tmp_path / "disk"
    out = disk / "run"
    filler: list[Path] = []

    def fill_after_two(generation: int) -> None:
        if generation == 1:  # two generations finished: now the disk fills up
            filler.append(_fill(disk))

    assert _run_calling(fill_after_two, config, out) == 2
    line = one_error_line(capsys)
    assert f"cannot write '{out}/" in line and "No space left on device" in line, line
    assert "its 2 finished generation(s) are kept" in line, line
    _assert_finished_part_intact(out, reference, generations=2)
    # Resuming on the still full disk fails the same way and loses nothing.
    assert main(["resume", str(out), "--quiet"]) == 2
    assert "No space left on device" in one_error_line(capsys)
    _assert_finished_part_intact(out, reference, generations=2)
    filler[0].unlink()  # space is back
    _assert_resumes_to_reference(out, reference, capsys)


def test_a_read_only_file_system(
    tmpfs: Callable[..., None],
    config: Path,
    reference: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    disk = tmp_path / "disk"
    out = disk / "run"

    def interrupt(generation: int) -> None:
        raise KeyboardInterrupt  # Ctrl-C once generation 0 is finished

    assert _run_calling(interrupt, config, out) == 130
    capsys.readouterr()
    tmpfs("ro")
    before = snapshot(out)
    assert main(["resume", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert f"cannot write '{out}/.lock': Read-only file system" in line, line
    assert main(["run", str(config), "--out", str(disk / "new"), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert f"cannot write '{disk / 'new'}': Read-only file system; the run did not start" in line
    assert snapshot(out) == before
    assert sorted(p.name for p in disk.iterdir()) == ["run"]
    tmpfs("rw")
    _assert_finished_part_intact(out, reference, generations=1)
    _assert_resumes_to_reference(out, reference, capsys)


def test_a_full_tmpfs_refuses_a_blueprint_instead_of_cutting_it(
    tmpfs: Callable[..., None], tmp_path: Path
) -> None:
    """Rerun's blueprint writer only logs a full disk (and leaves a cut file): ariel checks
    the free space first."""
    from ariel.recording import write_blueprint

    disk = tmp_path / "disk"
    _fill(disk)
    with pytest.raises(OSError) as raised:
        write_blueprint(disk / "blueprint.rbl")
    assert raised.value.errno == errno.ENOSPC
    assert sorted(p.name for p in disk.iterdir()) == ["filler"]


# --------------------------------------------------------------------------------------------
# Which errors are the storage's
# --------------------------------------------------------------------------------------------


def test_atomic_write_names_the_file_of_nameless_and_rerun_errors(tmp_path: Path) -> None:
    from ariel.recording.store._files import atomic_write

    def pyarrow_like(temporary: Path) -> None:
        raise OSError(errno.ENOSPC, "Error writing bytes to file")

    def rerun_like(temporary: Path) -> None:
        raise RuntimeError("Failed to write: No space left on device (os error 28)")

    for write in (pyarrow_like, rerun_like):
        with pytest.raises(OSError) as raised:
            atomic_write(tmp_path / "x.parquet", write)
        assert (raised.value.errno, raised.value.filename) == (
            errno.ENOSPC,
            str(tmp_path / "x.parquet"),
        )
    assert list(tmp_path.iterdir()) == []

    def broken(temporary: Path) -> None:
        raise RuntimeError("a bug, not a file problem")

    with pytest.raises(RuntimeError, match="a bug, not a file problem"):  # passes unchanged
        atomic_write(tmp_path / "y", broken)


STORAGE_CASES = {
    "full, unnamed": (OSError(errno.ENOSPC, "No space left on device"), True),
    "quota, in the run": (OSError(errno.EDQUOT, "Disk quota exceeded", "{run}/run.json"), True),
    "read-only, in the run": (OSError(errno.EROFS, "Read-only file system", "{run}/.lock"), True),
    "no permission, in the run": (
        PermissionError(errno.EACCES, "Permission denied", "{run}/x"),
        True,
    ),
    "no permission, a parent": (PermissionError(errno.EACCES, "Permission denied", "{root}"), True),
    "no permission, unnamed": (PermissionError(errno.EACCES, "Permission denied"), False),
    "no permission, elsewhere": (
        PermissionError(errno.EACCES, "Permission denied", "/etc/x"),
        False,
    ),
    "not the disk": (ConnectionRefusedError(errno.ECONNREFUSED, "Connection refused"), False),
    "missing input": (FileNotFoundError(errno.ENOENT, "No such file", "{run}/x"), False),
}


@pytest.mark.parametrize(("error", "ours"), STORAGE_CASES.values(), ids=STORAGE_CASES)
def test_storage_errors_converts_only_failed_writes_in_the_run_folder(
    tmp_path: Path, error: OSError, ours: bool
) -> None:
    from ariel.recording import RunStorageError
    from ariel.recording.store._run_folder import storage_errors

    run = tmp_path / "runs" / "r"
    if error.filename:
        error.filename = error.filename.format(run=run, root=tmp_path)
    with pytest.raises(RunStorageError if ours else type(error)) as raised, storage_errors(run):
        raise error
    if ours:
        message = str(raised.value)
        assert "\n" not in message and message.startswith("cannot write '")
        assert message.endswith("; the run did not start")  # no run.json there
        assert raised.value.__cause__ is error
    else:
        assert raised.value is error


def test_a_campaign_on_a_full_disk_says_how_to_resume_it(tmp_path: Path, capsys) -> None:
    """It said "the run did not start" (campaign.json is no run.json), with no resume line,
    after every run's first generation had finished."""
    from _helpers import REPO

    out = tmp_path / "campaign"
    tiny = REPO / "tests" / "data" / "campaign_tiny.toml"
    second = lambda p: p.as_posix().endswith("evaluations/gen-000001.parquet")  # noqa: E731
    with _disk_full_from(second):
        assert main(["campaign", "run", str(tiny), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert "gen-000001.parquet': No space left on device; the campaign stopped" in line, line
    assert line.endswith(f"continue with: {ariel_line('campaign', 'resume', out)}"), line
    assert main(["campaign", "resume", str(out), "--quiet"]) == 0
    assert "4 of 4 runs finished" in capsys.readouterr().out
