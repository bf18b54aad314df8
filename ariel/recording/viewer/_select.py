"""Which recordings ``ariel view`` opens (`select_recordings`): a run's best evaluations, one
generation's, one evaluation's (its 3D replay made on demand where it has none), or by default
``run.rrd`` and the best evaluation's; a campaign's ``campaign.rrd``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ariel.errors import MissingPluginError, ViewError
from ariel.recording.rerun import CAMPAIGN_BLUEPRINT, write_campaign_recording
from ariel.recording.resim import has_body_poses, on_demand_recording
from ariel.recording.store import (
    GENERATION_BLUEPRINT,
    NotARunError,
    cannot_write,
    check_eval_id,
    generation_recording_path,
    load_run,
    read_campaign_info,
    recording_path,
)
from ariel.recording.viewer._rerun_files import (
    check_rerun_files,
    recording_problem,
    rerun_file_problem,
)
from ariel.utils import ariel_line

if TYPE_CHECKING:
    from ariel.recording.store import Run

__all__ = ["Selection", "best_evaluations", "select_recordings"]

RECORDINGS = "recordings"
RUN_RECORDING = "run.rrd"
BLUEPRINT = "blueprint.rbl"
_EVAL_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
# A recording's file name is the id plus ".rrd": longer ones cannot exist (NAME_MAX 255), and
# asking the file system about them fails with ENAMETOOLONG.
_MAX_EVAL_ID = 200


@dataclass(frozen=True)
class Selection:
    """The recordings to open: ``.rrd`` paths, the blueprint (or None) and a description."""

    run_dir: Path
    recordings: tuple[Path, ...]
    blueprint: Path | None
    description: str
    #: The best evaluation's recording: the default view opens it alone, with the run's
    #: fitness, diversity (and archive) beside it (`write_view_recording`), so the viewer
    #: starts on its robot, morphology and joints.
    overview: Path | None = None
    #: Layouts of other application ids among the recordings (a generation's
    #: ``evaluations.rrd`` has its own, ``generation.rbl``).
    more_layouts: tuple[Path, ...] = ()
    #: The recordings are the run's, of application ``ariel`` (evaluations' own, run.rrd):
    #: each is opened as a copy with the run's charts beside it, laid out for the run (see
    #: `_prepared`). Not a generation's ``evaluations.rrd`` nor a campaign's recording.
    beside_run: bool = False
    #: A folder of files made for this view alone (a campaign's recording where it has none),
    #: removed when the viewer is done (`_view._prepared`).
    scratch: Path | None = None

    @property
    def files(self) -> list[Path]:
        """Every file to hand the viewer: recordings, then layouts."""
        layouts = [self.blueprint] if self.blueprint else []
        return [*self.recordings, *layouts, *self.more_layouts]


def _rrd_files(folder: Path) -> list[Path]:
    """The finished ``.rrd`` files in ``folder`` (temporaries are hidden ``.name.tmp`` files)."""
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.glob("*.rrd") if p.is_file() and not p.name.startswith("."))


def best_evaluations(evaluations: Any, k: int, *, maximise: bool) -> Any:
    """The ``k`` best finished evaluations (status ``ok``, finite fitness), best first; ties
    keep table order (earlier generation, then earlier evaluation)."""
    finite = evaluations["fitness"].map(lambda f: math.isfinite(f))
    ok = evaluations[(evaluations["status"] == "ok") & finite]
    return ok.sort_values("fitness", ascending=not maximise, kind="stable").head(k)


def _no_recordings(run: Run) -> ViewError:
    rerun_on = bool(run.config.get("record", {}).get("rerun", False))
    why = (
        "none written yet"
        if rerun_on
        else "the run was made with record.rerun = false; "
        "run it with --set record.rerun=true to record them"
    )
    return ViewError(f"no Rerun recordings in {run.path} ({why})")


def select_recordings(
    run_dir: str | Path,
    *,
    best: int | None = None,
    generation: int | None = None,
    eval_id: str | None = None,
) -> Selection:
    """Pick recordings of a run: the ``best`` K evaluations, one ``generation``'s, one
    ``eval_id``'s, or by default ``run.rrd`` and the best evaluation's. Raises `ViewError`."""
    if sum(x is not None for x in (best, generation, eval_id)) > 1:
        raise ViewError("choose one of --best, --generation and EVAL_ID")
    _refuse_links(Path(run_dir))
    if (Path(run_dir) / "campaign.json").is_file():
        chosen = _campaign_selection(Path(run_dir), best, generation, eval_id)
        check_rerun_files(chosen.files, chosen.run_dir)  # as a run's, below
        return chosen
    try:
        run = load_run(run_dir)
    except NotARunError as exc:
        raise ViewError(str(exc)) from None
    folder = run.path
    blueprint = folder / BLUEPRINT
    layout = blueprint if blueprint.is_file() else None
    if not (folder / RUN_RECORDING).is_file() and not any(
        (folder / RECORDINGS).glob("gen-*/*.rrd")
    ):
        raise _no_recordings(run)
    if eval_id is not None:
        chosen = _evaluation_selection(run, run_dir, eval_id, layout)
    elif generation is not None:
        chosen = _generation_of_run(run, generation, layout)
    else:
        chosen = _ranked_selection(run, best, layout)
    # A run's own layout is replaced by one written for the view (`_prepared`): not read.
    shown = chosen.recordings if chosen.beside_run else chosen.files
    check_rerun_files(shown, folder)  # a damaged file: one line, never the viewer's traceback
    return chosen


def _refuse_links(folder: Path) -> None:
    """Raise `ViewError` when a recording or layout of ``folder`` (its ``recordings/`` tree,
    its own ``.rrd`` and ``.rbl`` files) is a symbolic link: a received folder must not make
    the viewer read a file outside it."""
    found = [folder / RECORDINGS, *folder.glob("*.rrd"), *folder.glob("*.rbl")]
    if (folder / RECORDINGS).is_dir() and not (folder / RECORDINGS).is_symlink():
        for parent, folders, files in os.walk(folder / RECORDINGS):  # links not followed
            found += [Path(parent, name) for name in (*folders, *files)]
    for path in found:
        if path.is_symlink():
            raise ViewError(
                f"refusing to open {str(folder)!r}: {str(path.relative_to(folder))!r} is a "
                f"symbolic link (to {os.readlink(path)!r}); a folder's recordings are read only "
                "inside it: remove the link"
            )


def _beside_run(
    run: Run, paths: Sequence[Path], description: str, layout: Path | None
) -> Selection:
    """Recordings of the run's own, opened beside its charts (`Selection.beside_run`)."""
    return Selection(run.path, tuple(paths), layout, description, beside_run=True)


def _evaluation_selection(
    run: Run, run_dir: str | Path, eval_id: str, layout: Path | None
) -> Selection:
    """Evaluation ``eval_id``: its recording (with the bodies' poses), else its 3D replay made
    on demand, else its generation's recording."""
    folder = run.path
    if len(eval_id) > _MAX_EVAL_ID or not _EVAL_ID.fullmatch(eval_id):
        shown = eval_id if len(eval_id) <= 60 else f"{eval_id[:40]}...({len(eval_id)} characters)"
        raise ViewError(f"not an evaluation id: {shown!r} (ids look like b000012-i003-c005)")
    found = sorted((folder / RECORDINGS).glob(f"gen-*/{eval_id}.rrd"))
    problem = recording_problem(found[0]) if found else None
    if found and problem is None:
        return _beside_run(run, *_with_body_poses(run, eval_id, found[0]), layout)
    known = run.evaluations["eval_id"] == eval_id
    if known.any():
        generation_of = int(run.evaluations.loc[known, "generation"].iloc[0])
        where = found[0].relative_to(folder) if found else None
        why = f"has no sound recording ({where} {problem})" if found else "has no recording"
        return _replayed_or_generation(run, eval_id, generation_of, layout, why)
    raise ViewError(
        f"no evaluation {eval_id} in {folder} (ids look like b000012-i003-c005; "
        f"{ariel_line('view', run_dir, '--best', 5)} opens the 5 best)"
    )


def _generation_of_run(run: Run, generation: int, layout: Path | None) -> Selection:
    """Generation ``generation``'s recording of every evaluation (for a run recorded before
    those: its evaluations' own recordings)."""
    folder = run.path
    shared = generation_recording_path(folder, generation)
    if shared.is_file():
        return _generation_selection(run, generation, f"generation {generation}'s evaluations")
    found = _rrd_files(folder / RECORDINGS / f"gen-{generation:06d}")
    if found:  # a run recorded before generation recordings: its evaluations' own files
        return _beside_run(run, found, f"generation {generation}", layout)
    done = run.generations_done
    if not 0 <= generation < max(done, 1) or done == 0:
        span = f"generations 0..{done - 1}" if done else "no finished generation"
        raise ViewError(f"no generation {generation} in {folder} (it has {span})")
    raise ViewError(f"no recordings of generation {generation} in {folder}")


def _ranked_selection(run: Run, best: int | None, layout: Path | None) -> Selection:
    """The ``best`` K evaluations' recordings; ``best`` None: the best evaluation's and
    ``run.rrd``, whichever exist."""
    folder = run.path
    evaluations = run.evaluations
    ranked = best_evaluations(
        evaluations, best or 1, maximise=run.maximise if len(evaluations) else True
    )
    # Ids from the table name files: a crafted one (``../../x``) is refused, never opened.
    paths = [
        recording_path(folder, g, check_eval_id(e, folder))
        for g, e in zip(ranked["generation"], ranked["eval_id"])
    ]
    if best is not None:
        paths = [_own_or_replayed(run, path) for path in paths]
        if not paths:
            raise ViewError(f"no finished evaluation in {folder} to rank")
        return _beside_run(run, paths, f"the {len(paths)} best evaluations", layout)

    # Default: the best evaluation's recording (its own, else its 3D replay made on demand;
    # the viewer opens on its robot) and the run-level recording, whichever exist.
    picked, parts = [], []
    overview = _best_recording(run, paths[0]) if paths else None
    if overview is not None:
        picked.append(overview)
        parts.append(f"the best evaluation {overview.stem}")
    run_rrd = folder / RUN_RECORDING
    damaged = run_rrd.is_file() and rerun_file_problem(run_rrd)
    if damaged and overview is not None:  # the view opens the best evaluation's copy: go on
        print(f"ariel: {RUN_RECORDING} {damaged}; showing the best evaluation", file=sys.stderr)
    elif run_rrd.is_file():  # damaged and alone: refused in one line by the caller's check
        picked.append(run_rrd)
        parts.append(RUN_RECORDING)
    if not picked:
        raise _no_recordings(run)
    chosen = _beside_run(run, picked, " and ".join(parts), layout)
    return dataclasses.replace(chosen, overview=overview)


def _best_recording(run: Run, path: Path) -> Path | None:
    """The best evaluation's recording: its own, else its 3D replay made on demand; None (with
    a note) where neither can be had."""
    try:
        return _own_or_replayed(run, path)
    except ViewError as exc:
        print(f"ariel: {exc}; showing {RUN_RECORDING} alone", file=sys.stderr)
        return None


def _own_or_replayed(run: Run, path: Path) -> Path:
    """An evaluation's own recording, else its 3D replay made on demand (an evaluation that
    was not an elite is recorded in its generation's ``evaluations.rrd`` only; a damaged
    recording, or another evaluation's copied over it, is replaced the same way, with a
    note)."""
    problem = recording_problem(path) if path.is_file() else "is not recorded"
    if problem is None:
        return path
    where = path.relative_to(run.path)
    try:
        made = _replay(run, path.stem)
    except (MissingPluginError, ValueError) as exc:
        raise ViewError(f"{where} {problem} and cannot be replayed: {exc}") from None
    if path.is_file():
        print(f"ariel: {where} {problem}; showing its 3D replay instead", file=sys.stderr)
    return made


def _replay(run: Run, eval_id: str) -> Path:
    """`on_demand_recording`, where a folder it cannot write (read-only, full) is a
    `ValueError` that says so, as for a replay that cannot be made: the view goes on without."""
    try:
        return on_demand_recording(run.path, eval_id)
    except OSError as exc:
        raise ValueError(cannot_write(exc)) from None


def _replayed_or_generation(
    run: Run, eval_id: str, generation: int, blueprint: Path | None, why: str
) -> Selection:
    """An evaluation without its own recording (``why``: "has no recording", or what is
    wrong with its file): its 3D replay made on demand, else (without the run's plugins) its
    generation's recording of every evaluation, with a note."""
    shared = generation_recording_path(run.path, generation)
    try:
        made = _replay(run, eval_id)
    except (MissingPluginError, ValueError) as exc:
        if not shared.is_file():
            raise ViewError(f"evaluation {eval_id} {why} and no 3D replay: {exc}") from None
        print(
            f"ariel: evaluation {eval_id} {why} and no 3D replay: {exc}; showing its "
            "generation's recording",
            file=sys.stderr,
        )
        return _generation_selection(
            run, generation, f"generation {generation}'s evaluations ({eval_id} among them)"
        )
    if why != "has no recording":
        print(f"ariel: evaluation {eval_id} {why}; showing its 3D replay", file=sys.stderr)
    return Selection(
        run.path,
        (made,),
        blueprint,
        f"evaluation {eval_id} (3D replay re-simulated on demand)",
        beside_run=True,
    )


def _generation_selection(run: Run, generation: int, description: str) -> Selection:
    """The generation's recording of every evaluation, alone, with its layout. Alone: given
    the elites' 3D replays as well, the viewer opens on one of those instead. (They open
    one at a time: ``ariel view RUN EVAL_ID``.)"""
    layout = run.path / GENERATION_BLUEPRINT
    return Selection(
        run.path,
        (generation_recording_path(run.path, generation),),
        None,
        description,
        more_layouts=(layout,) if layout.is_file() else (),
    )


def _with_body_poses(run: Run, eval_id: str, recorded: Path) -> tuple[list[Path], str]:
    """The evaluation's recording when it holds the bodies' poses (or was not written by the
    loop), else its 3D replay made on demand by exact re-simulation (`on_demand_recording`;
    cached in the run folder). Without the run's plugins, the recording as it is, with a
    note."""
    if not run.config.get("record", {}).get("rerun") or has_body_poses(recorded):
        return [recorded], f"evaluation {eval_id}"
    try:
        made = _replay(run, eval_id)
    except (MissingPluginError, ValueError) as exc:
        print(f"ariel: no 3D replay of {eval_id}: {exc}", file=sys.stderr)
        return [recorded], f"evaluation {eval_id} (no 3D replay)"
    return [made], f"evaluation {eval_id} (3D replay re-simulated on demand)"


def _view_line(
    run_dir: str | Path, best: int | None, generation: int | None, eval_id: str | None, *more: str
) -> str:
    """The ``ariel view`` command line (pasteable) of these options."""
    words: list[object] = [run_dir, *([eval_id] if eval_id is not None else [])]
    words += ["--best", best] if best is not None else []
    words += ["--generation", generation] if generation is not None else []
    return ariel_line("view", *words, *more)


def _campaign_selection(
    folder: Path, best: int | None, generation: int | None, eval_id: str | None
) -> Selection:
    """A campaign folder: campaign.rrd (every run's best-so-far curve) with campaign.rbl."""
    try:  # a damaged or crafted campaign.json (a run path out of the folder) is one line
        read_campaign_info(folder)
    except NotARunError as exc:
        raise ViewError(str(exc)) from None
    if (best, generation, eval_id) != (None, None, None):
        runs = sorted(folder.glob("runs/condition=*/seed=*"))
        one = runs[0] if runs else folder / "runs" / "condition=NAME" / "seed=N"
        raise ViewError(
            f"{folder} is a campaign: --best, --generation and EVAL_ID apply to one of its runs, "
            f"e.g. {_view_line(one, best, generation, eval_id)}"
        )
    recording, scratch = folder / "campaign.rrd", None
    if not recording.is_file():  # a campaign running, or killed before it wrote one
        # made for this view, outside the folder: it may be read-only, or another's to write
        try:
            scratch = Path(tempfile.mkdtemp(prefix="ariel-view-"))
            recording = write_campaign_recording(folder, into=scratch)
        except OSError as exc:  # a full temporary disk
            raise ViewError(f"cannot make the campaign's recording to view: {exc}") from None
    blueprint = recording.parent / CAMPAIGN_BLUEPRINT
    return Selection(
        folder,
        (recording,),
        blueprint if blueprint.is_file() else None,
        "campaign.rrd (every run's best fitness so far)",
        scratch=scratch,
    )
