"""Which run (or campaign) a notebook in analysis/ looks at; the notebooks import it from here
(their kernel runs in analysis/, beside this file).

- A folder named in the notebook (``RUN_DIR``) or by the environment (``ARIEL_RUN_DIR``,
  ``ARIEL_CAMPAIGN_DIR``; the environment wins). A relative path is taken from the folder the
  command was typed in (``$PWD``, which Jupyter passes on to its kernel unchanged), else from
  the kernel's folder (analysis/), else from the repository root: so
  ``ARIEL_RUN_DIR=data/runs/<id> .venv/bin/jupyter nbconvert ... analysis/x.ipynb`` at the
  repository root reads ``<root>/data/runs/<id>``, not ``analysis/data/runs/<id>``.
- Else the newest finished run under ``<root>/data/runs`` (by run.json's ``created``); without
  one, the newest run with a finished generation. Runs newer than the one chosen (interrupted,
  killed, still running) are named as passed over.
- A folder that is not there, or not a run, is a `ChoiceError`: one line in the notebook (and
  at the end of nbconvert's output), not a traceback.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: The repository root: analysis/ sits in it.
REPO = Path(__file__).resolve().parent.parent


class ChoiceError(Exception):
    """The run or campaign to look at is not there: shown by IPython as its one-line message."""

    def _render_traceback_(self) -> list[str]:  # IPython shows this instead of a traceback
        return [f"error: {self}"]


@dataclass(frozen=True)
class Choice:
    """The folder chosen and why, in words (``why`` is printed by the notebooks)."""

    path: Path
    why: str


def resolve(
    value: str | os.PathLike[str],
    *,
    name: str,
    environ: Mapping[str, str] | None = None,
    cwd: str | os.PathLike[str] | None = None,
) -> Path:
    """``value`` as an absolute folder: relative paths are tried from ``$PWD``, then ``cwd``
    (default: this process's), then the repository root. `ChoiceError` if none is a folder."""
    environ = os.environ if environ is None else environ
    path = Path(value).expanduser()
    if path.is_absolute():
        candidates = [path]
    else:
        bases = [environ.get("PWD"), Path.cwd() if cwd is None else cwd, REPO]
        candidates = []
        for base in bases:
            if base and Path(base).is_absolute() and Path(base) / path not in candidates:
                candidates.append(Path(base) / path)
    for candidate in candidates:
        if candidate.is_dir():
            # The folder the OS opens: `link/../r` is r beside the link's target, not beside
            # the link (normpath's reading, as text), which may be another run.
            return Path(os.path.realpath(candidate))
    looked = ", ".join(str(c) for c in candidates)
    what = "a file, not a folder" if any(c.exists() for c in candidates) else "no such folder"
    where = "" if path.is_absolute() else f" (looked in {looked})"
    raise ChoiceError(f"{name}={value}: {what}{where}")


def _key(run: Mapping[str, Any]) -> tuple[str, str]:
    return (run["created"] or "", run["path"])


def newest_run(root: str | os.PathLike[str]) -> Choice:
    """The newest finished run under ``root``, else the newest with a finished generation."""
    from ariel.recording import list_runs

    root = Path(root)
    runs = list_runs(root)
    done = [r for r in runs if (r["generations_done"] or 0) > 0]
    finished = [r for r in done if r["status"] == "finished"]
    if finished:
        chosen, why = max(finished, key=_key), f"the newest finished run under {root}"
    elif done:
        chosen = max(done, key=_key)
        why = f"no finished run under {root}: the newest with a finished generation"
    else:
        empty = "no run" if not runs else f"no run with a finished generation ({len(runs)} without)"
        raise ChoiceError(
            f"{empty} under {root}: `make run` first, or name a run folder in RUN_DIR or "
            "ARIEL_RUN_DIR"
        )
    newer = sorted((r for r in runs if _key(r) > _key(chosen)), key=_key, reverse=True)
    if newer:
        names = ", ".join(
            f"{r['run_id']} ({r['status']}, {r['generations_done']} generations)" for r in newer
        )
        why += f"; passed over, newer: {names}"
    return Choice(Path(chosen["path"]), why)


def _given(
    name: str,
    value: str | os.PathLike[str] | None,
    environ: Mapping[str, str] | None,
    cwd: str | os.PathLike[str] | None,
) -> Choice | None:
    """The folder named by ``ARIEL_<name>`` (it wins), else by the notebook's ``<name>``
    (``value``), resolved (`resolve`); None where neither names one."""
    environ = os.environ if environ is None else environ
    variable = f"ARIEL_{name}"
    if environ.get(variable):
        named = environ[variable]
        return Choice(
            resolve(named, name=variable, environ=environ, cwd=cwd), f"{variable}={named}"
        )
    if value is not None:
        path = resolve(value, name=name, environ=environ, cwd=cwd)
        return Choice(path, f"{name} = {str(value)!r}")
    return None


def _opened(choice: Choice, load: Any) -> tuple[Any, Choice]:
    """``load(choice.path)`` and the choice; `ChoiceError` with the loader's one-line message
    for a folder that is not what it reads (or a damaged one)."""
    from ariel.errors import ArielError

    try:
        return load(choice.path), choice
    except ArielError as error:
        raise ChoiceError(f"{choice.why}: {error}") from None


def choose_run(
    run_dir: str | os.PathLike[str] | None = None,
    *,
    environ: Mapping[str, str] | None = None,
    cwd: str | os.PathLike[str] | None = None,
    root: str | os.PathLike[str] | None = None,
) -> Choice:
    """The run folder a notebook reads: ``ARIEL_RUN_DIR``, else ``run_dir``, else the newest
    finished run under ``root`` (default ``<repository>/data/runs``)."""
    given = _given("RUN_DIR", run_dir, environ, cwd)
    if given is not None:
        return given
    return newest_run(REPO / "data" / "runs" if root is None else root)


def open_run(run_dir: str | os.PathLike[str] | None = None, **choose: Any) -> tuple[Any, Choice]:
    """`load_run` of `choose_run`'s folder, and the choice; `ChoiceError` for a folder that is not
    a run (or a damaged one), with `load_run`'s one-line message, or for a run with no finished
    generation (nothing to analyse: the notebooks' figures failed on it with tracebacks)."""
    from ariel.recording import load_run

    run, choice = _opened(choose_run(run_dir, **choose), load_run)
    if run.generations_done == 0:
        raise ChoiceError(
            f"{choice.why}: run {run.path} has no finished generation yet: nothing to analyse "
            "(resume it, or name another run)"
        )
    return run, choice


def choose_campaign(
    campaign_dir: str | os.PathLike[str] | None = None,
    *,
    environ: Mapping[str, str] | None = None,
    cwd: str | os.PathLike[str] | None = None,
    root: str | os.PathLike[str] | None = None,
) -> Choice:
    """The campaign folder: ``ARIEL_CAMPAIGN_DIR``, else ``campaign_dir``, else the newest
    (campaign.json modified last) under ``root`` (default ``<repository>/data/campaigns``)."""
    given = _given("CAMPAIGN_DIR", campaign_dir, environ, cwd)
    if given is not None:
        return given
    root = Path(REPO / "data" / "campaigns" if root is None else root)
    found = sorted(root.glob("*/campaign.json"), key=lambda p: p.stat().st_mtime)
    if not found:
        raise ChoiceError(
            f"no campaign under {root}: `ariel campaign run FILE` first, or name one in "
            "CAMPAIGN_DIR or ARIEL_CAMPAIGN_DIR"
        )
    return Choice(found[-1].parent, f"the newest campaign under {root}")


def open_campaign(
    campaign_dir: str | os.PathLike[str] | None = None, **choose: Any
) -> tuple[Any, Choice]:
    """`load_campaign` of `choose_campaign`'s folder, and the choice (`ChoiceError` as above)."""
    from ariel.recording import load_campaign

    return _opened(choose_campaign(campaign_dir, **choose), load_campaign)
