"""Replay one evaluation of a run from its run folder alone, reproducing its stored fitness.

The run folder holds everything an evaluation depends on: the resolved config in ``run.json``
(plugins, options, duration, control, spawn, record rate) and the evaluation's row (genotype,
controller parameters as float64, seed). `replay` rebuilds the very task the loop built (both
call `ariel.evolution._tasks.evaluation_task`), evaluates it, and compares the fitness bit for
bit. Same software versions => the same fitness; `ReplayResult.version_differences` names the
versions that differ from those the run recorded.

Fitness functions see the recorded frames, so the stored fitness is reproduced at the run's own
``record.rate_hz``; `ReplayResult.full_rate` re-simulates the same evaluation recording every
physics step and every body's pose (for a Rerun recording, a video or the viewer). Recording
does not change the physics: the full-rate trajectory passes through the same states.

An evaluation run on MuJoCo Warp (``backend`` ``mujoco-warp:<device>``, executor ``gpu``) is
re-simulated on MuJoCo Warp again where its device is available here (else on the CPU engine),
as a batch of one world: float32 physics whose summation order depends on the batch, so the
replayed fitness is close to the stored one but not expected to equal it;
`ReplayResult.difference` says by how much.

What is rebuilt from the run folder (the row, the plugins, the task, the simulator, the
versions) is `ariel.recording.resim._rebuild`'s; this module re-simulates and shows it.
"""

from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel import evaluation
from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.errors import MissingPluginError, UnknownEvaluationError
from ariel.recording import resim
from ariel.recording.rerun import write_evaluation_recording
from ariel.recording.resim._rebuild import (
    BEST as BEST,
    _evaluate_as_stored as _evaluate_as_stored,
    _find_row,
    _require_plugins,
    cell_json,
    load_checked,
    replay_task,
)
from ariel.recording.resim._row_checks import changed
from ariel.recording.store import (
    Run,
    check_eval_id,
    output_file_problem,
    recording_path,
    refuse_symlinks,
    user_file,
    version_differences,
)

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation import EvaluationResult, EvaluationTask

__all__ = [
    "MissingPluginError",
    "ReplayResult",
    "UnknownEvaluationError",
    "has_body_poses",
    "on_demand_recording",
    "replay",
]

#: Where `on_demand_recording` keeps the 3D replays it makes, inside the generation's folder
#: of recordings (so a resume that discards the generation discards them too).
REPLAYS = "replays"


def _writable(path: str | Path) -> Path:
    problem = output_file_problem(path)
    if problem is not None:
        raise ValueError(problem)
    return user_file(path)


def _fitness_bits(value: float) -> bytes:
    return np.float64(value).tobytes()


def _same_bits(a: float, b: float) -> bool:
    """Bit-identical float64 values (so 0.0 and -0.0 differ, and NaN equals the same NaN)."""
    return _fitness_bits(a) == _fitness_bits(b)


@dataclass
class ReplayResult:
    """One evaluation re-simulated from its run folder.

    Attributes:
        run: the loaded run (`ariel.recording.Run`).
        row: the evaluation's row of the evaluations table (a dict).
        task: the rebuilt `EvaluationTask` (the loop's task, bit for bit).
        result: the `EvaluationResult` of evaluating it again.
        stored_fitness / fitness: the fitness in the table and the replayed one.
        identical: the two are the same float64, bit for bit (and so are the statuses).
        stored_backend / backend: the simulator of the stored and of the replayed fitness.
        exact: whether a bit-for-bit match is expected (both on the CPU engine).
        difference: replayed minus stored fitness.
        version_differences: ``{package: (recorded, now)}`` for versions that decide results.
    """

    run: Run
    row: dict[str, Any]
    task: Any
    result: Any
    version_differences: dict[str, tuple[object, object]] = field(default_factory=dict)
    _full_rate: EvaluationResult | None = field(default=None, repr=False)

    @property
    def eval_id(self) -> str:
        return str(self.row["eval_id"])

    @property
    def stored_fitness(self) -> float:
        return float(self.row["fitness"])

    @property
    def fitness(self) -> float:
        return float(self.result.fitness)

    @property
    def stored_status(self) -> str:
        return str(self.row["status"])

    @property
    def status(self) -> str:
        return str(self.result.status)

    @property
    def stored_backend(self) -> str:
        backend = self.row.get("backend")
        return backend if isinstance(backend, str) and backend else "mujoco"

    @property
    def backend(self) -> str:
        return str(self.result.backend)

    @property
    def exact(self) -> bool:
        return self.stored_backend == "mujoco" and self.backend == "mujoco"

    @property
    def difference(self) -> float:
        return self.fitness - self.stored_fitness

    @property
    def identical(self) -> bool:
        return _same_bits(self.fitness, self.stored_fitness) and self.status == self.stored_status

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled body in its world (`ariel.evaluation.build`); raises for an error body."""
        return evaluation.build(self.task).model

    # -- full-rate re-simulation ---------------------------------------------------------------

    def full_rate(self) -> EvaluationResult:
        """The same evaluation with a frame every physics step and every body's pose.

        Its ``fitness`` is the fitness function on these dense frames, which may differ from
        the stored one (computed on the run's ``record.rate_hz`` frames) for functions that
        look at more than the first and last frame.
        """
        if self._full_rate is None:
            dense = replace(self.task, record_every=1, record_bodies=True)
            self._full_rate = evaluation.evaluate(dense)
        return self._full_rate

    def controls(self) -> np.ndarray:
        """The control in force during each physics step, ``(nstep, nu)``."""
        dense = self.full_rate()
        return np.asarray(dense.joint_target[:-1])

    def properties(self) -> dict[str, object]:
        """What a recording of this replay stores about it (plain values)."""
        row = self.row
        dense = self.full_rate()
        return {
            "run_id": str(row.get("run_id", "")),
            "eval_id": self.eval_id,
            "generation": int(row["generation"]),
            "body_id": str(row["body_id"]),
            "body_encoder": str(row["body_encoder"]),
            "body_genotype": str(row["body_genotype"]),
            "controller": str(row["controller"]),
            "controller_params": [float(v) for v in row["controller_params"]],
            "world": str(row["world"]),
            "fitness_fn": str(row["fitness_fn"]),
            "seed": int(row["seed"]),
            "fitness": self.stored_fitness,
            "replayed_fitness": self.fitness,
            "identical": self.identical,
            "full_rate_fitness": float(dense.fitness),
            "record_every": 1,
            "status": self.status,
        }

    def graph_json(self) -> str | None:
        """The body's morphology graph (networkx node-link JSON) from the bodies table;
        `DamagedRunError` for one that is not a JSON object (a changed table)."""
        bodies = self.run.bodies
        mine = bodies[bodies["body_id"] == self.row["body_id"]]
        graphs = [g for g in mine["graph"] if isinstance(g, str) and g]
        if not graphs:
            return None
        if not isinstance(cell_json(self.run, self.row, "bodies", "graph", graphs[0]), dict):
            raise changed(self.run, self.row, "bodies", "its body's graph is not a JSON object")
        return graphs[0]

    def write_rrd(self, path: str | Path) -> Path:
        """A Rerun recording of the full-rate replay (3D bodies over time, joints, graph);
        `ValueError` for a ``path`` that `output_file_problem` refuses (inside a run folder)."""
        path = _writable(path)
        self._need_body("a recording")
        dense = self.full_rate()
        path.parent.mkdir(parents=True, exist_ok=True)
        return write_evaluation_recording(
            path,
            model=self.model,
            body_names=dense.body_names,
            result=dense,
            properties=self.properties(),
            graph_json=self.graph_json(),
            transforms=True,
        )

    def write_video(
        self, path: str | Path, *, width: int = 640, height: int = 480, fps: int = 30
    ) -> Path:
        """An MP4 of the replay, filmed by a camera that tracks the robot's core.

        mujoco is imported already (the replay simulated), so it renders with the backend
        ``MUJOCO_GL`` named then (`ariel replay --video` sets egl first where no display is
        set); one that fails is `ariel.utils.create_renderer`'s one line. `ValueError` for a
        ``path`` that `output_file_problem` refuses (inside a run folder)."""
        path = _writable(path)
        return resim.replay_video(self, path, width=width, height=height, fps=fps)

    def view(self, *, loop: bool = True) -> None:
        """Play the replay in MuJoCo's interactive viewer, in real time (needs a display)."""
        resim.play_replay(self, loop=loop)

    def driven(self, model: mujoco.MjModel) -> contextlib.AbstractContextManager[None]:
        """While inside, every ``mj_step`` of ``model`` applies this replay's controls.

        Sets the process-wide ``mjcb_control`` (what the tutorial renderers step with) to set
        ``ctrl`` to the control of the current physics step, and restores the previous one.
        """
        return resim.drive_replay(self, model)

    def _need_body(self, what: str) -> None:
        if self.stored_status == "error":
            raise ValueError(
                f"evaluation {self.eval_id!r} has no body to show in {what}: its genotype "
                f"cannot be built ({self.row.get('error') or 'build error'})"
            )


def replay(run_dir: str | Path, eval_id: str) -> ReplayResult:
    """Re-simulate evaluation ``eval_id`` (or ``"best"``) of the run in ``run_dir``.

    The task is rebuilt from the run's records as the loop built it, and evaluated on the
    simulator the row names where it is installed here (else the CPU engine).

    Args:
        run_dir: The run folder.
        eval_id: An evaluation id of its finished generations (e.g. ``"b000012-i003-c005"``),
            or ``"best"``: the run's best evaluation.

    Returns:
        The evaluation re-simulated: the stored and the replayed fitness, whether they are
        identical (bit for bit), and the versions of packages that decide results where
        they differ from the run's.

    Raises:
        UnknownEvaluationError: For an id not in the run's finished generations.
        MissingPluginError: When a plugin of the run is not installed here.
        NotARunError: For a folder that is not a run (`DamagedRunError`: one whose tables
            were changed, whose config has a section that is no table, or whose plugins
            reject the options its config records for them).
        TypeError: When ``eval_id`` is not a string.

    Example:
        ```python
        from ariel.recording import list_runs, replay

        again = replay(list_runs()[-1]["path"], "best")  # a run folder under data/runs
        print(again.eval_id, again.stored_fitness, again.fitness, again.identical)
        ```
    """
    if not isinstance(eval_id, str):  # 5 or None: "no evaluation 5", as if it were an id
        raise TypeError(f"replay: eval_id must be an evaluation id or 'best', not {eval_id!r:.40}")
    run = load_checked(run_dir)
    row = _find_row(run, eval_id)
    _require_plugins(run)
    task = replay_task(run, row, check_params=True)
    result = _evaluate_as_stored(task, row.get("backend"))
    return ReplayResult(
        run=run,
        row=row,
        task=task,
        result=result,
        version_differences=version_differences(run.info, int(row["generation"])),
    )


def has_body_poses(path: str | Path) -> bool:
    """Whether the ``.rrd`` at ``path`` holds the robot's body poses over time (a 3D replay)."""
    from rerun.chunk import RrdReader  # lazy: heavy optional library

    store = RrdReader(Path(path)).stream().collect()
    return any(
        chunk.entity_path == "/world/robot" and not chunk.is_static
        for chunk in store.stream().to_chunks()
    )


def replay_recording_path(run_dir: str | Path, generation: int, eval_id: str) -> Path:
    """``recordings/gen-NNNNNN/replays/<eval_id>.rrd``: an on-demand 3D replay's cache file;
    an ``eval_id`` that is not one (a crafted table's ``../../x``) is refused in one line
    (`DamagedRunError`), never a path outside the run folder."""
    check_eval_id(eval_id, run_dir)
    return recording_path(run_dir, generation, eval_id).parent / REPLAYS / f"{eval_id}.rrd"


def on_demand_recording(run_dir: str | Path, eval_id: str) -> Path:
    """The 3D replay of evaluation ``eval_id`` as the loop records an elite (``record.bodies =
    "all"``): its recording with the bodies' poses at the run's ``record.rate_hz``, made by
    re-simulating it exactly (`replay`), written atomically to `replay_recording_path` and
    reused from there. The poses equal, bit for bit, those an ``all`` run records (recording
    them never changes the physics). Raises as `replay` does.
    """
    run = load_checked(run_dir)
    row = _find_row(run, eval_id)
    path = replay_recording_path(run.path, int(row["generation"]), str(row["eval_id"]))
    if path.is_file():
        return path
    _require_plugins(run)
    replayed = ReplayResult(run=run, row=row, task=None, result=None)
    replayed._need_body("a 3D replay")
    graph = replayed.graph_json()
    # Poses are computed from the recorded frames after the physics: the same physics.
    task = replace(replay_task(run, row, graph=graph, check_params=True), record_bodies=True)
    replayed.task = task
    result = _evaluate_as_stored(task, row.get("backend"))
    replayed.result = result
    refuse_symlinks(path, run.path)
    return write_evaluation_recording(
        path,
        model=replayed.model,
        body_names=result.body_names,
        result=result,
        properties=_recorder_properties(run, row, task, result),
        graph_json=graph,
        transforms=True,
    )


def _recorder_properties(
    run: Run, row: dict[str, Any], task: EvaluationTask, result: EvaluationResult
) -> dict[str, object]:
    """The properties the loop's recorder gives an evaluation's recording, from its row, and
    the replayed fitness (``replayed_fitness``, ``identical``)."""
    config = run.config
    stored = float(row["fitness"])
    parents = row.get("parent_ids")
    return {
        "eval_id": str(row["eval_id"]),
        "run_id": str(row.get("run_id", "")),
        "generation": int(row["generation"]),
        "body_id": str(row["body_id"]),
        "iteration": int(row["iteration"]),
        "candidate": int(row["candidate"]),
        "parent_ids": [str(p) for p in ([] if parents is None else parents)],
        "fitness": stored,
        "status": str(row["status"]),
        "error": row.get("error"),
        "seed": int(row["seed"]),
        "body_encoder": str(row["body_encoder"]),
        "body_genotype_sha1": task.body.key,
        "controller": str(row["controller"]),
        "n_params": len(task.params),
        "world": str(row["world"]),
        "fitness_fn": str(row["fitness_fn"]),
        "morphology": json.dumps(
            {name: float(row[name]) for name in DESCRIPTOR_NAMES if name in row}
        ),
        "replayed": True,
        "replayed_fitness": float(result.fitness),
        "identical": _same_bits(float(result.fitness), stored),
        "record_bodies": str(config.get("record", {}).get("bodies", "")),
    }
