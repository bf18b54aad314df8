"""Rerun recordings: one ``.rrd`` per evaluation, a run-level ``run.rrd``, a viewer blueprint.

Parquet is the canonical record; these files are for looking (``rerun blueprint.rbl
recordings/gen-000003/*.rrd``). Rerun is imported here only, on first use.

Each recording is built after its rollout, column-wise: whole Rerun chunks, one per entity
(`rerun.chunk.Chunk.from_columns`, the chunk-level form of ``send_columns``; time series on a
``sim_time`` timeline, never a ``log`` call per frame), written as one recording with
`LazyChunkStream.write_rrd` under a temporary name and renamed (`atomic_write`): a killed
writer never leaves an unreadable ``.rrd``. No `RecordingStream` is involved, global or not:
a stream per recording (threads, batcher, sink) cost 4.2 ms of CPU against 1.3 ms for the same
chunks written directly, and the chunks every recording of a body shares (world, robot
geometry, joint names, graph) are built once and reused. Application id ``ariel``; the
recording id and name of an evaluation's recording are its eval id.

Entities of an evaluation recording (few on purpose: each is a chunk of ~1.5 kB overhead and
~0.3 ms to encode; one entity per body and per joint made a recording of a 19-body robot
3 times bigger and slower, 150 kB and 13 ms):

* ``/world``: the view coordinates (z up) and the floor, static: a plane as a thin box, a
  heightfield as a `Mesh3D` (cropped to the robot's path, see `TERRAIN_MARGIN`); other world
  geoms (walls, platforms) under ``/world/<geom>``.
* ``/world/robot``: every robot body's geometry as one `Boxes3D` batch, one box per body geom,
  coloured by module type (core yellow, brick blue, hinge red), labelled with the body name.
  With body poses (``transforms``) the boxes' world poses (centers + quaternions) change over
  ``sim_time``, one row per recorded frame, one instance per body geom: a 3D replay. Without,
  the robot stands in its start pose.
* ``/world/trajectory``: the core's path, a `LineStrips3D`.
* ``/joints/target`` and ``/joints/angle``: one scalar series per joint (named after the
  joint, `SeriesLines` names) over ``sim_time``: the control target and the measured angle.
* ``/graph``: the morphology graph, `GraphNodes` coloured by module type, labelled short
  ("core", "brick", a hinge by branch and number: "right 1") and placed as a tree from the
  core down (`tree_positions`), and directed `GraphEdges` (parent -> child).
* recording properties (``/__properties/ariel``): the caller's ``properties``.

``run.rrd`` (`write_run_recording`) holds per-generation fitness and diversity on a
``generation`` timeline, the best body of each generation and the lineage so far
(``/lineage``, `ariel.recording.rerun._lineage`); ``blueprint.rbl``
(`write_blueprint`) the default layout for all of them. ``ariel view`` opens an evaluation's
recording as a copy with the run's charts (and a MAP-Elites archive) beside it
(`write_view_recording`), laid out by a `blueprint` written for that run.

What the recordings share lives beside this module, and its names are still importable from
here: the chunk primitives (`ariel.recording.rerun._chunks`), a model's scene
(`ariel.recording.rerun._scene`), the morphology graph (`ariel.recording.rerun._graph`), the
views (`ariel.recording.rerun._views`) and the layout (`ariel.recording.rerun._blueprint`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.rerun._archive import (
    ARCHIVE_ENTITY,
    CvtCells,
    archive_image,
    archive_shown,
)
from ariel.recording.rerun._blueprint import (
    blueprint as blueprint,
    save_blueprint as save_blueprint,
    write_blueprint,
)
from ariel.recording.rerun._chunks import (
    APPLICATION_ID,
    _one_row,
    _property_chunks,
    rerun_module,
    rgb,
    static_chunk,
)
from ariel.recording.rerun._graph import (
    GRAPH_STEP as GRAPH_STEP,
    _graph_chunk,
    _graph_parts as _graph_parts,
    graph_archetypes,
    graph_colour as graph_colour,
    tree_positions,
)
from ariel.recording.rerun._joint_names import GraphJson, joint_labels
from ariel.recording.rerun._lineage import LINEAGE_ENTITY
from ariel.recording.rerun._scene import (
    TERRAIN_MARGIN,
    TERRAIN_MAX_SIDE as TERRAIN_MAX_SIDE,
    _box_poses,
    _Scene,
    _scene,
    _terrain,
    module_colours,
    module_type_of,
)
from ariel.recording.rerun._views import SUMMARY_SERIES
from ariel.recording.store import atomic_write, condition_colours
from ariel.utils import raise_pending

if TYPE_CHECKING:
    import mujoco
    import pandas as pd
    from rerun import AsComponents, TimeColumn
    from rerun.chunk import Chunk

    from ariel.evaluation import EvaluationResult

    #: A run's series per generation: a DataFrame or a dict of columns.
    Generations = pd.DataFrame | Mapping[str, Sequence[float]]

__all__ = [
    "APPLICATION_ID",
    "ARCHIVE_ENTITY",
    "TERRAIN_MARGIN",
    "archive_chunks",
    "module_colours",
    "module_type_of",
    "tree_positions",
    "write_blueprint",
    "write_evaluation_recording",
    "write_run_recording",
    "write_view_recording",
]


# Every writer's recordings go through this one (and this module's `atomic_write`).
def _write_chunks(
    path: Path,
    recording_id: str,
    chunks: Sequence[Chunk],
    *,
    fsync: bool,
    application_id: str = APPLICATION_ID,
) -> Path:
    """Write ``chunks`` as one recording whole to ``path``."""
    rr = rerun_module()

    def write(temporary: Path) -> None:
        try:
            rr.chunk.LazyChunkStream.from_iter(chunks).write_rrd(
                temporary, application_id=application_id, recording_id=recording_id
            )
        except Exception:
            # A signal taken inside Rerun's writer comes out wrapped ("RuntimeError:
            # Interrupted: 15"): then the interrupt is what happened, not a failed write.
            raise_pending()
            raise

    atomic_write(path, write, fsync=fsync)
    return path


# --------------------------------------------------------------------------------------------
# One evaluation
# --------------------------------------------------------------------------------------------


def write_evaluation_recording(
    path: str | os.PathLike[str],
    *,
    model: mujoco.MjModel,
    body_names: Sequence[str],
    result: EvaluationResult,
    properties: Mapping[str, object],
    graph_json: GraphJson | None = None,
    transforms: bool = True,
    fsync: bool = False,
) -> Path:
    """Write one evaluation's ``.rrd`` (entities: see the module docstring).

    Safe to call from a loop and from threads: no global state but small caches of what the
    recordings of one model (and one graph) share.

    Args:
        path: The ``.rrd`` file to write, whole under a temporary name and renamed; an
            existing one is replaced.
        model: The compiled robot + world (``ariel.evaluation.build(task).model``).
        body_names: The robot bodies ``result.body_pos`` refers to (``result.body_names``).
        result: An `EvaluationResult`.
        properties: Plain values (eval_id, body_id, run_id, generation, fitness, status,
            seed, controller, ...) stored as recording properties; the recording id and name
            are ``properties["eval_id"]`` (else ``result.eval_id``, else the file's stem).
        graph_json: The morphology as networkx node-link JSON (or its dict), drawn at
            ``/graph`` and used to label the joints; None: no graph.
        transforms: Whether to record the bodies' poses over ``sim_time`` (a 3D replay), when
            ``result`` has them (``body_pos``/``body_quat``, from
            ``EvaluationTask(record_bodies=True)``); else the robot is drawn in its start
            pose.
        fsync: Whether to also fsync the file (a killed writer never leaves a partial file
            either way; fsync costs ~2 ms a file and only matters for a power cut).

    Returns:
        ``path``, as a `Path`.
    """
    path = Path(path)
    eval_id = str(properties.get("eval_id") or getattr(result, "eval_id", "") or path.stem)
    shared = _scene(model, body_names)
    chunks = [*_property_chunks(properties, eval_id), *shared.world]
    core = np.asarray(result.core_pos, dtype=np.float32).reshape(-1, 3)
    for terrain in shared.heightfields:
        chunks.append(static_chunk(terrain.path, _terrain(terrain, core[:, :2])))

    rr = rerun_module()
    times = np.asarray(result.time, dtype=np.float64)
    sim_time = [rr.TimeColumn("sim_time", duration=times)]
    chunks += _robot_chunks(shared, result, body_names, times, sim_time, transforms=transforms)
    if len(core):
        strip = rr.LineStrips3D([core], colors=[module_colours()["CORE"]], radii=[0.005])
        chunks.append(static_chunk("/world/trajectory", strip))
    chunks += _joint_chunks(shared, result, graph_json, times, sim_time)
    if graph_json:
        graph = _graph_chunk(graph_json)
        if graph is not None:
            chunks.append(graph)
    return _write_chunks(path, eval_id, chunks, fsync=fsync)


def _robot_chunks(
    shared: _Scene,
    result: EvaluationResult,
    body_names: Sequence[str],
    times: np.ndarray,
    sim_time: list[TimeColumn],
    *,
    transforms: bool,
) -> list[Chunk]:
    """``/world/robot``: the boxes' world poses over ``sim_time`` (with ``transforms``, where
    ``result`` has the bodies' poses: a 3D replay), else the robot standing in its start pose."""
    rr = rerun_module()

    body_pos = getattr(result, "body_pos", None)
    body_quat = getattr(result, "body_quat", None)
    moving = (
        transforms
        and body_pos is not None
        and body_quat is not None
        and len(body_pos) == len(times) > 0
        and np.shape(body_pos)[1] == len(body_names)
    )
    boxes = len(shared.geom_body)
    if moving and boxes:
        pos, quat = np.asarray(body_pos), np.asarray(body_quat)  # not None: `moving`
        centers, quats = _box_poses(pos, quat, shared.geom_body, shared.geom_pos, shared.geom_quat)
        poses = (
            rerun_module()
            .Boxes3D.columns(centers=centers.reshape(-1, 3), quaternions=quats.reshape(-1, 4))
            .partition([boxes] * len(times))
        )
        return [shared.robot_sizes, rr.chunk.Chunk.from_columns("/world/robot", sim_time, poses)]
    if boxes:
        return [shared.robot_still]
    return []


def _joint_chunks(
    shared: _Scene,
    result: EvaluationResult,
    graph_json: GraphJson | None,
    times: np.ndarray,
    sim_time: list[TimeColumn],
) -> list[Chunk]:
    """``/joints/target`` and ``/joints/angle`` over ``sim_time``: one series per joint, named
    for people (`joint_labels`; the names' chunks are kept with the model's scene)."""
    rr = rerun_module()
    targets = np.asarray(result.joint_target, dtype=np.float64)
    angles = np.asarray(result.joint_angle, dtype=np.float64)
    joints = targets.shape[1] if targets.ndim == 2 and len(times) else 0
    if not joints:
        return []
    names = tuple(getattr(result, "joint_names", None) or ())[:joints]
    if names not in shared.joint_names:
        labels = joint_labels(names, graph_json) + [f"joint{j}" for j in range(len(names), joints)]
        # each joint one colour in both panels (Rerun picks one per entity path: a joint's
        # target and angle came out in two unrelated colours)
        colours = [rgb(c) for c in condition_colours([str(j) for j in range(joints)]).values()]
        shared.joint_names[names] = [
            static_chunk(f"/joints/{leaf}", rr.SeriesLines(names=labels, colors=colours))
            for leaf in ("target", "angle")
        ]
    chunks = list(shared.joint_names[names])
    for leaf, values in (("target", targets), ("angle", angles)):
        scalars = rr.Scalars.columns(scalars=values.ravel()).partition([joints] * len(times))
        chunks.append(rr.chunk.Chunk.from_columns(f"/joints/{leaf}", sim_time, scalars))
    return chunks


# --------------------------------------------------------------------------------------------
# The run
# --------------------------------------------------------------------------------------------

#: Columns of ``generations_df`` that `write_run_recording` plots, and their entities.
RUN_SERIES: dict[str, str] = {
    "best_fitness": "/fitness/best",
    "mean_fitness": "/fitness/mean",
    "median_fitness": "/fitness/median",
    "diversity": "/diversity/descriptor_distance",
    "distinct_morphologies": "/diversity/distinct_morphologies",
}


def write_run_recording(
    path: str | os.PathLike[str],
    generations_df: Generations,
    best_bodies: Mapping[int, Mapping[str, Any]] | Sequence[Mapping[str, Any]],
    *,
    archives: Mapping[int, np.ndarray | CvtCells] | None = None,
    lineage: Mapping[int, Sequence[AsComponents]] | None = None,
    run_id: str = "",
    properties: Mapping[str, object] | None = None,
    fsync: bool = True,
    chunk_cache: dict[tuple[str, int], Chunk | None] | None = None,
) -> Path:
    """Write the run-level ``run.rrd`` on a ``generation`` timeline.

    Args:
        path: The ``.rrd`` file to write, whole under a temporary name and renamed; an
            existing one is replaced.
        generations_df: One row per generation (a DataFrame or a dict of columns) with
            ``generation`` and any of the `RUN_SERIES` columns (``best_fitness``,
            ``mean_fitness``, ``median_fitness``, ``diversity``, ``distinct_morphologies``),
            each a scalar series.
        best_bodies: The best body of each generation, as a mapping generation -> body or as
            rows with a ``generation`` key; a body has ``body_id``, ``fitness`` and ``graph``
            (node-link JSON): logged at ``/best/graph`` (its morphology) and ``/best/body``
            (text).
        archives: A MAP-Elites run's archive per generation (`archive_cells`: a grid of
            fitness per cell, NaN: empty, or a CVT's cells), logged at ``/archive``
            (`archive_image`: a tensor, or points), so the viewer plays the archive over the
            generations; None: no archive.
        lineage: The lineage so far after each generation (`Lineage.archetypes`: its graph
            nodes and edges), logged whole at ``/lineage`` per generation; None: none.
        run_id: The recording's id and name; ``""``: the name of ``path``'s folder.
        properties: Plain values stored as recording properties; None: none.
        fsync: Whether to also fsync the file (it is written whole and renamed either way).
        chunk_cache: Where a writer that calls this once per generation (the recorder) keeps
            each generation's best graph, archive and lineage chunks, which never change once
            made: only the new generation's are made again. None: all are made.

    Returns:
        ``path``, as a `Path`.
    """
    path = Path(path)
    cache = {} if chunk_cache is None else chunk_cache
    generation = np.asarray(generations_df["generation"], dtype=np.int64)
    columns = set(getattr(generations_df, "columns", generations_df))
    if isinstance(best_bodies, Mapping):
        bests = sorted((int(g), b) for g, b in best_bodies.items())
    else:
        bests = sorted(((int(b["generation"]), b) for b in best_bodies), key=lambda gb: gb[0])
    name = run_id or path.parent.name or "run"
    rr = rerun_module()
    chunks = _property_chunks(dict(properties or {}), name)

    def kept(entity: str, gen: int, make: Callable[[], Sequence[AsComponents]]) -> None:
        """The generation's chunk at ``entity``, from the cache or made (None: nothing)."""
        if (entity, gen) not in cache:
            cache[entity, gen] = _at_generation(entity, gen, make())
        chunk = cache[entity, gen]
        if chunk is not None:
            chunks.append(chunk)

    index = [rr.TimeColumn("generation", sequence=generation)]
    for column, entity in RUN_SERIES.items():
        if column in columns and len(generation):
            values = np.asarray(generations_df[column], dtype=np.float64)
            chunks.append(static_chunk(entity, rr.SeriesLines(names=[column.replace("_", " ")])))
            chunks.append(
                rr.chunk.Chunk.from_columns(entity, index, rr.Scalars.columns(scalars=values))
            )
    if len(generation):
        chunks += run_summary_chunks(generations_df)
    if bests:
        gens = [rr.TimeColumn("generation", sequence=[gen for gen, _ in bests])]
        texts = [
            f"{body.get('body_id', '')}: {float(body.get('fitness', math.nan)):.6g}"
            for _, body in bests
        ]
        chunks.append(
            rr.chunk.Chunk.from_columns("/best/body", gens, rr.TextDocument.columns(text=texts))
        )
        for gen, body in bests:  # one row each: graphs differ in size
            graph = body.get("graph")
            kept("/best/graph", gen, lambda graph=graph: graph_archetypes(graph) if graph else [])
    for gen, grid in sorted((archives or {}).items()):
        kept("/archive", int(gen), lambda grid=grid: [archive_image(grid)])
    for gen, graph in sorted((lineage or {}).items()):  # one row each: the graph grows
        kept(LINEAGE_ENTITY, int(gen), lambda graph=graph: graph)
    return _write_chunks(path, name, chunks, fsync=fsync)


def _at_generation(
    entity: str, generation: int, archetypes: Sequence[AsComponents]
) -> Chunk | None:
    """One row of ``archetypes`` at ``entity`` on the ``generation`` timeline; None: none."""
    if not archetypes:
        return None
    at = [rerun_module().TimeColumn("generation", sequence=[int(generation)])]
    return rerun_module().chunk.Chunk.from_columns(entity, at, _one_row(*archetypes))


def run_summary_chunks(generations_df: Generations) -> list[Chunk]:
    """The run's fitness and diversity per generation as static bar charts under ``/run``.

    A time series view plots only the active timeline, so the run's curves (on
    ``generation``) cannot sit beside an evaluation's joints (on ``sim_time``); static bar
    charts over the generation numbers do, whatever the timeline.
    """
    rr = rerun_module()
    columns = set(getattr(generations_df, "columns", generations_df))
    generation = np.asarray(generations_df["generation"], dtype=np.float64)
    # A bar starts at its abscissa: half a generation earlier centres it on its number.
    left = generation - 0.5
    chunks = []
    for column, (entity, _name, colour) in SUMMARY_SERIES.items():
        if column not in columns or not len(generation):
            continue
        values = np.asarray(generations_df[column], dtype=np.float64)
        chart = rr.BarChart(values, abscissa=left, color=colour)
        chunks.append(static_chunk(entity, chart))
    return chunks


def archive_chunks(
    grid: np.ndarray | CvtCells, dimensions: Sequence[str] | None = None
) -> list[Chunk]:
    """A MAP-Elites archive (`archive_cells`: fitness per cell, NaN where empty, or a CVT's
    cells) static at `ARCHIVE_ENTITY` (`archive_shown`: a tensor, its dimensions named by
    ``dimensions``, e.g. "num_limbs (0 to 8)", or points), for a view beside an evaluation.
    Nothing for an archive without elites."""
    shown = archive_shown(grid, dimensions)
    return [] if shown is None else [static_chunk(ARCHIVE_ENTITY, shown)]


def write_view_recording(
    path: str | os.PathLike[str],
    evaluation: str | os.PathLike[str],
    generations_df: Generations,
    *,
    archive: np.ndarray | CvtCells | None = None,
    archive_dimensions: Sequence[str] | None = None,
    graph_json: GraphJson | None = None,
) -> Path:
    """One recording to open: the evaluation recording ``evaluation`` (its robot, joints and
    graph on ``sim_time``) with the run's fitness and diversity per generation beside
    (`run_summary_chunks`) and, for a MAP-Elites run, its ``archive`` (`archive_chunks`),
    under the evaluation's recording id; returns its path. ``graph_json``: the body's
    morphology, drawn again as this version draws it (a recording made by an older one keeps
    its own drawing otherwise)."""
    rr = rerun_module()

    reader = rr.chunk.RrdReader(Path(evaluation))
    (store,) = reader.recordings()[:1] or [None]
    recording_id = store.recording_id if store is not None else Path(evaluation).stem
    graph = _graph_chunk(graph_json) if graph_json else None
    replaced = ("/run/", *(["/graph"] if graph is not None else []))
    mine = [
        chunk
        for chunk in reader.stream().to_chunks()
        if not any(chunk.entity_path.startswith(prefix) for prefix in replaced)
    ]
    chunks = [*mine, *([graph] if graph is not None else []), *run_summary_chunks(generations_df)]
    if archive is not None:
        chunks += archive_chunks(archive, archive_dimensions)
    return _write_chunks(Path(path), recording_id, chunks, fsync=False)
