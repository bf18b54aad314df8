"""A plugin that raised during a run: the run stops with one line, the traceback in
``RUN/error.log`` (written here: the run folder is this layer's)."""

from __future__ import annotations

import traceback
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import TYPE_CHECKING

from ariel.errors import ConfigError, NotARunError, PluginFailedError, UnknownPluginError
from ariel.evolution import ERROR_LOG, ExperimentConfig, plugin_named
from ariel.recording.store._files import atomic_write_bytes
from ariel.recording.store._run_folder import RunFolder, resume_line
from ariel.utils import ariel_line

if TYPE_CHECKING:
    from ariel.evaluation import EvaluationTask

__all__ = ["plugin_failure"]


def plugin_failure(
    run_dir: str | Path,
    config: ExperimentConfig,
    task: EvaluationTask | None,
    exc: BaseException,
) -> PluginFailedError:
    """The `PluginFailedError` for ``exc``, raised evaluating ``task`` (None: raised by the
    body optimizer, or a learner's state that is not plain data, between evaluations);
    writes the full traceback (with the worker's, when it came from one) to ``RUN/error.log``
    first."""
    if isinstance(exc, BrokenProcessPool):  # the pool, not an evaluation, failed
        return PluginFailedError(f"the executor's workers failed: {exc}")
    first = (f"{type(exc).__name__}: {exc}".splitlines() or [""])[0]
    text = "".join(traceback.format_exception(exc))
    log = Path(run_dir) / ERROR_LOG
    where = f"; full traceback in {log}"
    try:
        head = "between evaluations" if task is None else f"evaluation {task.eval_id}"
        atomic_write_bytes(log, f"{head}\n{text}".encode(), root=run_dir)
    except (OSError, ValueError):  # the folder cannot take it: the line alone must do
        where = ""
    plugin = plugin_named(config, text)
    if (
        isinstance(exc, UnknownPluginError) and task is not None
    ):  # checked here, so unknown to the worker alone
        return PluginFailedError(
            f"evaluation {task.eval_id}: a worker process does not know a plugin this process "
            f"knows ({first}): it was registered where workers do not run it (under `if "
            '__name__ == "__main__":`, in a notebook cell): register it at the top level of '
            "the script or of a module it imports (docs/plugins.md), or run on executor "
            f'"serial"; the run stopped, its finished generations are kept{where}'
        )
    try:
        resume = resume_line(Path(run_dir), RunFolder(run_dir).read_info())
    except NotARunError:
        resume = ariel_line("resume", run_dir)
    if isinstance(exc, ConfigError):  # a setting, or a worker's environment: no plugin's fault
        at = "between evaluations" if task is None else f"in evaluation {task.eval_id}"
        return PluginFailedError(
            f"{at}: {first}{where}; the run stopped, its finished generations are kept: set it "
            f"right (where the evaluation ran: a Dask worker's environment), then {resume}"
        )
    # A brain optimizer fails asking for or told a batch, not in one of its evaluations; the
    # body optimizer between generations (its note says what it gave, where that was wrong).
    if task is None:
        notes = [n for n in getattr(exc, "__notes__", ()) if n.startswith(f"raised by {plugin}")]
        what = notes[-1].partition(": ")[2] if notes else ""
        at = f"between evaluations ({what})" if what else "between evaluations"
    elif plugin.startswith("brain optimizer"):
        at = f"at the batch of evaluation {task.eval_id}"
    else:
        at = f"in evaluation {task.eval_id}"
    return PluginFailedError(
        f"{plugin} failed {at}: {first}{where}; "
        f"the run stopped, its finished generations are kept: fix the plugin, then {resume}"
    )
