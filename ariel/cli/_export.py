"""``ariel export``: one evaluation into a folder (`ariel.recording.resim.export`), the run's
lineage as the ALife data standard's phylogeny CSV (``--lineage FILE.csv``), or both.

Bad input is one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import TYPE_CHECKING

from ariel import recording
from ariel.cli._common import IntermixedParser, fail, note_if_running
from ariel.recording import resim
from ariel.recording.store import cannot_write, output_file_problem, terminal_text, user_file
from ariel.utils import has_display, python_command, shell_path

if TYPE_CHECKING:
    from ariel.cli._common import SubParsers

__all__ = ["add_export_command"]


def add_export_command(sub: SubParsers) -> None:
    """The ``export`` sub-command, on the ``ariel`` parser's sub-parsers ``sub``."""
    p = sub.add_parser(
        "export",
        help="write one evaluation as MJCF, genotype and controller JSON, and a replay script; "
        "--lineage: the run's lineage as a CSV",
        description="Write one evaluation (EVAL_ID into DIR), the run's lineage (--lineage "
        "FILE.csv), or both. The lineage is the ALife data standard's phylogeny CSV: one row "
        "per body ever evaluated, with its id, ancestor_list (its parents), origin_time and "
        "destruction_time (generations; empty: still in the final population); "
        "docs/records.md, 'Lineage'.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder, e.g. data/runs/<run-id>")
    p.add_argument(
        "eval_id", nargs="?", metavar="EVAL_ID", help="e.g. b000012-i003-c005, or 'best'"
    )
    p.add_argument("out", nargs="?", metavar="DIR", help="a new or empty folder")
    p.add_argument(
        "--lineage",
        metavar="FILE.csv",
        help="write the run's lineage to FILE.csv, a new file (an existing one is never "
        "replaced); EVAL_ID and DIR are then optional",
    )
    p.__class__ = IntermixedParser  # EVAL_ID and DIR may follow --lineage FILE
    p.set_defaults(func=_cmd_export)


def _cmd_export(args: argparse.Namespace) -> int:
    if args.out is None and (args.lineage is None or args.eval_id is not None):
        return fail(
            "export: give EVAL_ID and DIR (one evaluation), --lineage FILE.csv (the run's "
            "lineage), or both (see ariel export --help)"
        )
    if args.lineage is not None and os.path.lexists(args.lineage):  # a dangling link too
        return fail(_exists(args.lineage))  # before anything is written
    problem = None if args.lineage is None else output_file_problem(args.lineage)
    if problem is not None:  # a folder, or inside a run folder: its records are never replaced
        return fail(f"--lineage: {problem}")
    if args.out is not None:
        out = resim.export(args.run_dir, str(args.eval_id), args.out)  # given with DIR
        if args.eval_id == resim.BEST:
            note_if_running(args.run_dir, "'best' is the best so far")
        python = python_command()
        body, replay = (shell_path(out / name) for name in ("body.xml", "replay.py"))
        # MuJoCo's viewer is a window: offered only where one can open (headless, it failed
        # with GLFW errors and left a MUJOCO_LOG.TXT where it ran)
        viewer = f" ({python} -m mujoco.viewer --mjcf {body})" if has_display() else ""
        print(  # escaped: DIR is any name, control characters too
            terminal_text(
                f"wrote {out}: body.xml{viewer}, genotype.json, controller.json, replay.py "
                f"({python} {replay})"
            )
        )
    return 0 if args.lineage is None else _export_lineage(args.run_dir, Path(args.lineage))


def _exists(path: str | Path) -> str:
    return f"{str(path)!r} already exists: remove it or name another file (it is never replaced)"


def _export_lineage(run_dir: str, path: Path) -> int:
    """The run's lineage (`ariel.recording.Run.lineage`) as the standard's CSV at ``path``."""
    frame = recording.load_run(run_dir).lineage()
    try:
        recording.write_lineage_csv(frame, user_file(path))
    except FileExistsError:  # made since the check in _cmd_export
        return fail(_exists(path))
    except OSError as exc:  # no permission, a full disk, a file where a folder goes
        return fail(cannot_write(exc, path))
    alive = int(frame["destruction_time"].isna().to_numpy().sum())
    print(
        terminal_text(
            f"wrote {path}: the lineage of {len(frame):,} "
            f"{'body' if len(frame) == 1 else 'bodies'} ({alive:,} in the final "
            "population), in the ALife data standard's phylogeny format"
        )
    )
    return 0
