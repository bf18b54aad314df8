"""One process at a time per run folder: an OS lock on ``RUN_DIR/.lock``.

`ariel run` and `ariel resume` hold ``fcntl.flock`` on that file for the whole run. The
kernel drops the lock when the process ends, however it ends (SIGKILL and power cuts
included), so a killed run never leaves a stale lock behind: the next `ariel resume` simply
takes it. The file holds the holder's pid and host name, only for the refusal message, and is
deleted when the run ends (a killed run leaves it, unlocked and harmless).

On a file system without ``flock`` support the run goes on unlocked, with a warning.

A campaign holds the lock of every run it drives, an open file each, for the whole campaign:
`ensure_open_files` checks the process's limit on open files (``ulimit -n``) before it starts,
raises it up to the hard limit where that is enough, and refuses in one line where not.

The lock file is never opened through a symbolic link (``O_NOFOLLOW``) and must be a plain file
with one name: a ``.lock`` planted in a copied run folder as a link (or a hard link) to another
file would otherwise have that file truncated. Such a ``.lock`` is refused (`UnsafePathError`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import stat
import time
import warnings
from pathlib import Path

from ariel.errors import ConfigError, RunInUseError
from ariel.recording.store._files import UnsafePathError, read_regular_file
from ariel.utils import file_kind, open_files_short

__all__ = [
    "CAMPAIGN_JSON",
    "LOCK_NAME",
    "RunInUseError",
    "RunLock",
    "ensure_open_files",
    "holder_gone",
    "in_use_error",
    "lock_holder",
]

LOCK_NAME = ".lock"
#: The lock file holds one line (``pid N on host H``): more is not read.
_LOCK_TEXT_BYTES = 4096
# A probe (`lock_holder`, e.g. from `ariel runs`) holds a shared lock for microseconds;
# retrying a few times keeps it from making a starting run refuse.
_TRIES = 4
_PAUSE_S = 0.05
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]


#: Open files a campaign process needs besides its runs' locks: Python and its libraries, the
#: campaign's own lock, the files a generation writes (measured: about 15 with a serial
#: executor, 20 with two local workers), with room to spare; and per worker (its pipes; a Dask
#: worker's sockets).
OPEN_FILES_BESIDE_RUNS = 64
OPEN_FILES_PER_WORKER = 8


def ensure_open_files(runs: int, workers: int = 1) -> None:
    """Make sure this process may open the files a campaign driving ``runs`` runs at once needs
    (one lock each, held throughout, and `OPEN_FILES_BESIDE_RUNS` + `OPEN_FILES_PER_WORKER` x
    ``workers``): raise the soft limit on open files (``ulimit -n``) towards the hard one where
    it is lower, else `ConfigError` in one line, before anything is written."""
    needed = runs + OPEN_FILES_BESIDE_RUNS + OPEN_FILES_PER_WORKER * max(workers, 1)
    most = open_files_short(needed)
    if most is None:
        return
    raise ConfigError(
        f"this campaign needs about {needed} open files ({runs} runs at once, a lock file "
        f"each, and {needed - runs} for the rest); the limit is {most} (ulimit -n): raise it "
        "with ulimit -n, or split the campaign into smaller ones"
    )


def _lock_text(path: Path) -> str:
    """The lock file's text; `ValueError` for one that is not a small regular file."""
    return read_regular_file(path, _LOCK_TEXT_BYTES).decode("utf-8")


def _holder_text(path: Path) -> str:
    with contextlib.suppress(OSError, ValueError):  # a FIFO, a device: not read
        text = _lock_text(path).strip()
        if text:
            return text
    return "another process"


#: The file that makes a folder a campaign folder (`ariel.recording.store._campaign`).
CAMPAIGN_JSON = "campaign.json"


def in_use_error(run_dir: Path, holder: str, kind: str | None = None) -> RunInUseError:
    """The one line for a run (or campaign, or ``kind``: "comparison") folder whose lock
    ``holder`` holds."""
    if kind is None:
        kind = "campaign" if os.path.lexists(Path(run_dir) / CAMPAIGN_JSON) else "run"
    return RunInUseError(
        f"{kind} folder {str(run_dir)!r} is in use by {holder}; wait for that {kind} to end "
        "(or stop it), then try again"
    )


def _probe(run_dir: str | Path) -> tuple[str, str | None]:
    """("free", None), ("held", who) or ("unknown", None); reads only, creates nothing."""
    path = Path(run_dir) / LOCK_NAME
    if fcntl is None:
        return "unknown", None
    try:
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return "free", None
    except OSError:  # a link (ELOOP) or unreadable: nothing known
        return "unknown", None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return "held", _holder_text(path)
    except OSError:  # no flock on this file system
        return "unknown", None
    finally:
        os.close(fd)  # closing also drops the probe's shared lock
    return "free", None


def lock_holder(run_dir: str | Path) -> str | None:
    """Who holds the run folder's lock (``"pid N on host H"``), or None when it is free (or
    this file system cannot tell). Reads only: nothing is created."""
    state, holder = _probe(run_dir)
    return holder if state == "held" else None


def holder_gone(run_dir: str | Path) -> bool:
    """Whether the process that ran the folder is surely gone: the one rule for showing a run
    whose run.json says "running" as stopped (``ariel runs``, campaign status, report, watch).

    Its lock is free (the kernel frees a killed process's lock at once; the probe holds a
    shared lock for microseconds, which a starting run waits out). Where this file system
    cannot tell, ``.lock`` is read instead: gone when it names a process of this host that no
    longer exists. Another host's process, or an unreadable file: False (nothing known)."""
    state, _ = _probe(run_dir)
    if state != "unknown":
        return state == "free"
    try:
        words = _lock_text(Path(run_dir) / LOCK_NAME).split()
    except (OSError, ValueError):
        return False
    # as `RunLock.acquire` writes it: "pid N on host H"
    if len(words) < 5 or words[0] != "pid" or words[-1] != socket.gethostname():
        return False
    try:
        os.kill(int(words[1]), 0)
    except ProcessLookupError:
        return True
    except (OSError, ValueError):
        return False
    return False


class RunLock:
    """The exclusive lock of one run folder; ``with RunLock(path):`` holds it.

    Making one takes nothing; ``acquire`` (or entering the ``with`` block) takes the lock and
    writes the holder's pid and host name into ``RUN_DIR/.lock``; ``release`` (or leaving the
    block) deletes that file and drops the lock.

    Args:
        run_dir: The run (or campaign) folder to lock.
        create: Whether to make the folder when it is missing (a new run), and remove it
            again on release when it is still empty (a run that refused to start). With
            False (the default) a missing folder is an error (`FileNotFoundError`).
        kind: What the folder is, for the "in use" line ("comparison"); None: a run, or a
            campaign where the folder holds campaign.json.
        wait_s: How long to wait for another holder to let go before giving up (a writer
            that holds it for a moment: two galleries into one folder); 0: at once.

    Raises:
        RunInUseError: On acquiring, when another process holds the lock.
        UnsafePathError: On acquiring, when ``.lock`` is a symbolic link, not a plain file,
            or a hard link.
    """

    def __init__(
        self,
        run_dir: str | Path,
        *,
        create: bool = False,
        kind: str | None = None,
        wait_s: float = 0.0,
    ) -> None:
        self.run_dir = Path(run_dir)
        self.path = self.run_dir / LOCK_NAME
        self.create = create
        self.kind = kind
        self.wait_s = wait_s
        self._fd: int | None = None
        self._made_folder = False

    def acquire(self) -> RunLock:
        if fcntl is None:  # pragma: no cover - not POSIX
            return self
        if self.create and not self.run_dir.is_dir():
            self._make_folder()
        for _ in range(100):
            try:
                fd = self._open()
            except FileNotFoundError:  # the last holder made the folder and removed it empty
                if not self.create:
                    raise
                self._make_folder()
                continue
            self._lock(fd)
            # The last holder deletes the file on release: a lock taken on a file that was
            # deleted meanwhile guards nothing, so take the one now at the path instead.
            try:
                current = os.stat(self.path)
            except FileNotFoundError:
                current = None
            mine = os.fstat(fd)
            if current is None or (current.st_ino, current.st_dev) != (mine.st_ino, mine.st_dev):
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.write(fd, f"pid {os.getpid()} on host {socket.gethostname()}\n".encode())
            self._fd = fd
            return self
        raise in_use_error(self.run_dir, "another process", self.kind)  # pragma: no cover

    def _make_folder(self) -> None:
        """Make the missing folder (``create``), to remove again on release if still empty."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self._made_folder = True

    def _open(self) -> int:
        """The lock file, created if missing, never through a link; `UnsafePathError` when it
        is a link, not a plain file, or a file with other names too (a hard link)."""
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | _NOFOLLOW | os.O_NONBLOCK, 0o644)
        except OSError as exc:
            if not self.path.is_symlink():
                raise
            self._cleanup_folder()
            raise self._unsafe(f"a symbolic link (to {os.readlink(self.path)!r})") from exc
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1:
            os.close(fd)
            self._cleanup_folder()
            if stat.S_ISREG(info.st_mode):
                raise self._unsafe("a hard link")
            raise self._unsafe(file_kind(info.st_mode), outside=False)
        return fd

    def _unsafe(self, what: str, *, outside: bool = True) -> UnsafePathError:
        why = (
            "which writing would change a file outside the run folder"
            if outside
            else ("not a file a run writes")
        )
        return UnsafePathError(
            f"refusing to use the lock file {str(self.path)!r}: it is {what}, {why}; remove it "
            "and try again"
        )

    def _lock(self, fd: int) -> None:
        """Take the lock on ``fd``; raises (``fd`` closed) when the run is in use."""
        assert fcntl is not None  # `acquire` refuses to lock without it
        tries = max(_TRIES, round(self.wait_s / _PAUSE_S))
        for attempt in range(tries):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except BlockingIOError:
                if attempt + 1 < tries:
                    time.sleep(_PAUSE_S)
            except OSError as exc:
                if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                    os.close(fd)
                    raise
                warnings.warn(
                    f"{self.path}: this file system cannot lock files ({exc.strerror}); "
                    "the run goes on without protection against a second run in this folder",
                    stacklevel=3,
                )
                return
        holder = _holder_text(self.path)
        os.close(fd)
        self._cleanup_folder()
        raise in_use_error(self.run_dir, holder, self.kind)

    def release(self) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            self.path.unlink()  # before unlocking: see `acquire`
        os.close(self._fd)  # drops the lock
        self._fd = None
        self._cleanup_folder()

    def _cleanup_folder(self) -> None:
        if self._made_folder:
            with contextlib.suppress(OSError):
                self.run_dir.rmdir()  # only when empty
            self._made_folder = False

    @property
    def held(self) -> bool:
        return self._fd is not None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
