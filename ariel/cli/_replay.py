"""``ariel replay RUN_DIR EVAL_ID``: one evaluation re-simulated (`ariel.recording.resim`) and its
fitness compared with the stored one, bit for bit; ``--rrd``, ``--video`` and ``--viewer`` show
it at the full rate. Exit 0 when reproduced, 1 when not.
"""

from __future__ import annotations

import argparse
import os
from typing import TYPE_CHECKING

from ariel.cli._common import fail, headless_unless_display, note_if_running
from ariel.recording import resim
from ariel.recording.store import cannot_write, output_file_problem, terminal_text
from ariel.utils import has_display, no_display_why

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers
    from ariel.recording.resim import ReplayResult

__all__ = ["add_replay_command"]


def add_replay_command(sub: SubParsers) -> None:
    """Add ``ariel replay`` to the sub-command parsers ``sub``."""
    p = sub.add_parser(
        "replay",
        help="re-simulate one evaluation of a run and check its stored fitness bit for bit",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument("eval_id", metavar="EVAL_ID", help="e.g. b000012-i003-c005, or 'best'")
    p.add_argument(
        "--rrd", metavar="FILE", help="write a full-rate Rerun recording (a FILE there is replaced)"
    )
    p.add_argument(
        "--video",
        metavar="FILE",
        help="write an MP4 (camera tracking the robot; a FILE there is replaced)",
    )
    p.add_argument("--viewer", action="store_true", help="play it in the MuJoCo viewer")
    p.set_defaults(func=_cmd_replay)


def _cmd_replay(args: argparse.Namespace) -> int:
    if args.viewer and not has_display():
        return fail(
            f"--viewer needs a display ({no_display_why()}); write a video with --video FILE "
            "or a Rerun recording with --rrd FILE instead"
        )
    for flag, path in (("--rrd", args.rrd), ("--video", args.video)):
        problem = None if path is None else output_file_problem(path)
        if problem is not None:  # before minutes of simulation, not after
            return fail(f"{flag}: {problem}")
    if args.video:  # replay() imports mujoco to re-simulate: the backend is chosen first
        headless_unless_display("run without --video")
    replayed = resim.replay(args.run_dir, args.eval_id)
    if args.eval_id == resim.BEST:
        note_if_running(args.run_dir, "'best' is the best so far")
    row = replayed.row
    _say(
        f"evaluation {replayed.eval_id} (generation {int(row['generation'])}, body "
        f"{row['body_id']}) of run {replayed.run.info.get('run_id', args.run_dir)}"
    )
    _say(f"stored fitness:   {replayed.stored_fitness!r} ({replayed.stored_status})")
    _say(f"replayed fitness: {replayed.fitness!r} ({replayed.status})")
    why = _why(replayed)
    if why:
        _say(why)
    if not replayed.exact:  # MuJoCo Warp (float32) on either side: close, never claimed equal
        _say(f"backend: stored {replayed.stored_backend}, replayed {replayed.backend}")
        _say(f"difference: {replayed.difference:+.3g} (MuJoCo Warp is not bitwise repeatable)")
    elif replayed.identical:
        _say("identical: yes, bit for bit")
    else:
        _say("identical: NO")
        for name, (then, now) in replayed.version_differences.items():
            _say(f"  {name}: the run used {then}, this replay {now}")
    try:
        if args.rrd is not None or args.video is not None or args.viewer:
            dense = replayed.full_rate()
            print(
                f"full rate (every physics step, {len(dense.time)} frames): fitness "
                f"{float(dense.fitness)!r}"
            )
        if args.rrd is not None:
            replaced = _replaces(args.rrd)
            replayed.write_rrd(args.rrd)
            _say(f"wrote {args.rrd}{replaced}")  # as named (its folder's links resolved there)
        if args.video is not None:
            replaced = _replaces(args.video)
            replayed.write_video(args.video)
            _say(f"wrote {args.video}{replaced}")
        if args.viewer:
            replayed.view()
    except (ValueError, RuntimeError, ImportError) as exc:
        return fail(str(exc).splitlines()[0])  # `fail` escapes it for the terminal
    except OSError as exc:  # --rrd / --video onto a full disk, a read-only file system, ...
        return fail(cannot_write(exc))
    close = not replayed.exact and replayed.status == replayed.stored_status
    return 0 if replayed.identical or close else 1


def _replaces(path: str) -> str:
    """What to add to the ``wrote FILE`` line when ``FILE`` was there before (a file the user
    named is theirs to replace, but not without a word)."""
    return " (it replaced the file that was there)" if os.path.lexists(path) else ""


def _say(text: str) -> None:
    """Print ``text``, escaped: the ids, statuses and versions in it are read from the run
    folder (run.json, its tables), which anyone may have written."""
    print(terminal_text(text))


#: How the engine words a body that could not be built (`ariel.evaluation`'s error results).
_BUILD_ERROR = "BodyBuildError: "


def _why(replayed: ReplayResult) -> str | None:
    """Why the replay ended in another status than the stored one, where the engine said why:
    a body that could not be built from the stored genotype (a changed table, or another
    encoder than the run's), or another error; None otherwise."""
    error = replayed.result.error
    if replayed.status == replayed.stored_status or not error:
        return None
    if str(error).startswith(_BUILD_ERROR):
        cause = str(error).removeprefix(_BUILD_ERROR)
        return f"why: the body could not be built from the stored genotype: {cause}"
    return f"why: the replay ended in an error: {error}"
