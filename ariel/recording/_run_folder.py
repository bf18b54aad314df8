"""One run = one folder: ``run.json``, Parquet tables per generation, checkpoints.

``run.json`` holds the resolved config, its hash, the seed, versions, the git commit,
plugin provenance, status and times; it never holds an absolute path of this machine, so a
run folder copied elsewhere still loads. The checkpoint (``checkpoints/state.pkl``) holds
exactly what resume needs; it is replaced atomically after every generation's tables.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import importlib.metadata
import json
import pickle
import platform
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

from ariel.recording._files import (
    TEMP_SUFFIX,
    atomic_write_bytes,
    atomic_write_json,
    remove_temporaries,
)
from ariel.recording._tables import TABLES, generation_file, table_generations

__all__ = [
    "CHECKPOINT_FORMAT",
    "RUN_FORMAT",
    "NotARunError",
    "RunFolder",
    "now",
    "software_versions",
]

RUN_FORMAT = 1
CHECKPOINT_FORMAT = 1
_VERSIONED = ("ariel", "mujoco", "numpy", "torch", "cma", "pyarrow", "pandas", "rerun-sdk")


def _is_temporary(path: Path) -> bool:
    return path.is_file() and path.name.startswith(".") and path.name.endswith(TEMP_SUFFIX)


class NotARunError(ValueError):
    """A folder that is not an ariel run folder (no readable run.json)."""


def now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def software_versions() -> dict[str, str | None]:
    """Installed versions of what decides results (read from metadata; nothing imported)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def git_commit() -> str | None:
    """The commit of the ariel source checkout, when running from one (else None)."""
    source = Path(__file__).resolve().parents[2]
    if not (source / ".git").exists():
        return None
    try:
        out = subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
        dirty = subprocess.run(
            ["git", "-C", str(source), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


class RunFolder:
    """Reads and writes one run folder."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    # -- paths ---------------------------------------------------------------------------------

    @property
    def run_json(self) -> Path:
        return self.path / "run.json"

    @property
    def checkpoint(self) -> Path:
        return self.path / "checkpoints" / "state.pkl"

    # -- creation ------------------------------------------------------------------------------

    @staticmethod
    def check_new(path: str | Path, *, overwrite: bool) -> None:
        """Raise `FileExistsError` unless ``path`` may become a new run folder.

        An existing non-empty folder needs ``overwrite``, and is only ever replaced when it
        is a run folder (never an arbitrary directory).
        """
        path = Path(path)
        if path.exists() and not path.is_dir():
            raise FileExistsError(f"output {str(path)!r} exists and is not a folder")
        # A folder holding only a killed writer's temporaries (killed while being created)
        # counts as empty.
        if not path.is_dir() or all(_is_temporary(p) for p in path.iterdir()):
            return
        if not overwrite:
            raise FileExistsError(
                f"output folder {str(path)!r} already exists; pass --overwrite to replace it, "
                "or `ariel resume` to continue it"
            )
        if not (path / "run.json").is_file():
            raise FileExistsError(
                f"refusing to overwrite {str(path)!r}: it is not an ariel run folder (no run.json)"
            )

    @classmethod
    def create(cls, path: str | Path, info: dict[str, Any], *, overwrite: bool) -> RunFolder:
        cls.check_new(path, overwrite=overwrite)
        path = Path(path)
        if path.is_dir() and any(path.iterdir()):
            shutil.rmtree(path)  # a run folder (check_new refuses anything else) or temporaries
        path.mkdir(parents=True, exist_ok=True)
        folder = cls(path)
        folder.write_info({"format": RUN_FORMAT, **info})
        return folder

    # -- run.json ------------------------------------------------------------------------------

    def read_info(self) -> dict[str, Any]:
        try:
            info = json.loads(self.run_json.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise NotARunError(
                f"{str(self.path)!r} is not an ariel run folder (no run.json)"
            ) from None
        except (OSError, ValueError) as exc:
            raise NotARunError(f"{self.run_json}: unreadable run.json ({exc})") from None
        if not isinstance(info, dict) or info.get("format") != RUN_FORMAT:
            raise NotARunError(f"{self.run_json}: not a run.json of format {RUN_FORMAT}")
        return info

    def write_info(self, info: dict[str, Any]) -> None:
        atomic_write_json(self.run_json, info)

    def update_info(self, **changes: Any) -> dict[str, Any]:
        info = self.read_info()
        info.update(changes)
        self.write_info(info)
        return info

    # -- checkpoints ---------------------------------------------------------------------------

    def save_checkpoint(self, state: Any) -> None:
        payload = {"format": CHECKPOINT_FORMAT, "state": state}
        atomic_write_bytes(self.checkpoint, pickle.dumps(payload, protocol=5))

    def load_checkpoint(self) -> Any | None:
        """The last saved state, or None when no generation finished yet."""
        if not self.checkpoint.is_file():
            return None
        payload = pickle.loads(self.checkpoint.read_bytes())
        if payload.get("format") != CHECKPOINT_FORMAT:
            raise NotARunError(f"{self.checkpoint}: checkpoint format {payload.get('format')}")
        return payload["state"]

    # -- tables --------------------------------------------------------------------------------

    def generations_on_disk(self, table: str = "evaluations") -> list[int]:
        return table_generations(self.path, table)

    def discard_after(self, generation: int) -> list[Path]:
        """Delete table files and Rerun recordings of generations after ``generation``, and
        temporaries (resume)."""
        removed = list(remove_temporaries(self.path))
        for table in TABLES:
            for gen in table_generations(self.path, table):
                if gen > generation:
                    path = generation_file(self.path, table, gen)
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
                    removed.append(path)
        recordings = self.path / "recordings"
        if recordings.is_dir():
            for folder in sorted(recordings.iterdir()):
                found = re.fullmatch(r"gen-(\d{6})", folder.name)
                if found and int(found.group(1)) > generation and folder.is_dir():
                    shutil.rmtree(folder, ignore_errors=True)
                    removed.append(folder)
        return removed
