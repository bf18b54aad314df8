"""One exception hierarchy: every error the workbench raises on purpose is an `ArielError`.

The ``ariel`` command catches `ArielError` and prints its one-line message (exit code 2).
Each class keeps the built-in base it had before this module existed (``ValueError``,
``KeyError``, ``RuntimeError``, ...), so ``except ValueError`` clauses written against the
old classes still catch them. The classes are still importable from where they were first
defined (``ariel.plugins``, ``ariel.evolution``, ``ariel.recording``, ...).

This module is the lowest layer of the package: it imports nothing from ``ariel``.
"""

from __future__ import annotations

from typing import NoReturn

__all__ = [
    "ArielError",
    "BodyBuildError",
    "BrowserError",
    "CallTimeoutError",
    "CannotVaryError",
    "ConfigError",
    "DamagedRunError",
    "DuplicatePluginError",
    "ExecutorStartError",
    "FaceNotAvailableError",
    "GLBackendError",
    "MissingPluginError",
    "NotARunError",
    "PluginCheckError",
    "PluginFailedError",
    "PluginLoadError",
    "RunInUseError",
    "RunStorageError",
    "UnknownEvaluationError",
    "UnknownPluginError",
    "UnsafePathError",
    "ViewError",
    "WarpUnavailableError",
    "WorkerLostError",
    "cannot_vary",
]


class ArielError(Exception):
    """Base class of the workbench's own errors; the message is one line for the user."""

    def _render_traceback_(self) -> list[str]:
        """What IPython (a notebook, nbconvert) shows for it instead of a traceback: the one
        line, as the ``ariel`` command prints it. A damaged table found on first use deep in
        ``run.evaluations`` showed some 130 lines of traceback ending in that line."""
        return [f"{type(self).__name__}: {self}"]


class _PlainMessageKeyError(KeyError):
    """A ``KeyError`` that prints its message as written (``KeyError`` would quote it)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


# --------------------------------------------------------------------------------------------
# Configuration and plugins
# --------------------------------------------------------------------------------------------


class ConfigError(ArielError, ValueError):
    """A bad experiment configuration: one line naming the key and what is allowed."""


class UnknownPluginError(ArielError, _PlainMessageKeyError, ValueError):
    """A name no registered plugin or installed entry point provides.

    Both a ``KeyError`` (a failed lookup) and a ``ValueError`` (a bad config value).
    """


class DuplicatePluginError(ArielError, ValueError):
    """Two providers for one plugin name."""


class PluginLoadError(ArielError, ImportError):
    """A plugin that could not be imported, or that gave an unusable object."""


class PluginCheckError(ArielError, AssertionError):
    """A plugin that breaks its contract; the one-line message names the plugin and the fault."""


class CannotVaryError(ArielError, NotImplementedError):
    """``mutate`` or ``crossover`` of a body encoder with fixed genotypes (``evolvable`` False)."""


def cannot_vary(encoder: str) -> NoReturn:
    """Raise the error of a body encoder with fixed genotypes (``evolvable = False``).

    Call it from such an encoder's ``mutate`` and ``crossover``: returning the input unchanged
    would let an evolutionary loop run on without ever changing a body.

    Args:
        encoder: The body encoder's registered name, quoted in the message.

    Raises:
        CannotVaryError: Always.
    """
    raise CannotVaryError(
        f"body encoder {encoder!r} cannot vary its genotypes; it serves fixed bodies "
        "(evolvable is False): evolve brains only, or use an evolvable encoder such as 'nde'"
    )


# --------------------------------------------------------------------------------------------
# Bodies and evaluation
# --------------------------------------------------------------------------------------------


class FaceNotAvailableError(ArielError, _PlainMessageKeyError, ValueError):
    """A face was looked up on a module that has no site there.

    It is a ``KeyError`` (dict semantics) and a ``ValueError`` (bad input), with a readable
    one-line message.
    """


class BodyBuildError(ArielError, RuntimeError):
    """A genotype whose body cannot be built: decoding, construction, spawning or compiling failed.

    Raised by `ariel.evaluation.build` only for faults of the genotype (the cause is chained),
    never for the caller's mistakes, which propagate as they are; `evaluate_batch` turns it
    into ``error`` results, and a driver that builds bodies itself can catch just this.
    """


class GLBackendError(ArielError, RuntimeError):
    """No OpenGL backend works for rendering (``MUJOCO_GL``: EGL, OSMesa, GLFW), or ``import
    mujoco`` failed in the one ``MUJOCO_GL`` names: one line saying what to install or set."""


class WarpUnavailableError(ArielError, RuntimeError):
    """MuJoCo Warp is not installed, or the device asked for is not there (one line)."""


class WorkerLostError(ArielError, RuntimeError):
    """Workers were lost: the process running a call died every time the call was tried, or
    a cluster's workers could not start."""


class ExecutorStartError(WorkerLostError):
    """The executor's workers could not start (a local Dask cluster's): nothing ran, and a
    run or campaign folder made for it is removed again."""


class CallTimeoutError(ArielError, TimeoutError):
    """A call gave no result within its timeout (its worker was stopped, or left behind)."""


# --------------------------------------------------------------------------------------------
# Run folders and the tools that read them
# --------------------------------------------------------------------------------------------


class NotARunError(ArielError, ValueError):
    """A folder that is not an ariel run folder (no readable run.json)."""


class DamagedRunError(NotARunError):
    """A run folder whose records differ from what was written (a file missing, cut short,
    changed): one line naming the file. ``ariel verify`` lists every such file."""


class UnsafePathError(ArielError, ValueError):
    """A run folder holds a symbolic link where the workbench writes or reads: refused."""


class MissingPluginError(ArielError, LookupError):
    """Replay re-simulates with the run's plugins; one of them is not installed here."""


class PluginFailedError(ArielError, RuntimeError):
    """A plugin raised during a run: the run stopped (resumable), details in RUN/error.log."""


class RunStorageError(ArielError, RuntimeError):
    """The run folder cannot be written: disk full, read-only, no permission, not a folder.

    One line naming the file and the problem. The generations finished before it stay in
    the folder, and ``ariel resume`` continues the run once the problem is fixed.
    """


class RunInUseError(ArielError, RuntimeError):
    """Another process is running (or resuming) this run folder."""


class UnknownEvaluationError(ArielError, _PlainMessageKeyError):
    """An evaluation id that is not in the run's finished generations."""


class ViewError(ArielError):
    """Bad input or a missing file for ``ariel view``: one line for the user (exit code 2)."""


class BrowserError(ArielError):
    """No browser, or the browser stopped answering: one line for the user."""
