"""One error hierarchy: every error the workbench raises on purpose is an `ArielError`, still
importable from where it was first defined, still caught by the ``except`` clauses written for
its old built-in base; the ``ariel`` command turns any of them into one line and exit code 2."""

from __future__ import annotations

import importlib
import pickle
import subprocess
import sys
from pathlib import Path

import pytest
from _helpers import one_error_line

from ariel import errors
from ariel.cli import main
from ariel.errors import ArielError

# class name -> (the modules that exported it before ariel.errors, the built-in bases it kept)
OLD_HOMES: dict[str, tuple[tuple[str, ...], tuple[type[BaseException], ...]]] = {
    "ConfigError": (("ariel.evolution", "ariel.evolution._config"), (ValueError,)),
    "UnknownPluginError": (("ariel.plugins",), (KeyError, ValueError)),
    "DuplicatePluginError": (("ariel.plugins",), (ValueError,)),
    "PluginLoadError": (("ariel.plugins",), (ImportError,)),
    "PluginCheckError": (("ariel.plugins",), (AssertionError,)),
    "CannotVaryError": ((), (NotImplementedError,)),
    "FaceNotAvailableError": (
        ("ariel.body_phenotypes.robogen_lite.modules.module",),
        (KeyError, ValueError),
    ),
    "BodyBuildError": (("ariel.evaluation", "ariel.evaluation._engine"), (RuntimeError,)),
    "GLBackendError": (("ariel.utils._gl",), (RuntimeError,)),
    "WarpUnavailableError": (("ariel.evaluation._warp",), (RuntimeError,)),
    "WorkerLostError": (("ariel.evaluation._pool", "ariel.evaluation.executors"), (RuntimeError,)),
    "CallTimeoutError": (("ariel.evaluation._pool", "ariel.evaluation.executors"), (TimeoutError,)),
    "ExecutorStartError": ((), (RuntimeError,)),  # new with it: a WorkerLostError, as it was
    "NotARunError": (("ariel.recording", "ariel.recording.store._run_folder"), (ValueError,)),
    "RunStorageError": (("ariel.recording", "ariel.recording.store._run_folder"), (RuntimeError,)),
    "RunInUseError": (("ariel.recording", "ariel.recording.store._lock"), (RuntimeError,)),
    "UnknownEvaluationError": (("ariel.recording.resim._replay",), (KeyError,)),
    "ViewError": (("ariel.recording.viewer._view",), ()),
    "BrowserError": (("ariel.recording.viewer._browser",), ()),
    "DamagedRunError": (("ariel.recording", "ariel.recording.store._run_folder"), (ValueError,)),
    "UnsafePathError": (("ariel.recording", "ariel.recording.store._files"), (ValueError,)),
    "MissingPluginError": (("ariel.recording.resim._replay",), (LookupError,)),
    "PluginFailedError": (("ariel.evolution._checks",), (RuntimeError,)),
}

ERROR_CLASSES = [name for name in errors.__all__ if name[0].isupper() and name != "ArielError"]


def test_the_table_above_covers_every_error_class() -> None:
    assert sorted(OLD_HOMES) == sorted(ERROR_CLASSES)


@pytest.mark.parametrize("name", ERROR_CLASSES)
def test_every_error_is_an_ariel_error_with_its_old_base(name: str) -> None:
    cls = getattr(errors, name)
    homes, bases = OLD_HOMES[name]
    assert issubclass(cls, ArielError)
    for base in bases:  # existing ``except ValueError`` etc. still catch it
        assert issubclass(cls, base), f"{name} lost its base {base.__name__}"
    for home in homes:  # one class, importable from where it was defined before
        assert getattr(importlib.import_module(home), name) is cls, f"{home}.{name}"
    error = cls("something went wrong")
    assert str(error) == "something went wrong"  # KeyError-based ones too: not quoted
    copy = pickle.loads(pickle.dumps(error))  # errors cross process boundaries (workers)
    assert type(copy) is cls and str(copy) == "something went wrong"


def test_cannot_vary_raises_not_implemented_naming_the_encoder() -> None:
    with pytest.raises(NotImplementedError, match="body encoder 'prebuilt' cannot vary"):
        errors.cannot_vary("prebuilt")
    from ariel.plugins import cannot_vary

    assert cannot_vary is errors.cannot_vary


def test_errors_module_imports_nothing_from_ariel() -> None:
    code = (
        "import sys, ariel.errors\n"
        "print(sorted(m for m in sys.modules if m.partition('.')[0] == 'ariel'))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    # ``ariel`` (the package) and its version module load with any submodule.
    assert out.strip() == "['ariel', 'ariel._version', 'ariel.errors']"


class _NewKindOfError(ArielError):
    """A subclass the CLI has never heard of: caught through the base class alone."""


@pytest.mark.parametrize("error", [_NewKindOfError, errors.RunStorageError, errors.ViewError])
def test_the_cli_turns_any_ariel_error_into_one_line_and_exit_2(
    error: type[ArielError],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import ariel.recording

    def broken_list_runs(folder: object) -> list[dict[str, object]]:
        raise error("the run index cannot be read: disk on fire")

    monkeypatch.setattr(ariel.recording, "list_runs", broken_list_runs)
    assert main(["runs", str(tmp_path)]) == 2
    line = one_error_line(capsys, quiet=True)
    assert line == "ariel: error: the run index cannot be read: disk on fire"


def test_the_cli_does_not_swallow_errors_that_are_not_ariel_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ariel.recording

    def buggy_list_runs(folder: object) -> list[dict[str, object]]:
        raise ZeroDivisionError("a bug, not bad input")

    monkeypatch.setattr(ariel.recording, "list_runs", buggy_list_runs)
    with pytest.raises(ZeroDivisionError):  # a bug keeps its traceback
        main(["runs", str(tmp_path)])


def test_a_notebook_shows_an_ariel_error_as_its_one_line() -> None:
    """IPython printed some 130 lines of traceback for a damaged table a notebook cell found
    (`run.evaluations`), and for a comparison refused; the promise is one line."""
    from ariel.errors import ArielError, DamagedRunError
    from ariel.recording.analysis import CompareError

    damaged = DamagedRunError("run folder 'r' is damaged: evaluations/gen-000001.parquet ...")
    assert damaged._render_traceback_() == [f"DamagedRunError: {damaged}"]
    assert isinstance(CompareError("x"), ArielError) and isinstance(CompareError("x"), ValueError)
    assert CompareError("no pair")._render_traceback_() == ["CompareError: no pair"]
