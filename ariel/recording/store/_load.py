"""Load a run folder into pandas: `load_run(path)` (`list_runs(folder)` lists them)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.body_phenotypes.robogen_lite.graph_io import graph_key
from ariel.errors import UnknownEvaluationError
from ariel.evolution import archive_quality
from ariel.plugins import body_encoders, fitness_functions
from ariel.recording.store._archive import archive_cell_count, describe_archive
from ariel.recording.store._escape import short_ascii, terminal_text
from ariel.recording.store._files import damaged
from ariel.recording.store._lineage import lineage
from ariel.recording.store._manifest import Manifest, relative
from ariel.recording.store._run_folder import (
    DamagedRunError,
    JsonObject,
    NotARunError,
    RunFolder,
)
from ariel.recording.store._tables import generation_file, read_file, read_table, to_pandas
from ariel.utils import path_argument

__all__ = [
    "QD_COLUMNS",
    "Run",
    "archive_quality_table",
    "load_run",
    "population_after_selection",
    "stored_graph_key",
]


@dataclass
class Run:
    """A run's records. Tables load on first access and hold finished generations only.

    Attributes:
        path: the run folder, as it was given.
        root: the run folder as an absolute path, where its tables are read from (the same
            folder after a notebook changes directory).
        info: ``run.json`` (status, seed, versions, plugin provenance, times, ...).
        config: the resolved experiment config as a dict.
        manifest: what the finished generations' tables must be (a
            `ariel.recording.store._manifest.Manifest`: each file's size and SHA-256), checked as
            the tables are read; None reads them unchecked.
    """

    path: Path
    info: JsonObject
    config: JsonObject = field(init=False)
    manifest: Manifest | None = field(default=None, repr=False)  # what is checked
    # Where its tables are read from: the folder as it was when loaded, so that a notebook
    # that changes directory still reads it (a relative path then named another folder, and
    # its tables were reported as damaged).
    root: Path = field(init=False, repr=False)

    def __post_init__(self) -> None:
        config = self.info.get("config")
        self.config = config if isinstance(config, dict) else {}
        self.root = Path(self.path).absolute()
        if self.manifest is not None:  # it reads the files too: from the same folder
            self.manifest = replace(self.manifest, run_dir=self.root)

    def __repr__(self) -> str:
        """One line: ``<Run ID: STATUS, DONE/GENERATIONS generations, N evaluations, best
        fitness F>``, from run.json (no table is read)."""
        run_id = self.info.get("run_id")
        run_id = run_id if isinstance(run_id, str) else self.path.name
        total = self.config.get("generations")
        done = f"{self.generations_done}/{total}" if isinstance(total, int) else "?"
        evaluations = self.info.get("evaluations_done")
        count = f"{evaluations:,}" if isinstance(evaluations, int) else "?"
        best = self.info.get("best_fitness")
        fitness = f"{best:.6g}" if isinstance(best, int | float) else "none"
        return (
            f"<Run {run_id}: {self.info.get('status', '?')}, {done} generations, "
            f"{count} evaluations, best fitness {fitness}>"
        )

    @property
    def generations_done(self) -> int:
        done = self.info.get("generations_done", 0)
        return done if isinstance(done, int) and done >= 0 else 0

    @cached_property
    def maximise(self) -> bool:
        """Whether higher fitness is better: run.json's ``maximise``. A run made before run.json
        recorded it asks its fitness function (which must then be installed here)."""
        recorded = self.info.get("maximise")
        if isinstance(recorded, bool):
            return recorded

        name = str(self.config.get("task", {}).get("fitness", "xy_displacement"))
        try:
            return bool(fitness_functions.get(name).maximise)
        except (KeyError, ValueError, ImportError):
            raise NotARunError(
                f"{self.path / 'run.json'}: no fitness direction recorded (a run made before "
                f"run.json held 'maximise') and fitness function {name!r} is not installed "
                "here; install the plugin that provides it"
            ) from None

    @property
    def body_optimizer(self) -> str:
        """The body optimizer its config names (``"ga"``, ``"map_elites"``, ``"novelty"``, ...);
        ``"ga"`` for a run made before configs named one (the GA was the only one then);
        ``"none"`` for a brain-only run, which asks none whatever its config says."""
        if self.brain_only:
            return "none"
        body = self.config.get("body")
        optimizer = body.get("optimizer") if isinstance(body, Mapping) else None
        return optimizer if isinstance(optimizer, str) and optimizer else "ga"

    @cached_property
    def brain_only(self) -> bool:
        """One fixed body (run.json's ``brain_only``). A run made before run.json recorded it:
        ``body.genotype`` set, an encoder that cannot vary its genotypes, or one body."""
        recorded = self.info.get("brain_only")
        if isinstance(recorded, bool):
            return recorded
        body = self.config.get("body", {})
        if body.get("genotype") is not None:
            return True

        try:
            encoder = body_encoders.get(body.get("encoder", "nde"))
            return not bool(getattr(encoder, "evolvable", True))
        except (KeyError, ValueError, ImportError, AttributeError):
            return self.bodies["body_id"].nunique() == 1  # not installed: judge the records

    def _table(self, name: str) -> Any:
        up_to = self.generations_done - 1
        return to_pandas(read_table(self.root, name, up_to=up_to, manifest=self.manifest))

    @cached_property
    def evaluations(self) -> Any:
        """One row per evaluation (ids, genotype, controller params, fitness, status, ...)."""
        return self._table("evaluations")

    @cached_property
    def bodies(self) -> Any:
        """One row per body per generation (``selected``: it survived into the next one)."""
        return self._table("bodies")

    @cached_property
    def trajectories(self) -> Any:
        """One row per recorded frame: ``eval_id``, ``t``, core position, joint lists."""
        return self._table("trajectories")

    def lineage(self) -> pd.DataFrame:
        """The run's lineage in the ALife data standard's phylogeny format: one row per body
        ever evaluated (``id``, ``ancestor_list``, ``origin_time``, ``destruction_time``, ...;
        every column defined in `ariel.recording.store._lineage`). Computed on each call.

        `ariel.recording.write_lineage_csv` writes it as the standard's CSV (``ariel export
        RUN --lineage FILE.csv``); `ariel.recording.lineage_statistics` counts the surviving
        lineages and the best body's ancestry depth per generation.

        Returns:
            A DataFrame ordered by ``id`` (`ariel.recording.lineage`).

        Raises:
            DamagedRunError: When the bodies table holds a body id that is not one, or a
                parent that is no body of the run.
        """

        return lineage(self)

    def joint_signals(self, eval_id: str) -> pd.DataFrame:
        """Evaluation ``eval_id``'s joint signals: a DataFrame indexed by ``t`` (seconds), one
        column per signal and joint, ``("target", joint)`` and ``("angle", joint)`` (radians),
        joints named as in its ``joint_names``. Reads that evaluation's rows only.

        Raises `UnknownEvaluationError` for an id not in the run's finished generations.
        """

        evals = self.evaluations
        found = evals[evals["eval_id"] == eval_id]
        if not len(found):
            raise UnknownEvaluationError(
                f"no evaluation {eval_id!r} in the finished generations of run {str(self.path)!r}"
            )
        row = found.iloc[0]
        joints = [str(name) for name in row["joint_names"]]
        columns = pd.MultiIndex.from_product(
            [["target", "angle"], joints], names=["signal", "joint"]
        )
        path = generation_file(self.root, "trajectories", int(row["generation"]))
        if not path.is_file():  # record.trajectories = false
            return pd.DataFrame(columns=columns, index=pd.Index([], name="t"), dtype=float)
        frames = read_file(
            self.root,
            path,
            "trajectories",
            manifest=self.manifest,
            filters=[("eval_id", "==", eval_id)],
            columns=["eval_id", "t", "joint_target", "joint_angle"],
        ).sort_by("t")
        width = len(joints)

        def signal(name: str) -> np.ndarray:
            column = frames.column(name).combine_chunks()
            values = column.flatten().to_numpy(zero_copy_only=False)
            if column.null_count or values.size != frames.num_rows * width:  # no run writes it
                problem = f"has {name} lists of evaluation {terminal_text(eval_id)} that are not"
                raise damaged(self.path, relative(self.root, path), f"{problem} one per joint")
            return np.asarray(values, dtype=np.float64).reshape(frames.num_rows, width)

        data = np.hstack([signal("joint_target"), signal("joint_angle")])
        index = pd.Index(frames.column("t").to_numpy(), name="t")
        return pd.DataFrame(data, index=index, columns=columns)

    @cached_property
    def archive(self) -> Any:
        """MAP-Elites runs: one row per filled cell of the archive after each generation
        (``cell``, the elite's ``body_id``, ``fitness``, ``measures``, ``grid``); empty else."""
        return self._table("archive")

    @cached_property
    def novelty(self) -> Any:
        """Novelty search runs: after each generation, one row per body of the population
        (its ``novelty``, ``local_competition`` and ``rank``) or of the novelty archive
        (``in_archive``), with its normalised ``place``; empty for other runs."""
        return self._table("novelty")

    @cached_property
    def archive_description(self) -> JsonObject | None:
        """MAP-Elites and novelty runs: what the archive is (``kind``, ``"grid"`` or ``"cvt"``;
        ``measures``; ``ranges``; a grid's ``bins`` or a CVT's ``cells`` and ``centroids``),
        as run.json records it; a run made before that: its grid, from its config and the
        ``archive`` table (`describe_archive`). None for a run without an archive.

        Raises `DamagedRunError` where the description or the table's rows are what no ariel
        writes (`archive_damage`: a cell past the archive, centroids that are not points)."""
        return describe_archive(self.info, self.archive, run_dir=self.path)

    @cached_property
    def population(self) -> Any:
        """The bodies table's rows of the population after selection: per generation, the
        bodies kept for the next one (``selected``) with a finite fitness; the bodies whose
        fitness and morphology `generations` sums up (`population_after_selection`)."""
        return population_after_selection(self.bodies)

    @cached_property
    def qd_offset(self) -> float | None:
        """MAP-Elites runs: the fitness that counts as nothing in the QD-score (run.json's
        ``qd_offset``, the ``map_elites`` option ``qd_offset``). A run made before run.json
        recorded it: 0 for a maximised fitness (its QD-score then was the same sum), None for
        a minimised one (no offset known: its QD-scores are NaN)."""
        recorded = self.info.get("qd_offset")
        if isinstance(recorded, int | float) and not isinstance(recorded, bool):
            return float(recorded)
        return 0.0 if self.maximise else None

    @cached_property
    def generations(self) -> Any:
        """Per generation: evaluations, failures, and best / mean / median fitness of the
        population after selection (a MAP-Elites run: its elites), and ``distinct_bodies``:
        how many distinct robot graphs that population holds (by structure,
        `ariel.body_phenotypes.robogen_lite.graph_io.graph_key`; a body without a graph counts
        as its own; NaN for a table without graphs).

        MAP-Elites runs also get the archive's QD metrics, as the run printed them
        (`ariel.evolution._qd.archive_quality`): ``coverage`` (filled cells / cells),
        ``qd_score`` (the sum over elites of how much better than `qd_offset` each is, never
        below 0) and ``norm_qd_score`` (``qd_score`` / cells).

        Then the population's mean morphology: ``mean_<descriptor>`` for each morphology
        descriptor (``mean_num_modules``, ...): its mean over the bodies the fitness columns
        describe (NaN where none has descriptors)."""

        evaluations, bodies = self.evaluations, self.bodies
        maximise = self.maximise if len(evaluations) else True
        rows = []
        # Grouped once: a filter per generation made this generations x evaluations.
        by_generation = dict(tuple(evaluations.groupby("generation", sort=False)))
        for generation, group in bodies.groupby("generation", sort=True):
            population = population_after_selection(group)
            alive = population["fitness"]
            evals = by_generation.get(generation, evaluations.iloc[:0])
            morphology = {
                f"mean_{name}": float(population[name].astype("Float64").mean())
                if population[name].notna().any()
                else math.nan
                for name in DESCRIPTOR_NAMES
            }
            rows.append(
                {
                    "generation": int(generation),
                    "evaluations": len(evals),
                    "new_bodies": int(group["is_new"].sum()),
                    "errors": int((evals["status"] == "error").sum()),
                    "unstable": int((evals["status"] == "unstable").sum()),
                    "invalid": int((evals["status"] == "invalid").sum()),
                    "best_fitness": (alive.max() if maximise else alive.min())
                    if len(alive)
                    else math.nan,
                    "mean_fitness": alive.mean() if len(alive) else math.nan,
                    "median_fitness": alive.median() if len(alive) else math.nan,
                    "distinct_bodies": _distinct_bodies(population),
                    **morphology,
                }
            )
        columns = [
            "generation",
            "evaluations",
            "new_bodies",
            "errors",
            "unstable",
            "invalid",
            "best_fitness",
            "mean_fitness",
            "median_fitness",
            "distinct_bodies",
        ]
        morphology_columns = [f"mean_{name}" for name in DESCRIPTOR_NAMES]
        # the columns even before a generation ends
        frame = pd.DataFrame(rows, columns=columns + morphology_columns)
        if not rows:  # the dtypes a finished generation gives (all object when empty)
            counts = [*columns[:6], "distinct_bodies"]
            frame = frame.astype({n: "int64" if n in counts else "float64" for n in frame})
        archive = self.archive
        if len(archive):
            quality = archive_quality_table(
                archive, self.qd_offset, maximise, self.archive_description
            )
            frame = frame.join(quality, on="generation")
            frame = frame[[*columns, *QD_COLUMNS, *morphology_columns]]
        return frame


#: The QD metrics `Run.generations` has for a MAP-Elites run.
QD_COLUMNS = ("coverage", "qd_score", "norm_qd_score")


def archive_quality_table(
    archive: pd.DataFrame,
    qd_offset: float | None,
    maximise: bool,
    description: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Per generation of an ``archive`` table (`Run.archive`): the `QD_COLUMNS`, as
    `ariel.evolution._qd.archive_quality` computes them in the run (QD-scores NaN
    when ``qd_offset`` is None: an old run of a minimised fitness), over the cells of
    ``description`` (`Run.archive_description`; None: the product of the ``grid`` column)."""

    rows = {}
    for generation, group in archive.groupby("generation", sort=True):
        cells = (
            archive_cell_count(description) if description else int(np.prod(group["grid"].iloc[0]))
        )
        fitness = group["fitness"].astype(float).tolist()
        if qd_offset is None:
            rows[generation] = {
                "coverage": len(fitness) / cells,
                "qd_score": math.nan,
                "norm_qd_score": math.nan,
            }
        else:
            rows[generation] = archive_quality(fitness, cells, qd_offset, maximise)
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(QD_COLUMNS))
    frame.index.name = "generation"
    return frame


def _distinct_bodies(population: pd.DataFrame) -> int | float:
    """Distinct robot graphs among ``population``'s rows (see `Run.generations`)."""

    if "graph" not in population.columns:
        return math.nan

    def key(graph: object, body_id: object) -> object:
        return stored_graph_key(graph, body_id) if isinstance(graph, str) and graph else body_id

    return len(
        {key(graph, body_id) for graph, body_id in zip(population["graph"], population["body_id"])}
    )


def stored_graph_key(graph: str, body_id: object) -> str:
    """`graph_key` of a bodies table's ``graph`` cell; a cell that is no robot graph (no run
    writes one) is a one-line `DamagedRunError` naming the body, not a traceback."""
    try:
        return graph_key(graph)
    except Exception as exc:  # RecursionError, JSON, networkx
        raise DamagedRunError(
            f"body {terminal_text(body_id)}: its graph cell is not a robot graph "
            f"({type(exc).__name__}); the bodies table was changed or damaged"
        ) from None


def population_after_selection(bodies: Any) -> Any:
    """The rows of a bodies table (``Run.bodies``) that form the population after selection:
    ``selected`` (kept for the next generation; a MAP-Elites run: its elites) with a finite
    fitness (a body that could not be built or never scored is left out).

    Args:
        bodies: A bodies table (a DataFrame with ``selected`` and ``fitness`` columns), of
            one generation or of several.

    Returns:
        Those rows, a DataFrame with the same columns and index labels.
    """
    kept = bodies[bodies["selected"].eq(True)]  # a null (a table read unchecked): not kept
    # A boolean mask even when no body is kept (an empty map is no mask: it picks columns)
    return kept[kept["fitness"].map(math.isfinite).astype(bool)]


def load_run(path: str | Path) -> Run:
    """The records of the run in ``path`` (a folder made by `ariel run`).

    Its finished generations' tables are checked against the run's manifest: a missing or
    changed table raises `DamagedRunError` (a `NotARunError`), here for a missing file or one of
    another size, when a table is first read for other bytes. Works without the run's plugins
    installed (run.json records what readers need).

    Args:
        path: The run folder.

    Returns:
        The run's records: ``info`` (run.json) and ``config`` at once, and its tables as
        pandas DataFrames (``evaluations``, ``bodies``, ``trajectories``, ``archive``, the
        per-generation summary ``generations``) loaded on first access.

    Raises:
        NotARunError: When ``path`` has no readable run.json.
        DamagedRunError: When a finished generation's table is missing or has another size
            than its manifest says, or run.json holds no config.

    Example:
        ```python
        from ariel.recording import list_runs, load_run

        run = load_run(list_runs()[-1]["path"])  # the last run by name under ./data/runs
        print(run)  # <Run ID: STATUS, DONE/GENERATIONS generations, N evaluations, ...>
        print(run.generations[["generation", "best_fitness", "mean_fitness"]])
        best = run.evaluations.sort_values("fitness", ascending=not run.maximise).iloc[0]
        print(best["eval_id"], best["fitness"])
        ```
    """

    folder = RunFolder(path_argument("path", path, function="load_run"))
    info = folder.read_info()
    if not isinstance(info.get("config"), dict):  # what the tables are checked against
        raise damaged(
            folder.path,
            "run.json",
            f"has no config (its 'config' is {short_ascii(info.get('config'))})",
        )
    return Run(path=folder.path, info=info, manifest=Manifest.load(folder.path, info))
