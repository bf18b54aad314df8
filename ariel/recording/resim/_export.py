"""Export one evaluation of a run for use outside the workbench (`ariel export`).

The folder it writes holds the body in its world as MJCF (``body.xml``, MuJoCo's own viewer
opens it: ``python -m mujoco.viewer --mjcf body.xml``), the genotype (``genotype.json``), the
controller and its exact parameters (``controller.json``), and ``replay.py``: a short
script of the tutorial API that rebuilds the robot (`load_exported`: the registries, the
constructor, ``world.spawn``, `Controller`), drives it (``mjcb_control``, `simple_runner`)
and prints where the core ends up, beside where the run recorded it (the same: the tutorial
path equals the engine's), and the fitness of the replay (the run's fitness function on the
frames the run recorded, `ExportedRobot.replayed_fitness`) beside the recorded one. (MJCF
rounds numbers to 6 digits, so a simulation of ``body.xml`` drifts from the recorded path;
it is for looking at.)

A run folder is data, and so is what is exported from it: ``replay.py`` is the same text for
every export (it reads the ids and values from ``controller.json`` when it runs), and the run
id and evaluation id are checked against their shapes (`_ids`) before anything is written, so
a crafted id is refused in one line instead of becoming code; an error in ``replay.py`` is one
escaped line, never a traceback. The names of the plugins are the run's config's (a row that
names others, a negative seed, a body larger than the run's encoder makes: refused, one line,
by `replay_task`).

All or nothing: every file is written (whole, never through a link: `_files.atomic_write`)
into a new hidden folder beside ``out``, ``.<name>.<random hex>.tmp``, which is then renamed
to ``out`` (atomic onto a missing or empty folder); a failure or Ctrl-C removes it again, and
a rename onto a folder another export made meanwhile is refused in one line.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import secrets
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from ariel import evaluation
from ariel.errors import ArielError
from ariel.plugins import body_encoders, worlds
from ariel.recording import store
from ariel.recording.resim._rebuild import (
    _find_row,
    _require_plugins,
    cell_json,
    load_checked,
    replay_task,
)
from ariel.recording.store import (
    Run,
    cannot_write,
    check_eval_id,
    check_run_id,
    evaluation_trajectory,
    one_line,
)

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation import EvaluationTask

__all__ = ["ExportError", "export"]

#: The files `export` writes into its folder.
FILES = ("body.xml", "genotype.json", "controller.json", "replay.py")

#: ``replay.py``: no data of the run in it (the ids and the recorded values are read from
#: controller.json when it runs); ``{core}`` is the core geom's name, a constant of ours.
_SCRIPT = '''\
"""Replay the evaluation exported to this folder with ARIEL's tutorial API: python replay.py

Which evaluation of which run, and what it recorded: controller.json. The replayed fitness is
the run's fitness function on the frames the run recorded (robot.set_control keeps them).
An error is printed as one line, its characters escaped (the folder is data: any text).
"""

import sys
from pathlib import Path


def main() -> None:
    import mujoco

    from ariel.recording import load_exported
    from ariel.utils.runners import simple_runner

    robot = load_exported(Path(__file__).resolve().parent)  # genotype.json, controller.json
    mujoco.set_mjcb_control(robot.set_control)  # robot.controller, and the fitness's frames
    simple_runner(robot.model, robot.data, duration=robot.duration)
    mujoco.mj_kinematics(robot.model, robot.data)  # the final state's positions
    print("core at", robot.data.geom("{core}").xpos.tolist())
    recorded = robot.recorded_core  # the run's record of the same path
    print("recorded core at", recorded if recorded else "(not recorded: no trajectories)")
    unit = " " + robot.fitness_unit if robot.fitness_unit else ""
    print(
        f"replayed fitness {{robot.replayed_fitness()!r}}{{unit}} "
        f"(recorded {{robot.fitness!r}}{{unit}}; {{robot.fitness_fn}})"
    )
    if robot.backend != "mujoco":  # MuJoCo Warp: float32, not bitwise MuJoCo's arithmetic
        print("the run simulated it with", robot.backend, "(float32): this MuJoCo replay differs")
    print("evaluation", robot.eval_id, "of run", robot.run_id)


if __name__ == "__main__":
    try:
        main()
    except Exception as error:  # one line, escaped: no traceback, no control character
        message = type(error).__name__ + ": " + str(error)
        sys.exit("replay.py: error: " + message.encode("unicode_escape").decode("ascii"))
'''


class ExportError(ArielError, ValueError):
    """An export that cannot be made (its folder is not empty, its body cannot be built)."""


def export(run_dir: str | Path, eval_id: str, out: str | Path) -> Path:
    """Write evaluation ``eval_id`` (or ``"best"``) of the run in ``run_dir`` to the folder
    ``out`` (created; an existing one must be empty): `FILES`. Returns ``out``.

    Raises `UnknownEvaluationError` for an id not in the run's finished generations,
    `ExportError` for a non-empty ``out`` or an evaluation whose body could not be built,
    `DamagedRunError` for a row whose stored genotype no longer builds or a config whose
    plugins reject its options, and `MissingPluginError` when a plugin the body or world
    needs is not installed here.
    """
    out = Path(out)
    _check_out(out)
    run = load_checked(run_dir)
    run_id = check_run_id(run.info.get("run_id"), run.path)
    row = _find_row(run, eval_id)
    check_eval_id(row["eval_id"], run.path)
    if row["status"] == "error":
        raise ExportError(
            f"evaluation {row['eval_id']!r} has no body to export: its genotype cannot be "
            f"built ({one_line(row.get('error') or 'build error')})"
        )
    _require_plugins(run)
    # The row checked (ids, plugin names, seed, body size), and its body built, or why not.
    task = replay_task(run, row, check_params=True, unbuildable=True)
    xml = _world_spec(task).to_xml()
    body = run.config["body"]  # the run's encoder (a row naming another was refused)
    genotype = {  # as the run's encoder sees it (the task may ship the decoded graph instead)
        "body_encoder": str(body["encoder"]),
        "options": body.get("options", {}),
        "genotype": cell_json(run, row, "evaluations", "body_genotype", row["body_genotype"]),
    }
    brain = {
        "run_id": run_id,
        "eval_id": str(row["eval_id"]),
        "controller": task.controller,
        "options": task.controller_options,
        "params": [float(v) for v in task.params],
        "seed": int(task.seed),
        "duration": float(task.duration),
        "settle": float(task.settle),
        "control_period": int(task.control_period),
        "smoothing": float(task.smoothing),
        "world": task.world,
        "world_options": task.world_options,
        "spawn_position": list(task.spawn_position),
        "spawn_rotation": list(task.spawn_rotation),
        "fitness_fn": task.fitness,
        "fitness_options": task.fitness_options,
        "record_every": int(task.record_every),
        "fitness": float(row["fitness"]),
        "core_end": _recorded_core(run, row),
        "backend": str(row.get("backend") or "mujoco"),  # replay.py says when it differs
    }
    script = _SCRIPT.format(core=evaluation.SPAWN_PREFIX + "core")  # the same for every export
    texts = {
        "body.xml": xml,
        "genotype.json": json.dumps(genotype, indent=1) + "\n",
        "controller.json": json.dumps(brain, indent=1) + "\n",
        "replay.py": script,
    }
    _write(out, texts)
    return out


def _check_out(out: Path) -> None:
    """`ExportError` where ``out`` cannot be the export's folder: a symbolic link, behind one
    that leads nowhere (`_check_way`), not an empty folder, the folder this command runs
    in (renamed onto, it would leave the shell in a removed folder), or inside a run or
    campaign folder (whose records no command writes among)."""
    if out.is_symlink():
        raise ExportError(f"{str(out)!r} is a symbolic link; name a new folder")
    _check_way(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ExportError(f"{str(out)!r} exists and is not an empty folder; name a new one")
    if out.exists() and os.path.samefile(out, os.curdir):
        raise ExportError(
            f"{str(out)!r} is the folder this command runs in: name a new folder (an export "
            "is written whole beside it and then renamed into its place)"
        )
    records = store.records_folder_of(out)
    if records is not None:
        raise ExportError(
            f"{str(out)!r} is inside the run or campaign folder {str(records)!r}, whose "
            "records are never written among: name a folder outside it"
        )


def _check_way(out: Path) -> None:
    """`ExportError` where a folder on the way to ``out`` cannot be one: a symbolic link that
    leads nowhere (dangling, or a loop), or a file."""
    for folder in [*reversed(out.parents), out]:
        if folder.is_symlink() and not folder.exists():
            raise ExportError(
                f"cannot make the folder {str(out)!r}: {str(folder)!r} is a symbolic link to "
                f"{os.readlink(folder)!r}, which is no folder; name another folder"
            )
        if folder != out and folder.exists() and not folder.is_dir():
            raise ExportError(
                f"cannot make the folder {str(out)!r}: {str(folder)!r} is not a folder"
            )


def _write(out: Path, texts: dict[str, str]) -> None:
    """Write ``texts`` (file name -> text) into a new hidden folder beside ``out``
    (`_temporary_folder`), then rename it to ``out``: all the files or none. On any failure
    (disk full, read-only, no permission; Ctrl-C) the hidden folder is removed again, and so
    are the folders made on the way to it; `ExportError` names the file and why, or says that
    another export made ``out`` meanwhile (a rename onto a folder that is not empty fails)."""
    made = _make_parent(out.parent)
    temporary: Path | None = None
    try:
        temporary = _temporary_folder(out)
        for name, text in texts.items():
            data = text.encode("utf-8")
            # From the store's face at each call, as before (tests stand in for it there).
            store.atomic_write(
                temporary / name, lambda path, data=data: path.write_bytes(data), root=temporary
            )
        _rename(temporary, out)
    except BaseException as exc:
        if temporary is not None:  # our own new folder (rmtree follows no link out of it)
            shutil.rmtree(temporary, ignore_errors=True)
        _remove_empty(made)
        if isinstance(exc, OSError):
            named = _named(exc, temporary, out)
            raise ExportError(f"{cannot_write(named, out)}; nothing was exported") from exc
        raise


def _make_parent(parent: Path) -> list[Path]:
    """Make ``parent`` and the folders on the way that are missing; those made, deepest
    first (`ExportError` where one cannot be made)."""
    missing = [folder for folder in [parent, *parent.parents] if not folder.exists()]
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        _remove_empty(missing)
        raise ExportError(f"{cannot_write(exc, parent)}; nothing was exported") from exc
    return missing


def _remove_empty(folders: list[Path]) -> None:
    """Remove ``folders`` (deepest first) where they are empty folders."""
    for folder in folders:
        with contextlib.suppress(OSError):
            folder.rmdir()


def _temporary_folder(out: Path) -> Path:
    """A new folder ``.<out's name>.<random hex>.tmp`` beside ``out`` (made by ``mkdir``:
    never one that was there); its name cut to fit a file name."""
    name = os.fsencode(out.name)[:64]
    for _ in range(8):
        folder = out.parent / os.fsdecode(b"." + name + f".{secrets.token_hex(8)}.tmp".encode())
        try:
            folder.mkdir()
        except FileExistsError:
            continue
        return folder
    raise FileExistsError(errno.EEXIST, "no new temporary folder could be made", str(out))


def _rename(temporary: Path, out: Path) -> None:
    """Rename ``temporary`` to ``out``: atomic onto a missing or empty folder; `ExportError`
    where ``out`` was made meanwhile and is no empty folder (another export, a file)."""
    try:
        os.rename(temporary, out)
    except OSError as exc:
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
            raise
        raise ExportError(
            f"{str(out)!r} was made meanwhile (by another export?) and is not an empty folder: "
            "nothing was exported; name a new folder"
        ) from None
    store.fsync_folder(out.parent)  # the rename lasts a power cut


def _named(exc: OSError, temporary: Path | None, out: Path) -> OSError:
    """``exc``, naming the file in ``out`` that a file in ``temporary`` stands for, or
    ``out`` itself for the hidden folder beside it (`_temporary_folder`: made, or not)."""
    if exc.filename is None:
        return exc
    path = Path(os.fsdecode(exc.filename))
    if temporary is not None and path.parent == temporary:
        exc.filename = str(out / path.name)
    elif path == temporary or (path.parent == out.parent and path.name.endswith(".tmp")):
        exc.filename = str(out)
    return exc


def _recorded_core(run: Run, row: Mapping[str, object]) -> list[float] | None:
    """Where the run recorded the core at the evaluation's end (its last trajectory frame);
    None where the run kept no trajectories."""
    frames = evaluation_trajectory(run, row)
    if frames is None or not len(frames):
        return None
    last = frames.iloc[-1]  # sorted by time
    return [float(last["core_x"]), float(last["core_y"]), float(last["core_z"])]


def _world_spec(task: EvaluationTask) -> mujoco.MjSpec:
    """``task``'s body spawned in its world: the `mujoco.MjSpec` that `build` compiles."""
    encoder = evaluation.make_plugin(body_encoders, task.body.encoder, task.body.options)
    world = evaluation.make_plugin(worlds, task.world, task.world_options)
    core, _ = evaluation.robot_module(encoder, task.body.genotype)
    world.spawn(core.spec, position=task.spawn_position, rotation=task.spawn_rotation)
    return world.spec
