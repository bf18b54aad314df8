"""A generation's evaluations in one Rerun recording: ``recordings/gen-NNNNNN/evaluations.rrd``.

Every evaluation of the generation is one step of an ``evaluation`` timeline (0, 1, ... in eval
id order, so the file does not depend on the order results came back): scrubbing it shows one
evaluation after another. Per step:

* ``/evaluation``: a text card: the evaluation row's fields marked ``card`` in its declaration
  (`_row_types.EvaluationRow`: ids, parents, plugins, fitness, status, error, seed), whether it
  improved its body's best, its genotype's hash, parameter count and morphology descriptors;
* ``/fitness``: the evaluation's fitness (a plot over the generation's evaluations);
* ``/world/trajectory``: the core's path, a `LineStrips3D`;
* ``/joints/target`` and ``/joints/angle``: one `LineStrips2D` per joint, x = simulated
  seconds, y = rad, labelled with the joint's name (the same joint the same colour in both);
* ``/graph``: the morphology, `GraphNodes` coloured by module type, drawn as a tree from the
  core down, and directed `GraphEdges`.

Why one recording and not one per evaluation: a Rerun 0.41 recording costs at least 10-17 kB
whatever it holds (its footer's manifest and every chunk's Arrow schema, about 2 kB a chunk),
more than the data of an 8 s evaluation at 10 Hz. Here each entity is one chunk for the whole
generation, so an evaluation costs its data, ~3-5 kB. 3D replays of the bodies are in the
elites' own recordings (`write_evaluation_recording`) or made on demand (``ariel view RUN
EVAL_ID``). Application id ``ariel-generation``, with its own layout (`write_generation_blueprint`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.recording.rerun._blueprint import save_layout
from ariel.recording.rerun._chunks import _property_chunks, rerun_module, static_chunk
from ariel.recording.rerun._graph import _graph_parts, graph_colour, tree_positions
from ariel.recording.rerun._joint_names import joint_labels, module_labels
from ariel.recording.rerun._rerun import _write_chunks
from ariel.recording.rerun._scene import module_colours

if TYPE_CHECKING:
    from rerun import ComponentColumn
    from rerun.blueprint import Blueprint

    from ariel.evaluation import EvaluationResult

__all__ = [
    "GENERATION_APPLICATION_ID",
    "EvaluationTrace",
    "trace_of",
    "write_generation_blueprint",
    "write_generation_recording",
]

GENERATION_APPLICATION_ID = "ariel-generation"
#: Joint colours, by the joint's index in its body (a target and its angle share one).
_PALETTE = (
    (31, 119, 180, 255),
    (255, 127, 14, 255),
    (44, 160, 44, 255),
    (214, 39, 40, 255),
    (148, 103, 189, 255),
    (140, 86, 75, 255),
    (227, 119, 194, 255),
    (127, 127, 127, 255),
    (188, 189, 34, 255),
    (23, 190, 207, 255),
)


@dataclass
class EvaluationTrace:
    """What the generation recording keeps of one evaluation (small: no body poses)."""

    card: dict[str, Any]  # the recording properties, shown as text: eval_id, fitness, ...
    time: np.ndarray  # (T,) seconds
    core: np.ndarray  # (T, 3) float32
    targets: np.ndarray  # (T, J)
    angles: np.ndarray  # (T, J)
    joint_names: tuple[str, ...]  # for people (`joint_labels`)
    graph_json: str | None

    @property
    def eval_id(self) -> str:
        return str(self.card["eval_id"])

    @property
    def fitness(self) -> float:
        return float(self.card["fitness"])


def trace_of(
    properties: Mapping[str, object], result: EvaluationResult, graph_json: str | None
) -> EvaluationTrace:
    """An evaluation's trace from its recording properties (see `RerunRecorder.evaluation`)
    and its `EvaluationResult`."""
    targets = np.asarray(result.joint_target, dtype=np.float32)
    joints = targets.shape[1] if targets.ndim == 2 else 0
    names = tuple(getattr(result, "joint_names", None) or ())[:joints]
    labels = _joint_labels(names, graph_json or None, joints)
    return EvaluationTrace(
        card=dict(properties),
        time=np.asarray(result.time, dtype=np.float32),
        core=np.asarray(result.core_pos, dtype=np.float32).reshape(-1, 3),
        targets=targets.reshape(len(result.time), joints),
        angles=np.asarray(result.joint_angle, dtype=np.float32).reshape(len(result.time), joints),
        joint_names=labels,
        graph_json=graph_json or None,
    )


def _card(trace: EvaluationTrace) -> str:
    """The evaluation's text card, markdown."""
    lines = [f"## {trace.eval_id}", "", "| | |", "|---|---|"]
    for key, value in trace.card.items():
        if key == "eval_id" or value is None or value == "":
            continue
        if key == "morphology" and isinstance(value, str):
            value = ", ".join(f"{k} {v:.3g}" for k, v in json.loads(value).items())
        elif isinstance(value, float):
            value = f"{value:.6g}" if math.isfinite(value) else str(value)
        elif isinstance(value, list | tuple):
            value = ", ".join(str(v) for v in value) or "-"
        lines.append(f"| {key} | {value} |")
    return "\n".join(lines)


def _joint_columns(traces: Sequence[EvaluationTrace], leaf: str) -> list[ComponentColumn]:
    """``/joints/<leaf>`` over the evaluations: each row one strip (t, rad) per joint."""
    rr = rerun_module()
    strips, labels, colours, lengths = [], [], [], []
    for trace in traces:
        values = trace.targets if leaf == "target" else trace.angles
        for j in range(values.shape[1]):
            strips.append(np.column_stack([trace.time, values[:, j]]))
            labels.append(trace.joint_names[j])
            colours.append(_PALETTE[j % len(_PALETTE)])
        lengths.append(values.shape[1])
    return rr.LineStrips2D.columns(strips=strips, labels=labels, colors=colours).partition(lengths)


@lru_cache(maxsize=64)
def _joint_labels(names: tuple[str, ...], graph_json: str | None, joints: int) -> tuple[str, ...]:
    """`joint_labels` of a body's joints (cached: a body's evaluations share its graph, and
    reading the graph is most of the cost)."""
    labels = joint_labels(names, graph_json)
    return (*labels, *(f"joint{j}" for j in range(len(names), joints)))


@lru_cache(maxsize=64)
def _drawing(
    graph_json: str | None,
) -> tuple[
    list[str],
    list[str],
    list[tuple[int, int, int, int]],
    list[tuple[str, str]],
    list[tuple[float, float]],
]:
    """A morphology's node ids, labels, colours, edges and positions (a tree drawn top-down,
    `tree_positions`; cached as `_joint_labels`)."""
    if not graph_json:
        return [], [], [], [], []
    ids, types, edges = _graph_parts(graph_json)
    colours = [graph_colour(t) for t in types]
    labels = module_labels(ids, types, graph_json)
    return ids, labels, colours, edges, tree_positions(ids, edges)


def _graph_columns(traces: Sequence[EvaluationTrace]) -> list[ComponentColumn]:
    """``/graph`` over the evaluations: each row one morphology (empty when not known)."""
    rr = rerun_module()
    ids, labels, colours, edges, positions = [], [], [], [], []
    node_counts, edge_counts = [], []
    for trace in traces:
        node_ids, node_labels, node_colours, links, places = _drawing(trace.graph_json)
        ids += node_ids
        labels += node_labels
        colours += node_colours
        edges += links
        positions += places
        node_counts.append(len(node_ids))
        edge_counts.append(len(links))
    nodes = rr.GraphNodes.columns(
        node_ids=ids,
        labels=labels,
        colors=colours,
        positions=np.asarray(positions, dtype=np.float32).reshape(-1, 2),
    )
    return [
        *nodes.partition(node_counts),
        *rr.GraphEdges.columns(edges=edges).partition(edge_counts),
    ]


def write_generation_recording(
    path: str | os.PathLike[str],
    traces: Sequence[EvaluationTrace],
    *,
    run_id: str,
    generation: int,
    properties: Mapping[str, object] | None = None,
) -> Path:
    """Write a generation's evaluations as one recording (see the module docstring), whole
    under a temporary name and renamed; recording id ``<run_id>/gen-NNNNNN``.

    Args:
        path: The ``.rrd`` file to write (usually ``recordings/gen-NNNNNN/evaluations.rrd``
            of the run folder); an existing one is replaced.
        traces: The generation's evaluations (`trace_of`), in any order: they are stepped
            through in eval id order.
        run_id: The run's id (in the recording id and its properties).
        generation: The generation's number.
        properties: More recording properties (name -> value) beside ``run_id``,
            ``generation`` and ``evaluations``; None: none.

    Returns:
        ``path``, as a `Path`.
    """
    rr = rerun_module()
    traces = sorted(traces, key=lambda trace: trace.eval_id)
    name = f"{run_id}/gen-{int(generation):06d}"
    card = {"run_id": run_id, "generation": int(generation), "evaluations": len(traces)}
    chunks = _property_chunks({**card, **dict(properties or {})}, name)
    chunks += [
        static_chunk("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP),
        static_chunk(
            "/world/trajectory",
            rr.LineStrips3D.from_fields(colors=[module_colours()["CORE"]], radii=[0.005]),
        ),
        static_chunk("/fitness", rr.SeriesLines(names=["fitness"])),
        # Only the media type is static: a static text would hide every step's card.
        static_chunk("/evaluation", rr.TextDocument.from_fields(media_type=rr.MediaType.MARKDOWN)),
    ]
    if traces:
        index = [rr.TimeColumn("evaluation", sequence=np.arange(len(traces)))]
        ones = [1] * len(traces)
        text = rr.TextDocument.columns(text=[_card(t) for t in traces]).partition(ones)
        chunks.append(rr.chunk.Chunk.from_columns("/evaluation", index, text))
        fitness = rr.Scalars.columns(scalars=[t.fitness for t in traces])
        chunks.append(rr.chunk.Chunk.from_columns("/fitness", index, fitness))
        strips = rr.LineStrips3D.columns(strips=[t.core for t in traces]).partition(ones)
        chunks.append(rr.chunk.Chunk.from_columns("/world/trajectory", index, strips))
        for leaf in ("target", "angle"):
            chunks.append(
                rr.chunk.Chunk.from_columns(f"/joints/{leaf}", index, _joint_columns(traces, leaf))
            )
        chunks.append(rr.chunk.Chunk.from_columns("/graph", index, _graph_columns(traces)))
    return _write_chunks(
        Path(path), name, chunks, fsync=False, application_id=GENERATION_APPLICATION_ID
    )


def generation_blueprint(*, panels: bool = True) -> Blueprint:
    """The layout of a generation recording: the evaluation's card, path and morphology above,
    its joints and the generation's fitness below; the time panel on ``evaluation``.
    ``panels=False``: the side panels collapsed (a screenshot shows the views)."""
    rrb = rerun_module().blueprint
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(
                rrb.TextDocumentView(name="evaluation", origin="/evaluation"),
                rrb.Spatial3DView(name="core path", origin="/world"),
                rrb.GraphView(name="morphology", origin="/graph"),
                column_shares=[1, 2, 1],
            ),
            rrb.Horizontal(
                rrb.Spatial2DView(name="joint targets (rad over s)", origin="/joints/target"),
                rrb.Spatial2DView(name="joint angles (rad over s)", origin="/joints/angle"),
                rrb.TimeSeriesView(name="fitness per evaluation", origin="/fitness"),
            ),
            row_shares=[3, 2],
        ),
        # Its own state, else the time panel stays open whatever collapse_panels says.
        rrb.TimePanel(timeline="evaluation", **({} if panels else {"state": "collapsed"})),
        collapse_panels=not panels,
    )


def write_generation_blueprint(path: str | os.PathLike[str], *, panels: bool = True) -> Path:
    """Write `generation_blueprint` (application id ``ariel-generation``) to ``path``."""
    return save_layout(path, generation_blueprint, GENERATION_APPLICATION_ID, panels=panels)
