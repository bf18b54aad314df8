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
"""

from __future__ import annotations

import json
import math
import os
import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from ariel.recording.rerun._archive import (
    ARCHIVE_ENTITY,
    archive_image,
    archive_shown,
    archive_view,
)
from ariel.recording.rerun._joint_names import joint_labels, module_labels
from ariel.recording.rerun._lineage import LINEAGE_ENTITY, lineage_view
from ariel.recording.store import atomic_write, json_data, require_free_space

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

APPLICATION_ID = "ariel"
ROBOT_PREFIX = "robot1_"
#: Metres of terrain drawn around the robot's path (a heightfield mesh of a whole arena is up
#: to 150 kB per recording; the part the robot walked on is what one looks at).
TERRAIN_MARGIN = 1.0
#: Largest number of heightfield rows or columns drawn (subsampled beyond).
TERRAIN_MAX_SIDE = 32
#: Half-extent drawn for an infinite MuJoCo plane (size 0).
INFINITE_PLANE_HALF_EXTENT = 20.0
_OTHER_COLOUR = (128, 128, 128, 255)
_BLUEPRINT_ROOM = 1 << 20  # bytes free before a blueprint (~70 kB) is written


def rerun_module() -> Any:
    import rerun

    return rerun


def _rgba255(colour: Sequence[float]) -> tuple[int, int, int, int]:
    r, g, b, a = (round(255 * float(c)) for c in colour[:4])
    return r, g, b, a


@cache
def module_colours() -> dict[str, tuple[int, int, int, int]]:
    """Module type -> RGBA (0-255): the colours the robogen-lite modules give their geoms."""
    from ariel.body_phenotypes.robogen_lite.modules.brick import BRICK_COLOUR
    from ariel.body_phenotypes.robogen_lite.modules.core import CORE_COLOUR
    from ariel.body_phenotypes.robogen_lite.modules.hinge import STATOR_COLOUR

    return {
        "CORE": _rgba255(CORE_COLOUR),
        "BRICK": _rgba255(BRICK_COLOUR),
        "HINGE": _rgba255(STATOR_COLOUR),
    }


def module_type_of(geom_name: str) -> str:
    """The module type (CORE, BRICK, HINGE, else OTHER) of a robot geom, from its name.

    The constructor names geoms after their module: ``...core``, ``...brick``, and a hinge's
    ``...stator`` and ``...rotor``.
    """
    name = geom_name.lower()
    if name.endswith("core"):
        return "CORE"
    if name.endswith("brick"):
        return "BRICK"
    if name.endswith(("stator", "rotor", "hinge")):
        return "HINGE"
    return "OTHER"


def _short(name: str) -> str:
    return name[len(ROBOT_PREFIX) :] if name.startswith(ROBOT_PREFIX) else name


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions (w, x, y, z) -> Rerun's (x, y, z, w), float32."""
    return np.ascontiguousarray(np.asarray(wxyz, dtype=np.float32)[..., [1, 2, 3, 0]])


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of (w, x, y, z) quaternions, broadcast."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)`` (w, x, y, z)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


# --------------------------------------------------------------------------------------------
# What every recording of one compiled model shares (built once per model, cached)
# --------------------------------------------------------------------------------------------


@dataclass
class _Heightfield:
    path: str
    pos: np.ndarray  # geom world position
    quat: np.ndarray  # geom world quaternion (w, x, y, z)
    heights: np.ndarray  # (nrow, ncol), metres above the geom frame
    radius: tuple[float, float]
    colour: tuple[int, int, int, int]


@dataclass
class _Scene:
    """Static chunks and geometry shared by every recording of one compiled model."""

    model: Any  # kept alive so the cache key (its id) stays unique
    world: list[Any]  # static chunks: /world (view coordinates, boxes), other world geoms
    heightfields: list[_Heightfield]
    robot_sizes: Any  # static chunk: the robot's boxes (sizes, colours, labels)
    robot_still: Any  # static chunk: the same boxes in the start pose
    geom_body: np.ndarray  # (G,) column in body_names of each robot box
    geom_pos: np.ndarray  # (G, 3) in its body's frame
    geom_quat: np.ndarray  # (G, 4) in its body's frame, (w, x, y, z)
    joint_names: dict[tuple[str, ...], list[Any]] = field(default_factory=dict)


_SCENES: OrderedDict[tuple[int, tuple[str, ...]], _Scene] = OrderedDict()
_SCENE_CACHE_SIZE = 32  # more than the bodies a generation usually learns side by side
_CACHE_LOCK = threading.Lock()


def _scene(model: Any, body_names: Sequence[str]) -> _Scene:
    key = (id(model), tuple(body_names))
    with _CACHE_LOCK:
        scene = _SCENES.get(key)
        if scene is not None and scene.model is model:
            _SCENES.move_to_end(key)
            return scene
    scene = _build_scene(model, body_names)
    with _CACHE_LOCK:
        _SCENES[key] = scene
        while len(_SCENES) > _SCENE_CACHE_SIZE:
            _SCENES.popitem(last=False)
    return scene


def _build_scene(model: Any, body_names: Sequence[str]) -> _Scene:
    import mujoco

    rr = rerun_module()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    geom_xquat = np.empty((model.ngeom, 4))
    for g in range(model.ngeom):
        mujoco.mju_mat2Quat(geom_xquat[g], data.geom_xmat[g])
    geom_names = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(model.ngeom)
    ]
    body_index = {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "": b for b in range(model.nbody)
    }
    robot_bodies = []
    for name in body_names:
        if name not in body_index:
            raise ValueError(f"body {name!r} is not in the model")
        robot_bodies.append(body_index[name])
    column = {b: i for i, b in enumerate(robot_bodies)}

    # The robot: box geoms of the given bodies.
    box = mujoco.mjtGeom.mjGEOM_BOX
    geoms = [
        g
        for g in range(model.ngeom)
        if int(model.geom_bodyid[g]) in column and int(model.geom_type[g]) == box
    ]
    colours = [_rgba255(model.geom_rgba[g]) for g in geoms]
    labels = [_short(geom_names[g]) or f"geom{g}" for g in geoms]
    boxes = rr.Boxes3D(
        half_sizes=np.asarray(model.geom_size[geoms], dtype=np.float32).reshape(-1, 3),
        colors=colours,
        labels=labels,
        show_labels=False,
        fill_mode="solid",
    )

    # The world: everything else. Boxes (and planes, as thin boxes) form one batch at /world,
    # with the view coordinates: one chunk for a flat floor or a whole arena.
    world_boxes: dict[str, list[Any]] = {
        k: [] for k in ("half", "center", "quat", "colour", "label")
    }
    world: list[tuple[str, list[Any]]] = []
    heightfields: list[_Heightfield] = []
    kinds = mujoco.mjtGeom
    robot_geoms = set(np.flatnonzero(np.isin(model.geom_bodyid, robot_bodies)).tolist())
    for g in range(model.ngeom):
        if g in robot_geoms or geom_names[g].startswith(ROBOT_PREFIX):
            continue
        kind = int(model.geom_type[g])
        size = np.asarray(model.geom_size[g], dtype=np.float64)
        colour = _rgba255(model.geom_rgba[g])
        name = geom_names[g] or f"geom{g}"
        pos, quat = data.geom_xpos[g].copy(), geom_xquat[g].copy()
        path = f"/world/{rr.escape_entity_path_part(name)}"
        if kind in (kinds.mjGEOM_PLANE, kinds.mjGEOM_BOX):
            if kind == kinds.mjGEOM_PLANE:  # a thin box whose top is the plane
                half = [float(s) if s > 0 else INFINITE_PLANE_HALF_EXTENT for s in size[:2]]
                size = np.array([half[0], half[1], 0.001])
                pos = pos - _rotate(quat, np.array([0.0, 0.0, 0.001]))
            world_boxes["half"].append(size)
            world_boxes["center"].append(pos)
            world_boxes["quat"].append(quat)
            world_boxes["colour"].append(colour)
            world_boxes["label"].append(name)
        elif kind == kinds.mjGEOM_HFIELD:
            field = int(model.geom_dataid[g])
            nrow, ncol = int(model.hfield_nrow[field]), int(model.hfield_ncol[field])
            rx, ry, top, _base = (float(v) for v in model.hfield_size[field])
            start = int(model.hfield_adr[field])
            heights = np.asarray(model.hfield_data[start : start + nrow * ncol], dtype=np.float64)
            heightfields.append(
                _Heightfield(path, pos, quat, heights.reshape(nrow, ncol) * top, (rx, ry), colour)
            )
        elif kind in (kinds.mjGEOM_SPHERE, kinds.mjGEOM_ELLIPSOID):
            half = [size[0]] * 3 if kind == kinds.mjGEOM_SPHERE else size
            shape = rr.Ellipsoids3D(
                half_sizes=[half], centers=[pos], quaternions=[_xyzw(quat)], colors=[colour]
            )
            world.append((path, [shape]))
        elif kind == kinds.mjGEOM_CAPSULE:  # Rerun's capsule starts at its translation
            base = pos - _rotate(quat, np.array([0.0, 0.0, size[1]]))
            shape = rr.Capsules3D(
                lengths=[2 * size[1]],
                radii=[size[0]],
                translations=[base],
                quaternions=[_xyzw(quat)],
                colors=[colour],
            )
            world.append((path, [shape]))
        elif kind == kinds.mjGEOM_CYLINDER:
            shape = rr.Cylinders3D(
                lengths=[2 * size[1]],
                radii=[size[0]],
                centers=[pos],
                quaternions=[_xyzw(quat)],
                colors=[colour],
            )
            world.append((path, [shape]))
        # meshes and other shapes of a world: not drawn
    ground: list[Any] = [rr.ViewCoordinates.RIGHT_HAND_Z_UP]
    if world_boxes["half"]:
        ground.append(
            rr.Boxes3D(
                half_sizes=np.array(world_boxes["half"], dtype=np.float32),
                centers=np.array(world_boxes["center"], dtype=np.float32),
                quaternions=_xyzw(np.array(world_boxes["quat"])),
                colors=world_boxes["colour"],
                labels=world_boxes["label"],
                show_labels=False,
                fill_mode="solid",
            )
        )
    world.insert(0, ("/world", ground))
    world_chunks = [static_chunk(path, *archetypes) for path, archetypes in world]

    body_xpos = data.xpos[robot_bodies] if robot_bodies else np.zeros((0, 3))
    body_xquat = data.xquat[robot_bodies] if robot_bodies else np.zeros((0, 4))
    geom_body = np.array([column[int(model.geom_bodyid[g])] for g in geoms], dtype=np.int64)
    geom_pos = np.asarray(model.geom_pos[geoms], dtype=np.float64).reshape(-1, 3)
    geom_quat = np.asarray(model.geom_quat[geoms], dtype=np.float64).reshape(-1, 4)
    centers, quats = _box_poses(body_xpos[None], body_xquat[None], geom_body, geom_pos, geom_quat)
    start = rr.Boxes3D.from_fields(centers=centers[0], quaternions=quats[0])
    return _Scene(
        model=model,
        world=world_chunks,
        heightfields=heightfields,
        robot_sizes=static_chunk("/world/robot", boxes),
        robot_still=static_chunk("/world/robot", boxes, start),
        geom_body=geom_body,
        geom_pos=geom_pos,
        geom_quat=geom_quat,
    )


def _box_poses(
    body_pos: np.ndarray,
    body_quat: np.ndarray,
    geom_body: np.ndarray,
    geom_pos: np.ndarray,
    geom_quat: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """World centers ``(T, G, 3)`` and quaternions ``(T, G, 4)`` (x, y, z, w) of the boxes."""
    bp = np.asarray(body_pos, dtype=np.float64)[:, geom_body]
    bq = np.asarray(body_quat, dtype=np.float64)[:, geom_body]
    centers = bp + _rotate(bq, np.broadcast_to(geom_pos, bp.shape))
    quats = _quat_mul(bq, np.broadcast_to(geom_quat, bq.shape))
    return centers.astype(np.float32), _xyzw(quats)


def _terrain(field: _Heightfield, path_xy: np.ndarray) -> Any:
    """A world-frame `Mesh3D` of the heightfield around ``path_xy`` (the core's x, y)."""
    rr = rerun_module()
    nrow, ncol = field.heights.shape
    rx, ry = field.radius
    xs = np.linspace(-rx, rx, ncol)
    ys = np.linspace(-ry, ry, nrow)
    cols, rows = np.arange(ncol), np.arange(nrow)
    inverse = field.quat * np.array([1.0, -1.0, -1.0, -1.0])
    if path_xy.size:
        # The path in the field's frame (exact for fields rotated about z, close enough for
        # tilted ones given the margin).
        path = np.column_stack([path_xy, np.zeros(len(path_xy))]) - field.pos
        local = _rotate(inverse, path)
        lo, hi = local[:, :2].min(0) - TERRAIN_MARGIN, local[:, :2].max(0) + TERRAIN_MARGIN
        cols = cols[(xs >= lo[0]) & (xs <= hi[0])]
        rows = rows[(ys >= lo[1]) & (ys <= hi[1])]
    if len(rows) < 2 or len(cols) < 2:
        rows, cols = np.arange(nrow), np.arange(ncol)
    if len(rows) > TERRAIN_MAX_SIDE:
        rows = rows[np.linspace(0, len(rows) - 1, TERRAIN_MAX_SIDE).round().astype(int)]
    if len(cols) > TERRAIN_MAX_SIDE:
        cols = cols[np.linspace(0, len(cols) - 1, TERRAIN_MAX_SIDE).round().astype(int)]
    xx, yy = np.meshgrid(xs[cols], ys[rows])
    zz = field.heights[np.ix_(rows, cols)]
    local = np.stack([xx, yy, zz], axis=-1).reshape(-1, 3)
    vertices = (field.pos + _rotate(field.quat, local)).astype(np.float32)
    r, c = len(rows), len(cols)
    index = np.arange(r * c, dtype=np.uint32).reshape(r, c)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    d, e = index[1:, :-1].ravel(), index[1:, 1:].ravel()
    triangles = np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, d], 1)])
    return rr.Mesh3D(
        vertex_positions=vertices, triangle_indices=triangles, albedo_factor=field.colour
    )


# --------------------------------------------------------------------------------------------
# Morphology graph and properties
# --------------------------------------------------------------------------------------------


def _graph_parts(graph_json: str | Mapping[str, Any]) -> tuple[list[str], list[str], list[Any]]:
    """Node ids, their module types and (parent, child) edges of a node-link graph."""
    data = json_data(graph_json) if isinstance(graph_json, str) else graph_json  # guarded
    nodes = data.get("nodes", [])
    ids = [str(node["id"]) for node in nodes]
    types = [str(node.get("type", "?")).upper() for node in nodes]
    links = data.get("edges", data.get("links", []))
    edges = [(str(e["source"]), str(e["target"])) for e in links]
    return ids, types, edges


#: Scene units between neighbouring leaves of a drawn morphology (across) and between a module
#: and its children (down): room for a label such as "right 1" beside the next.
GRAPH_STEP = (110.0, 70.0)


def tree_positions(ids: Sequence[str], edges: Sequence[Any]) -> list[tuple[float, float]]:
    """Where to draw each node of a morphology (``ids``, parent -> child ``edges``): a tree
    drawn top-down, the root (the core) on top at x = 0, each module one row below its parent,
    the leaves side by side in depth-first order and a parent centred over its children, so
    no two labels overlap (the viewer's force layout piles them up). A graph that is not one
    tree (never a robot's) is drawn as rows of four."""
    children: dict[str, list[str]] = {str(i): [] for i in ids}
    parents: set[str] = set()
    tree = True
    for source, target in edges:
        source, target = str(source), str(target)
        if source not in children or target not in children or target in parents:
            tree = False
            break
        children[source].append(target)
        parents.add(target)
    roots = [i for i in children if i not in parents]
    order: list[str] = []
    depth: dict[str, int] = {}
    if tree and len(roots) == 1:
        stack = [(roots[0], 0)]
        while stack:  # depth-first, children in their order
            node, d = stack.pop()
            if node in depth:
                break
            depth[node] = d
            order.append(node)
            stack.extend((child, d + 1) for child in reversed(children[node]))
    if len(order) != len(children):
        step_x, step_y = GRAPH_STEP
        return [(step_x * (k % 4), step_y * (k // 4)) for k in range(len(ids))]
    x: dict[str, float] = {}
    leaves = 0
    for node in order:
        if not children[node]:
            x[node] = float(leaves)
            leaves += 1
    for node in reversed(order):  # children before their parent
        if children[node]:
            x[node] = float(np.mean([x[child] for child in children[node]]))
    root_x = x[roots[0]]
    step_x, step_y = GRAPH_STEP
    return [(step_x * (x[str(i)] - root_x), step_y * depth[str(i)]) for i in ids]


def graph_colour(module_type: str) -> tuple[int, int, int, int]:
    """A module type's colour for a graph label: its module colour, darkened where it is too
    light to read on the viewer's white graph background (the core's yellow)."""
    r, g, b, a = module_colours().get(module_type, _OTHER_COLOUR)
    brightness = (0.299 * r + 0.587 * g + 0.114 * b) / 255
    scale = min(1.0, 0.5 / brightness) if brightness else 1.0
    return round(r * scale), round(g * scale), round(b * scale), a


def graph_archetypes(graph_json: str | Mapping[str, Any]) -> list[Any]:
    rr = rerun_module()
    ids, types, edges = _graph_parts(graph_json)
    if not ids:
        return []
    return [
        rr.GraphNodes(
            ids,
            labels=module_labels(ids, types, graph_json),
            colors=[graph_colour(t) for t in types],
            positions=tree_positions(ids, edges),
            show_labels=True,
        ),
        rr.GraphEdges(edges, graph_type="directed"),
    ]


_GRAPHS: OrderedDict[str, Any] = OrderedDict()  # graph JSON -> its static /graph chunk


def _graph_chunk(graph_json: str | Mapping[str, Any]) -> Any:
    """The static ``/graph`` chunk of a morphology (cached: a body's evaluations share it)."""
    key = graph_json if isinstance(graph_json, str) else json.dumps(graph_json, sort_keys=True)
    with _CACHE_LOCK:
        if key in _GRAPHS:
            _GRAPHS.move_to_end(key)
            return _GRAPHS[key]
    archetypes = graph_archetypes(graph_json)
    chunk = static_chunk("/graph", *archetypes) if archetypes else None
    with _CACHE_LOCK:
        _GRAPHS[key] = chunk
        while len(_GRAPHS) > 64:
            _GRAPHS.popitem(last=False)
    return chunk


def _property_value(value: Any) -> Any:
    """A value `AnyValues` holds: a number, bool or string; lists of them; else JSON text."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        return None
    if isinstance(value, bool | int | float | str):
        return [value]
    if isinstance(value, Sequence) and value and all(isinstance(v, str) for v in value):
        return list(value)
    if (
        isinstance(value, Sequence)
        and value
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        return [float(v) for v in value]
    return [json.dumps(value, default=str)]


def _property_chunks(properties: Mapping[str, Any], name: str) -> list[Any]:
    """The recording's name and the ``ariel`` recording property (``/__properties``)."""
    from rerun.archetypes import RecordingInfo
    from rerun.chunk import Chunk

    chunks = [Chunk.from_columns("/__properties", [], RecordingInfo.columns(name=[name]))]
    values = {str(k): _property_value(v) for k, v in properties.items()}
    values = {k: v for k, v in values.items() if v is not None}
    if values:
        chunks.append(Chunk.from_property("ariel", rerun_module().AnyValues(**values)))
    return chunks


# --------------------------------------------------------------------------------------------
# Chunks and files
# --------------------------------------------------------------------------------------------


def _one_row(*archetypes: Any) -> list[Any]:
    """Component columns of one row holding every batch of ``archetypes``."""
    return [
        batch.partition([len(batch.as_arrow_array())])
        for archetype in archetypes
        for batch in archetype.as_component_batches()
    ]


def static_chunk(path: str, *archetypes: Any) -> Any:
    """One static chunk at ``path`` holding ``archetypes``."""
    from rerun.chunk import Chunk

    return Chunk.from_columns(path, [], _one_row(*archetypes))


def _write_chunks(
    path: Path,
    recording_id: str,
    chunks: Sequence[Any],
    *,
    fsync: bool,
    application_id: str = APPLICATION_ID,
) -> Path:
    """Write ``chunks`` as one recording whole to ``path``."""
    from rerun.chunk import LazyChunkStream

    def write(temporary: Path) -> None:
        LazyChunkStream.from_iter(chunks).write_rrd(
            temporary, application_id=application_id, recording_id=recording_id
        )

    atomic_write(path, write, fsync=fsync)
    return path


# --------------------------------------------------------------------------------------------
# One evaluation
# --------------------------------------------------------------------------------------------


def write_evaluation_recording(
    path: str | os.PathLike[str],
    *,
    model: Any,
    body_names: Sequence[str],
    result: Any,
    properties: Mapping[str, Any],
    graph_json: str | Mapping[str, Any] | None = None,
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
    from rerun.chunk import Chunk

    rr = rerun_module()
    path = Path(path)
    eval_id = str(properties.get("eval_id") or getattr(result, "eval_id", "") or path.stem)
    shared = _scene(model, body_names)
    chunks = [*_property_chunks(properties, eval_id), *shared.world]
    core = np.asarray(result.core_pos, dtype=np.float32).reshape(-1, 3)
    for terrain in shared.heightfields:
        chunks.append(static_chunk(terrain.path, _terrain(terrain, core[:, :2])))

    times = np.asarray(result.time, dtype=np.float64)
    sim_time = [rr.TimeColumn("sim_time", duration=times)]
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
        poses = rr.Boxes3D.columns(
            centers=centers.reshape(-1, 3), quaternions=quats.reshape(-1, 4)
        ).partition([boxes] * len(times))
        chunks += [shared.robot_sizes, Chunk.from_columns("/world/robot", sim_time, poses)]
    elif boxes:
        chunks.append(shared.robot_still)
    if len(core):
        strip = rr.LineStrips3D([core], colors=[module_colours()["CORE"]], radii=[0.005])
        chunks.append(static_chunk("/world/trajectory", strip))

    targets = np.asarray(result.joint_target, dtype=np.float64)
    angles = np.asarray(result.joint_angle, dtype=np.float64)
    joints = targets.shape[1] if targets.ndim == 2 and len(times) else 0
    if joints:
        names = tuple(getattr(result, "joint_names", None) or ())[:joints]
        if names not in shared.joint_names:
            labels = joint_labels(names, graph_json) + [
                f"joint{j}" for j in range(len(names), joints)
            ]
            shared.joint_names[names] = [
                static_chunk(f"/joints/{leaf}", rr.SeriesLines(names=labels))
                for leaf in ("target", "angle")
            ]
        chunks += shared.joint_names[names]
        for leaf, values in (("target", targets), ("angle", angles)):
            scalars = rr.Scalars.columns(scalars=values.ravel()).partition([joints] * len(times))
            chunks.append(Chunk.from_columns(f"/joints/{leaf}", sim_time, scalars))
    if graph_json:
        graph = _graph_chunk(graph_json)
        if graph is not None:
            chunks.append(graph)
    return _write_chunks(path, eval_id, chunks, fsync=fsync)


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
    generations_df: Any,
    best_bodies: Mapping[int, Mapping[str, Any]] | Sequence[Mapping[str, Any]],
    *,
    archives: Mapping[int, np.ndarray] | None = None,
    lineage: Mapping[int, Sequence[Any]] | None = None,
    run_id: str = "",
    properties: Mapping[str, Any] | None = None,
    fsync: bool = True,
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

    Returns:
        ``path``, as a `Path`.
    """
    path = Path(path)
    generation = np.asarray(generations_df["generation"], dtype=np.int64)
    columns = set(getattr(generations_df, "columns", generations_df))
    if isinstance(best_bodies, Mapping):
        bests = sorted((int(g), b) for g, b in best_bodies.items())
    else:
        bests = sorted(((int(b["generation"]), b) for b in best_bodies), key=lambda gb: gb[0])
    name = run_id or path.parent.name or "run"
    from rerun.chunk import Chunk

    rr = rerun_module()
    chunks = _property_chunks(dict(properties or {}), name)
    index = [rr.TimeColumn("generation", sequence=generation)]
    for column, entity in RUN_SERIES.items():
        if column in columns and len(generation):
            values = np.asarray(generations_df[column], dtype=np.float64)
            chunks.append(static_chunk(entity, rr.SeriesLines(names=[column.replace("_", " ")])))
            chunks.append(Chunk.from_columns(entity, index, rr.Scalars.columns(scalars=values)))
    if len(generation):
        chunks += run_summary_chunks(generations_df)
    if bests:
        gens = [rr.TimeColumn("generation", sequence=[gen for gen, _ in bests])]
        texts = [
            f"{body.get('body_id', '')}: {float(body.get('fitness', math.nan)):.6g}"
            for _, body in bests
        ]
        chunks.append(Chunk.from_columns("/best/body", gens, rr.TextDocument.columns(text=texts)))
        for gen, body in bests:  # one row each: graphs differ in size
            graph = graph_archetypes(body["graph"]) if body.get("graph") else []
            if graph:
                at = [rr.TimeColumn("generation", sequence=[gen])]
                chunks.append(Chunk.from_columns("/best/graph", at, _one_row(*graph)))
    for gen, grid in sorted((archives or {}).items()):
        at = [rr.TimeColumn("generation", sequence=[int(gen)])]
        chunks.append(Chunk.from_columns("/archive", at, _one_row(archive_image(grid))))
    for gen, graph in sorted((lineage or {}).items()):  # one row each: the graph grows
        at = [rr.TimeColumn("generation", sequence=[int(gen)])]
        chunks.append(Chunk.from_columns(LINEAGE_ENTITY, at, _one_row(*graph)))
    return _write_chunks(path, name, chunks, fsync=fsync)


#: Per-generation series drawn beside an evaluation (bar charts: they show on any timeline):
#: their entities, names and colours. A bar chart has no series name (its legend would show
#: the entity path), so each gets a view of its own, titled with its name and unit.
SUMMARY_SERIES: dict[str, tuple[str, str, tuple[int, int, int, int]]] = {
    "best_fitness": ("/run/fitness/best", "best fitness", (214, 39, 40, 255)),
    "mean_fitness": ("/run/fitness/mean", "mean fitness", (31, 119, 180, 255)),
    "diversity": (
        "/run/diversity/descriptor_distance",
        "descriptor distance",
        (44, 160, 44, 255),
    ),
    "distinct_morphologies": (
        "/run/diversity/distinct_morphologies",
        "distinct bodies",
        (148, 103, 189, 255),
    ),
}


def run_summary_chunks(generations_df: Any) -> list[Any]:
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


def archive_chunks(grid: Any, dimensions: Sequence[str] | None = None) -> list[Any]:
    """A MAP-Elites archive (`archive_cells`: fitness per cell, NaN where empty, or a CVT's
    cells) static at `ARCHIVE_ENTITY` (`archive_shown`: a tensor, its dimensions named by
    ``dimensions``, e.g. "num_limbs (0 to 8)", or points), for a view beside an evaluation.
    Nothing for an archive without elites."""
    shown = archive_shown(grid, dimensions)
    return [] if shown is None else [static_chunk(ARCHIVE_ENTITY, shown)]


def write_view_recording(
    path: str | os.PathLike[str],
    evaluation: str | os.PathLike[str],
    generations_df: Any,
    *,
    archive: Any = None,
    archive_dimensions: Sequence[str] | None = None,
    graph_json: str | Mapping[str, Any] | None = None,
) -> Path:
    """One recording to open: the evaluation recording ``evaluation`` (its robot, joints and
    graph on ``sim_time``) with the run's fitness and diversity per generation beside
    (`run_summary_chunks`) and, for a MAP-Elites run, its ``archive`` (`archive_chunks`),
    under the evaluation's recording id; returns its path. ``graph_json``: the body's
    morphology, drawn again as this version draws it (a recording made by an older one keeps
    its own drawing otherwise)."""
    from rerun.chunk import RrdReader

    reader = RrdReader(Path(evaluation))
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


# --------------------------------------------------------------------------------------------
# Blueprint
# --------------------------------------------------------------------------------------------


def blueprint(
    *,
    panels: bool = True,
    archive: bool | str = False,
    fitness_unit: str | None = None,
    run_curves: bool = True,
) -> Any:
    """The default layout: the 3D replay and the morphology (and, with ``archive``, a MAP-Elites
    run's archive, `ARCHIVE_ENTITY`: True or ``"grid"``, or ``"cvt"``, `archive_view`) above,
    joints and the run's fitness and diversity per generation below; the time panel on
    ``sim_time`` (the evaluation's clock).

    The morphology view shows an evaluation's ``/graph`` and run.rrd's best body of each
    generation (``/best/graph``). Fitness and diversity per generation are static bar charts
    (`run_summary_chunks`, drawn whatever the timeline), one view per series, titled with its
    name and unit (``fitness_unit``, e.g. "m"); with ``run_curves`` each group has a second
    tab of run.rrd's curves on the ``generation`` timeline, and the morphology a tab of its
    lineage graph (`lineage_view`). The 3D camera looks at the start, from 1.5 m away.
    ``panels=False`` collapses the side panels (the blueprint tree, the selection, the time
    panel) for pictures of the views alone.
    """
    rr = rerun_module()
    rrb = rr.blueprint
    time_panel = rrb.TimePanel(timeline="sim_time", **({} if panels else {"state": "collapsed"}))
    side = (
        [time_panel]
        if panels
        else [
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            time_panel,
        ]
    )
    unit = f" ({fitness_unit})" if fitness_unit else ""
    hidden = rrb.PlotLegend(visible=False)

    def bars(column: str) -> Any:
        entity, name, _ = SUMMARY_SERIES[column]
        title = f"{name}{unit if 'fitness' in column else ''} per generation"
        return rrb.BarChartView(name=title, origin=entity, plot_legend=hidden)

    def curve(entity: str, title: str) -> Any:
        return rrb.TimeSeriesView(name=title, origin=entity, plot_legend=hidden)

    fitness: Any = rrb.Vertical(
        bars("best_fitness"), bars("mean_fitness"), name="fitness per generation"
    )
    diversity: Any = rrb.Vertical(
        bars("diversity"), bars("distinct_morphologies"), name="diversity per generation"
    )
    if run_curves:
        fitness = rrb.Tabs(
            fitness,
            rrb.TimeSeriesView(
                name=f"fitness{unit} (generation timeline)",
                origin="/fitness",
                plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftTop),
            ),
            active_tab=0,
        )
        diversity = rrb.Tabs(
            diversity,
            rrb.Vertical(
                curve("/diversity/descriptor_distance", "descriptor distance"),
                curve("/diversity/distinct_morphologies", "distinct bodies"),
                name="diversity (generation timeline)",
            ),
            active_tab=0,
        )
    top = [
        rrb.Spatial3DView(
            name="robot",
            origin="/world",
            eye_controls=rrb.EyeControls3D(
                kind=rrb.components.Eye3DKind.Orbital,
                position=(0.8, -1.2, 0.7),
                look_target=(0.1, 0.0, 0.0),
                eye_up=(0.0, 0.0, 1.0),
            ),
        ),
        rrb.GraphView(name="morphology", origin="/", contents=["/graph/**", "/best/graph/**"]),
    ]
    if run_curves:  # run.rrd's lineage, a tab beside the morphology
        top[1] = rrb.Tabs(top[1], lineage_view(), active_tab=0)
    if archive:  # measure 0 across, measure 1 up
        top.append(archive_view(archive, unit, sliced=True))
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(*top, column_shares=[4, 2, 2] if archive else [3, 1]),
            rrb.Horizontal(
                rrb.TimeSeriesView(name="joint targets (rad)", origin="/joints/target"),
                rrb.TimeSeriesView(name="joint angles (rad)", origin="/joints/angle"),
                fitness,
                diversity,
            ),
            row_shares=[3, 2],
        ),
        *side,
        collapse_panels=False,
    )


def write_blueprint(
    path: str | os.PathLike[str],
    *,
    panels: bool = True,
    archive: bool | str = False,
    fitness_unit: str | None = None,
    run_curves: bool = True,
) -> Path:
    """Write the default viewer layout (``blueprint.rbl``, application id ``ariel``).

    Open it with the recordings: ``rerun blueprint.rbl run.rrd recordings/gen-000000/*.rrd``.

    Args:
        path: The blueprint file to write (whole, replacing an existing one), usually
            ``blueprint.rbl`` beside the recordings.
        panels: False collapses the side panels (the blueprint tree, the selection, the time
            panel) for pictures of the views alone.
        archive: Whether to add a view of a MAP-Elites run's archive (`ARCHIVE_ENTITY`):
            False, True or ``"grid"`` (a tensor view), ``"cvt"`` (a 2D view of its points).
        fitness_unit: The fitness's unit (e.g. ``"m"``) for the fitness views' titles; None:
            no unit.
        run_curves: Whether the fitness and diversity views get a second tab of run.rrd's
            curves on the ``generation`` timeline, and the morphology one of its lineage.

    Returns:
        ``path``, as a `Path`.
    """
    layout = blueprint(
        panels=panels, archive=archive, fitness_unit=fitness_unit, run_curves=run_curves
    )
    return save_blueprint(path, layout, APPLICATION_ID)


def save_blueprint(path: str | os.PathLike[str], layout: Any, application_id: str) -> Path:
    """Write the blueprint ``layout`` for ``application_id`` whole to ``path``."""
    path = Path(path)

    def write(temporary: Path) -> None:
        # Rerun's blueprint writer logs a full disk and leaves a cut file: check first.
        require_free_space(temporary.parent, _BLUEPRINT_ROOM)
        # Rerun writes blueprints to paths ending in .rbl only: build beside, then move.
        staging = temporary.with_name(temporary.name + ".rbl")
        try:
            layout.save(application_id, str(staging))
            os.replace(staging, temporary)
        finally:
            if staging.exists():
                staging.unlink()

    atomic_write(path, write)
    return path
