"""What the loop records in Rerun (``record.rerun``): each generation's evaluations in one
recording, elites' 3D replays, ``run.rrd`` and the layouts, in the run folder.

* ``recordings/gen-NNNNNN/evaluations.rrd``: every evaluation of the generation, one step
  each of an ``evaluation`` timeline (`write_generation_recording`): its card, fitness, core
  path, joints and graph. The driver keeps them as batches return and writes the file after
  the generation's tables.
* ``recordings/gen-NNNNNN/<eval_id>.rrd``: an evaluation's own recording with the bodies'
  poses over time (a 3D replay, `write_evaluation_recording`), written by the driver as its
  batch returns (so writing overlaps the workers' physics), after CMA-ES was told the
  batch's fitness. ``record.bodies`` decides which get one: ``all``; ``elites``, the
  evaluations that were their body's best so far when their batch returned (each improvement
  of its brain run, hence always its final best; in a brain-only run, each new best of the
  one brain run); ``none``. `ariel view RUN EVAL_ID` makes any other's 3D replay on demand,
  re-simulating it exactly (``recordings/gen-NNNNNN/replays/<eval_id>.rrd``). A body that
  cannot be built has no recording.
* ``run.rrd``: per generation the best, mean and median fitness of the population after
  selection (as ``Run.generations`` computes them; a brain-only run's mean and median are its
  CMA-ES candidates', as ``ariel report`` draws them), two diversity measures of that population
  (``diversity``: the mean pairwise Euclidean distance between the bodies' morphology
  descriptor vectors, the 12 descriptors as stored; ``distinct_morphologies``: the number of
  distinct robot graphs, compared by structure, ``graph_io.graph_key``), the best body's
  graph and the lineage so far (``/lineage``: a node per body, an edge per parent link,
  `Lineage`; drawn as of at most `LINEAGE_SNAPSHOTS` generations spread over the run, and the
  last: each drawing holds every body so far, so one per generation made run.rrd grow with
  the square of the run, 167 MB at 1,000 generations of 8 bodies); rewritten whole after
  every generation.
* ``blueprint.rbl`` and ``generation.rbl``: the viewer layouts, written once.

Files are written whole under a temporary name and renamed, so a killed run leaves no
unreadable recording; recordings are not fsynced one by one (that costs ~2 ms each; Parquet,
fsynced, is the canonical record), so after a power cut the last generations' recordings may
be empty files. Resume deletes the recordings of unfinished generations (`RunFolder
.discard_after`) and redoes them.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.body_phenotypes.robogen_lite.graph_io import graph_key
from ariel.evolution import (
    BatchEvaluated,
    FlushDue,
    GenerationEnded,
    RunEvent,
    fitness_rank,
)
from ariel.recording.rerun._archive import CvtCells, archive_cells, archive_grid
from ariel.recording.rerun._blueprint import write_blueprint
from ariel.recording.rerun._generation_rrd import (
    EvaluationTrace,
    trace_of,
    write_generation_blueprint,
    write_generation_recording,
)
from ariel.recording.rerun._lineage import LINEAGE_ENTITY, Lineage
from ariel.recording.rerun._rerun import write_evaluation_recording, write_run_recording
from ariel.recording.store import (
    GENERATION_BLUEPRINT,
    NotARunError,
    RunFolder,
    body_rows_of,
    describe_archive,
    evaluation_row,
    generation_recording_path,
    read_table,
    recording_path,
    refuse_symlinks,
)

if TYPE_CHECKING:
    import mujoco
    from rerun import AsComponents
    from rerun.chunk import Chunk

    from ariel.evaluation import EvaluationResult, EvaluationTask
    from ariel.evolution import Body, ExperimentConfig
    from ariel.recording.store import EvaluationRow

# archive_grid: defined in _archive, still importable from here
__all__ = ["RerunRecorder", "archive_grid", "generation_summary"]


#: How many generations' lineage graphs run.rrd holds at most (besides the last one's).
LINEAGE_SNAPSHOTS = 64


def generation_summary(
    generation: int,
    body_rows: Sequence[Mapping[str, Any]],
    maximise: bool,
    candidates: Iterable[float] | None = None,
) -> tuple[dict[str, float], dict[str, Any] | None]:
    """One generation's ``run.rrd`` row and its best body, from its rows of the bodies table.

    The population is the bodies ``selected`` into the next generation. Returns the row
    (generation, best/mean/median fitness of its finite fitnesses, ``diversity`` and
    ``distinct_morphologies``, see the module docstring) and the best body (``body_id``,
    ``fitness``, ``graph``; None when no body has a finite fitness). ``candidates``: a
    brain-only run's fitnesses of the generation's evaluations, whose mean and median are
    the row's, as ``ariel report`` draws them (the one body's would be its best again).
    """

    population = [row for row in body_rows if row.get("selected")]
    fitness = np.array([float(row["fitness"]) for row in population], dtype=np.float64)
    finite = fitness[np.isfinite(fitness)]
    best = float((finite.max() if maximise else finite.min()) if finite.size else math.nan)
    built = [row for row in population if row.get("status", "ok") == "ok"]
    vectors = np.array(
        [[float(row.get(name) or 0.0) for name in DESCRIPTOR_NAMES] for row in built],
        dtype=np.float64,
    ).reshape(len(built), len(DESCRIPTOR_NAMES))
    pairs = list(itertools.combinations(range(len(built)), 2))
    diversity = (
        float(np.mean([np.linalg.norm(vectors[i] - vectors[j]) for i, j in pairs]))
        if pairs
        else 0.0
    )
    if candidates is not None:
        spread = np.array([float(v) for v in candidates], dtype=np.float64)
        spread = spread[np.isfinite(spread)]
    else:
        spread = finite
    row = {
        "generation": int(generation),
        "best_fitness": best,
        "mean_fitness": float(spread.mean()) if spread.size else math.nan,
        "median_fitness": float(np.median(spread)) if spread.size else math.nan,
        "diversity": diversity,
        "distinct_morphologies": float(
            len({graph_key(r["graph"]) if r.get("graph") else r["body_id"] for r in built})
        ),
    }
    ranked = sorted(
        population, key=lambda r: (fitness_rank(float(r["fitness"]), maximise), r["body_id"])
    )
    top = ranked[0] if ranked and math.isfinite(float(ranked[0]["fitness"])) else None
    best_body = (
        None
        if top is None
        else {
            "generation": int(generation),
            "body_id": top["body_id"],
            "fitness": float(top["fitness"]),
            "graph": top.get("graph") or "",
        }
    )
    return row, best_body


class RerunRecorder:
    """Writes a run's Rerun files (see the module docstring); one per run, an observer of its
    driver (`notify`)."""

    def __init__(
        self,
        run_dir: str | Path,
        *,
        run_id: str,
        bodies: str,
        maximise: bool,
        config: ExperimentConfig,
        brain_only: bool = False,
    ) -> None:
        if bodies not in ("all", "elites", "none"):
            raise ValueError(f"record.bodies must be all, elites or none, not {bodies!r}")
        self.run_dir = Path(run_dir)
        self.run_id = run_id
        self.bodies = bodies
        self.maximise = maximise
        self.config = config
        self.brain_only = (
            brain_only  # run.rrd's mean: the brains' candidates (`generation_summary`)
        )
        self._rows: dict[int, dict[str, float]] = {}
        self._best: dict[int, dict[str, Any]] = {}
        # MAP-Elites: fitness per cell (`archive_cells`)
        self._archives: dict[int, np.ndarray | CvtCells] = {}
        self._lineage = Lineage(maximise=maximise)
        # A received folder's linked recordings/ took a resumed run's recordings elsewhere: it
        # is refused before any evaluation (a linked gen-NNNNNN/ is refused by the writer,
        # `atomic_write`, which checks the folder a file goes in).
        refuse_symlinks(self.run_dir / "recordings" / "gen-000000", self.run_dir)
        # per generation: the lineage graph so far
        self._lineages: dict[int, list[AsComponents]] = {}
        self._lineage_stride = 1  # of the generations whose lineage graph is kept
        # run.rrd's chunks of each generation (`write_run_recording`), made once: it is
        # rewritten every generation, and remaking them all was most of a long run's time.
        self._run_chunks: dict[tuple[str, int], Chunk | None] = {}
        self._described: dict[str, Any] | None = None  # run.json's archive description
        # per generation: its evaluations' traces
        self._traces: dict[int, list[EvaluationTrace]] = {}
        self._blueprint = False
        self._waiting: list[dict[str, Any]] = []  # evaluations waiting for their recording

    def notify(self, event: RunEvent) -> None:
        """The driver's events: a batch's evaluations kept as it comes back and recorded once
        the next batches are sent (`FlushDue`); the generation's recordings at its end."""
        if isinstance(event, BatchEvaluated):
            self._keep(event)
        elif isinstance(event, FlushDue):
            self.flush()
        elif isinstance(event, GenerationEnded):
            rows = body_rows_of(self.run_id, self.config, event.generation, event.bodies)
            self.generation(event.generation, [row.record() for row in rows], event.archive)

    def _keep(self, event: BatchEvaluated) -> None:
        """The batch's evaluations that ran (a body that cannot be built has no recording),
        each with its row of the evaluations table."""
        for k, (task, result) in enumerate(zip(event.tasks, event.results)):
            if not result.time.size:
                continue
            row = evaluation_row(
                self.run_id,
                self.config,
                event.body,
                task,
                result,
                event.generation,
                event.iteration,
                k,
            )
            self._waiting.append(
                dict(
                    model=event.model,
                    body=event.body,
                    task=task,
                    result=result,
                    row=row,
                    new_best=k == event.improved,
                )
            )

    def flush(self) -> None:
        """Record the evaluations kept since the last call."""
        while self._waiting:
            evaluation = self._waiting.pop(0)
            self.evaluation(**evaluation)
            result = evaluation["result"]
            result.body_pos = result.body_quat = None  # recorded; not kept till the tables

    @property
    def record_bodies(self) -> bool:
        """Whether evaluations must return body poses (``EvaluationTask.record_bodies``)."""
        return self.bodies != "none"

    def evaluation(
        self,
        *,
        model: mujoco.MjModel,
        body: Body,
        task: EvaluationTask,
        result: EvaluationResult,
        row: EvaluationRow,
        new_best: bool,
    ) -> Path | None:
        """Keep the evaluation (``row``: its `EvaluationRow`) for its generation's recording, and
        write its own recording (a 3D replay) when ``record.bodies`` asks for it; ``new_best``:
        it improved its body's best. Returns the path of its own recording, if one was written.
        """
        if not self._blueprint:
            self.write_blueprint()
        generation = row.generation
        properties = {
            **row.card(),  # the row's fields marked for the card, in column order
            "new_best": bool(new_best),
            "body_genotype_sha1": task.body.key,
            "n_params": len(row.controller_params),
            # One text property, not twelve: each property is a column of ~300 bytes.
            "morphology": json.dumps(
                {name: float(value) for name, value in row.descriptors.items()}
            ),
        }
        graph = body.graph or None
        self._traces.setdefault(generation, []).append(trace_of(properties, result, graph))
        if not (self.bodies == "all" or (self.bodies == "elites" and new_best)):
            return None  # in the generation's recording only
        return write_evaluation_recording(
            recording_path(self.run_dir, generation, task.eval_id),
            model=model,
            body_names=result.body_names,
            result=result,
            properties=properties,
            graph_json=graph,
        )

    def generation(
        self,
        generation: int,
        body_rows: Sequence[Mapping[str, Any]],
        archive: Sequence[Mapping[str, Any]] | None = None,
    ) -> Path:
        """After a generation's tables: write its evaluations' recording
        (``recordings/gen-NNNNNN/evaluations.rrd``), add its summary (and its MAP-Elites
        archive) and rewrite ``run.rrd``."""
        if not self._blueprint:
            self.write_blueprint()
        traces = self._traces.pop(generation, [])
        write_generation_recording(
            generation_recording_path(self.run_dir, generation),
            traces,
            run_id=self.run_id,
            generation=generation,
        )
        self._load_earlier(generation)
        candidates = [t.fitness for t in traces] if self.brain_only else None
        row, best = generation_summary(generation, body_rows, self.maximise, candidates)
        self._rows[generation] = row
        if best is not None:
            self._best[generation] = best
        self._grow_lineage(generation, body_rows)
        if archive is not None:
            self._archives[generation] = archive_cells(archive, self._description())
        gens = sorted(g for g in self._rows if g <= generation)
        columns = {key: [self._rows[g][key] for g in gens] for key in row}
        c = self.config
        return write_run_recording(
            self.run_dir / "run.rrd",
            columns,
            {g: b for g, b in self._best.items() if g <= generation},
            archives={g: a for g, a in self._archives.items() if g <= generation},
            lineage={g: a for g, a in self._lineages.items() if g <= generation},
            run_id=self.run_id,
            chunk_cache=self._run_chunks,
            properties={
                "run_id": self.run_id,
                "name": c.name,
                "seed": c.seed,
                "generations": c.generations,
                "generations_done": generation + 1,
                "body_encoder": c.body.encoder,
                "controller": c.brain.controller,
                "world": c.world.name,
                "fitness_fn": c.task.fitness,
                "config": json.dumps(c.to_plain(), sort_keys=True),
            },
        )

    def _load_earlier(self, generation: int) -> None:
        """A resumed run: summarise the finished generations from the bodies table, once."""
        missing = [g for g in range(generation) if g not in self._rows]
        if not missing:
            return
        rows = read_table(self.run_dir, "bodies", up_to=generation - 1).to_pylist()
        cells = read_table(self.run_dir, "archive", up_to=generation - 1).to_pylist()
        fitness = (
            read_table(self.run_dir, "evaluations", up_to=generation - 1)
            .select(["generation", "fitness"])
            .to_pylist()
            if self.brain_only
            else []
        )
        for g in missing:
            archive = [row for row in cells if row["generation"] == g]
            if archive:
                self._archives[g] = archive_cells(archive, self._description())
            bodies = [r for r in rows if r["generation"] == g]
            candidates = [r["fitness"] for r in fitness if r["generation"] == g]
            row, best = generation_summary(
                g, bodies, self.maximise, candidates if self.brain_only else None
            )
            self._rows[g] = row
            if best is not None:
                self._best[g] = best
            self._grow_lineage(g, bodies)

    def _grow_lineage(self, generation: int, body_rows: Sequence[Mapping[str, Any]]) -> None:
        """Add the generation's bodies to the lineage and keep its graph as of then; of the
        earlier graphs, those of every ``stride``-th generation, the stride doubled until at
        most `LINEAGE_SNAPSHOTS` are left (the viewer shows the last one before the time)."""
        self._lineage.grow(body_rows, generation)
        self._lineages[generation] = self._lineage.archetypes()
        stride = self._lineage_stride
        while sum(1 for g in self._lineages if g % stride == 0) > LINEAGE_SNAPSHOTS:
            stride *= 2
        self._lineage_stride = stride
        for g in [g for g in self._lineages if g % stride and g != generation]:
            del self._lineages[g]
            self._run_chunks.pop((LINEAGE_ENTITY, g), None)

    def _description(self) -> dict[str, Any] | None:
        """run.json's ``archive`` (the driver writes it before the first generation); None: a
        grid (a run made before it was recorded)."""
        if self._described is None:
            with contextlib.suppress(NotARunError):
                self._described = describe_archive(RunFolder(self.run_dir).read_info(), None)
        return self._described

    def write_blueprint(self) -> Path:
        """Write the layouts: ``blueprint.rbl`` (evaluations, run.rrd) and ``generation.rbl``
        (the generations' ``evaluations.rrd``)."""
        path = write_blueprint(self.run_dir / "blueprint.rbl")
        write_generation_blueprint(self.run_dir / GENERATION_BLUEPRINT)
        self._blueprint = True
        return path
