"""The best body so far of a watched run, walking in the live view (`BestBody`).

It is the run's best evaluation (status ok, finite fitness; ties: the earlier) among the
generations shown. Its own recording (``recordings/gen-NNNNNN/<eval_id>.rrd``, written by the
loop for an elite with ``record.rerun``) is shown when it holds the bodies' poses; else it is
re-simulated with `ariel.recording.replay` in a thread (so polling goes on meanwhile) and its
full-rate recording written to a `tempfile` folder, never into the run. When a better one is
found, the old one's entity tree is cleared (``Clear(recursive=True)``) and the new one's
chunks are sent under the same prefix with fresh row ids.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from ariel.errors import UnknownEvaluationError
from ariel.recording.resim import replay
from ariel.recording.store import NotARunError, check_eval_id, recording_path
from ariel.recording.viewer._rerun_files import recording_chunks

__all__ = ["BestBody", "fresh_chunks"]


def fresh_chunks(chunks: Iterable[Chunk], prefix: str) -> list[Chunk]:
    """``chunks`` moved under entity ``prefix`` with fresh row ids (newer than a `Clear`
    logged before: a recording's own row ids are as old as its file). Recording properties
    are left out."""
    moved: list[Chunk] = []
    for chunk in chunks:
        if chunk.entity_path.startswith("/__properties"):
            continue
        batch = chunk.to_record_batch()
        kinds = [(f.metadata or {}).get(b"rerun:kind") for f in batch.schema]
        batch = batch.select([i for i, kind in enumerate(kinds) if kind != b"control"])
        meta = {k: v for k, v in (batch.schema.metadata or {}).items() if k != b"rerun:id"}
        meta[b"rerun:entity_path"] = (prefix.rstrip("/") + chunk.entity_path).encode()
        extra = {"index": None} if chunk.is_static else {}
        moved += Chunk.from_record_batch(batch.replace_schema_metadata(meta), **extra)
    return moved


def _poses_of(path: Path) -> list[Chunk] | None:
    """The chunks of an evaluation's recording at ``path`` when it holds the bodies' poses
    over time (a 3D replay), else None (no file, an unreadable one, another evaluation's
    copied over it, a robot standing still)."""
    chunks = recording_chunks(path)  # read quietly: no Rerun warning printed
    if chunks is None:
        return None
    moving = any(c.entity_path == "/world/robot" and not c.is_static for c in chunks)
    return chunks if moving else None


class BestBody:
    """The best evaluation so far of the run in ``run_dir``, shown under entity ``prefix``
    (``/world``, ``/joints``, ``/graph`` of its recording, and ``info``: a text)."""

    def __init__(self, run_dir: str | os.PathLike[str], maximise: bool, prefix: str = "/best"):
        self.run_dir = Path(run_dir)
        self.maximise = maximise
        self.prefix = prefix.rstrip("/")
        self.best: tuple[float, str, int] | None = None  # fitness, eval id, generation
        self._shown: str | None = None
        self._job: dict[str, Any] | None = None  # a replay under way in a thread
        self._scratch: str | None = None

    @property
    def settled(self) -> bool:
        """Whether the best so far is shown (or there is none) and no replay is under way."""
        return self._job is None and (self.best is None or self._shown == self.best[1])

    def offer(self, evaluations: Any, generation: int) -> None:
        """Note a generation's evaluations (``eval_id``, ``fitness``, ``status``): its best
        when it beats the best so far."""
        ok = evaluations[(evaluations["status"] == "ok") & np.isfinite(evaluations["fitness"])]
        if not len(ok):
            return
        top = ok.sort_values("fitness", ascending=not self.maximise, kind="stable")
        fitness, eval_id = float(top["fitness"].iloc[0]), str(top["eval_id"].iloc[0])
        best = self.best
        if best is None or (fitness > best[0] if self.maximise else fitness < best[0]):
            self.best = (fitness, eval_id, generation)

    def update(self, rec: rr.RecordingStream, *, ended: bool = False) -> bool:
        """Show a better evaluation: its own recording now, else its 3D replay (made in a
        thread, shown by the update that finds it done); True when anything was logged.
        ``ended``: the run has ended (a replay that waits for run.json to count its
        generation gives up)."""
        if self._job is not None:
            if self._job["thread"].is_alive():
                return False
            job, self._job = self._job, None
            if job.get("again") and ended:  # killed between its manifest and run.json
                job["error"] = "the run ended before run.json counted its generation"
            elif job.get("again"):
                return False  # the next update starts it again
            return self._show(rec, job)
        if self.best is None or self.settled:
            return False
        best = self.best
        try:
            own = recording_path(self.run_dir, best[2], check_eval_id(best[1], self.run_dir))
        except NotARunError:
            return self._show(rec, {"best": best, "error": "a crafted evaluation id"})
        chunks = _poses_of(own)
        if chunks is not None:
            return self._show(rec, {"best": best, "chunks": chunks, "how": "its own recording"})
        self._replay(best)
        return False

    def _replay(self, best: tuple[float, str, int]) -> None:
        if self._scratch is None:
            self._scratch = tempfile.mkdtemp(prefix="ariel-watch-")
        scratch, eval_id = Path(self._scratch), best[1]
        job: dict[str, Any] = {"best": best, "how": "a 3D replay re-simulated here"}

        def work() -> None:
            try:
                made = replay(self.run_dir, eval_id).write_rrd(scratch / f"{eval_id}.rrd")
                job["chunks"] = _poses_of(made)
                made.unlink(missing_ok=True)
            except UnknownEvaluationError:  # run.json lags its newest manifest: try again
                job["again"] = True
            except Exception as exc:  # a plugin not installed here, a body that cannot build
                job["error"] = (str(exc).splitlines() or [type(exc).__name__])[0]

        job["thread"] = threading.Thread(target=work, name="ariel-watch-replay", daemon=True)
        job["thread"].start()
        self._job = job

    def _show(self, rec: rr.RecordingStream, job: dict[str, Any]) -> bool:
        (fitness, eval_id, generation), chunks = job["best"], job.get("chunks")
        chunks = None if job.get("error") else chunks
        rec.log(self.prefix, rr.Clear(recursive=True), static=True)
        if chunks is not None:
            rec.send_chunks(fresh_chunks(chunks, self.prefix))
        how = job.get("how") if chunks is not None else f"not drawn: {job.get('error')}"
        text = f"best so far: evaluation {eval_id} (generation {generation}), fitness {fitness:.6g}"
        rec.log(f"{self.prefix}/info", rr.TextDocument(f"{text}\n\n3D: {how}"), static=True)
        self._shown = eval_id
        return True

    def close(self) -> None:
        """Remove the scratch folder of 3D replays."""
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)
            self._scratch = None
