"""What every recording of one compiled model shares, built once per model and cached: the
world's static chunks (the floor, walls and platforms, heightfields cropped to the robot's
path) and the robot's boxes, one per body geom, coloured by module type.

Poses are MuJoCo's quaternions (w, x, y, z) turned into Rerun's (x, y, z, w) here.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from ariel.recording.rerun._chunks import _CACHE_LOCK, rerun_module, static_chunk
from ariel.utils import mujoco_module

if TYPE_CHECKING:
    import mujoco
    from rerun import AsComponents, Boxes3D, Mesh3D
    from rerun.chunk import Chunk

__all__ = ["TERRAIN_MARGIN", "module_colours", "module_type_of"]

ROBOT_PREFIX = "robot1_"
#: Metres of terrain drawn around the robot's path (a heightfield mesh of a whole arena is up
#: to 150 kB per recording; the part the robot walked on is what one looks at).
TERRAIN_MARGIN = 1.0
#: Largest number of heightfield rows or columns drawn (subsampled beyond).
TERRAIN_MAX_SIDE = 32
#: Half-extent drawn for an infinite MuJoCo plane (size 0).
INFINITE_PLANE_HALF_EXTENT = 20.0
_OTHER_COLOUR = (128, 128, 128, 255)


def _rgba255(colour: Sequence[float]) -> tuple[int, int, int, int]:
    r, g, b, a = (round(255 * float(c)) for c in colour[:4])
    return r, g, b, a


@cache
def module_colours() -> dict[str, tuple[int, int, int, int]]:
    """Module type -> RGBA (0-255): the colours the robogen-lite modules give their geoms."""
    # lazy: the modules import mujoco, which loads its GL backend (MUJOCO_GL) on import
    from ariel.body_phenotypes.robogen_lite.modules.brick import BRICK_COLOUR
    from ariel.body_phenotypes.robogen_lite.modules.core import CORE_COLOUR  # lazy: as above
    from ariel.body_phenotypes.robogen_lite.modules.hinge import STATOR_COLOUR  # lazy: as above

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

    model: mujoco.MjModel  # kept alive so the cache key (its id) stays unique
    world: list[Chunk]  # static chunks: /world (view coordinates, boxes), other world geoms
    heightfields: list[_Heightfield]
    robot_sizes: Chunk  # static chunk: the robot's boxes (sizes, colours, labels)
    robot_still: Chunk  # static chunk: the same boxes in the start pose
    geom_body: np.ndarray  # (G,) column in body_names of each robot box
    geom_pos: np.ndarray  # (G, 3) in its body's frame
    geom_quat: np.ndarray  # (G, 4) in its body's frame, (w, x, y, z)
    joint_names: dict[tuple[str, ...], list[Chunk]] = field(default_factory=dict)


_SCENES: OrderedDict[tuple[int, tuple[str, ...]], _Scene] = OrderedDict()
_SCENE_CACHE_SIZE = 32  # more than the bodies a generation usually learns side by side


def _scene(model: mujoco.MjModel, body_names: Sequence[str]) -> _Scene:
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


def _build_scene(model: mujoco.MjModel, body_names: Sequence[str]) -> _Scene:
    mujoco = mujoco_module()

    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    geom_xquat = np.empty((model.ngeom, 4))
    for g in range(model.ngeom):
        mujoco.mju_mat2Quat(geom_xquat[g], data.geom_xmat[g])
    geom_names = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(model.ngeom)
    ]
    robot_bodies = _robot_bodies(model, body_names)
    column = {b: i for i, b in enumerate(robot_bodies)}

    # The robot: box geoms of the given bodies.
    box = mujoco.mjtGeom.mjGEOM_BOX
    geoms = [
        g
        for g in range(model.ngeom)
        if int(model.geom_bodyid[g]) in column and int(model.geom_type[g]) == box
    ]
    boxes = _robot_boxes(model, geoms, geom_names)
    world_chunks, heightfields = _world(model, data, geom_xquat, geom_names, robot_bodies)

    body_xpos = data.xpos[robot_bodies] if robot_bodies else np.zeros((0, 3))
    body_xquat = data.xquat[robot_bodies] if robot_bodies else np.zeros((0, 4))
    geom_body = np.array([column[int(model.geom_bodyid[g])] for g in geoms], dtype=np.int64)
    geom_pos = np.asarray(model.geom_pos[geoms], dtype=np.float64).reshape(-1, 3)
    geom_quat = np.asarray(model.geom_quat[geoms], dtype=np.float64).reshape(-1, 4)
    centers, quats = _box_poses(body_xpos[None], body_xquat[None], geom_body, geom_pos, geom_quat)
    start = rerun_module().Boxes3D.from_fields(centers=centers[0], quaternions=quats[0])
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


def _robot_bodies(model: mujoco.MjModel, body_names: Sequence[str]) -> list[int]:
    """The model's body ids of ``body_names``; `ValueError` for one it does not have."""
    mujoco = mujoco_module()

    body_index = {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "": b for b in range(model.nbody)
    }
    robot_bodies = []
    for name in body_names:
        if name not in body_index:
            raise ValueError(f"body {name!r} is not in the model")
        robot_bodies.append(body_index[name])
    return robot_bodies


def _robot_boxes(model: mujoco.MjModel, geoms: Sequence[int], geom_names: list[str]) -> Boxes3D:
    """The robot's box geoms ``geoms`` as one batch: sizes, colours, labels (no poses)."""
    colours = [_rgba255(model.geom_rgba[g]) for g in geoms]
    labels = [_short(geom_names[g]) or f"geom{g}" for g in geoms]
    return rerun_module().Boxes3D(
        half_sizes=np.asarray(model.geom_size[geoms], dtype=np.float32).reshape(-1, 3),
        colors=colours,
        labels=labels,
        show_labels=False,
        fill_mode="solid",
    )


def _world(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geom_xquat: np.ndarray,
    geom_names: list[str],
    robot_bodies: list[int],
) -> tuple[list[Chunk], list[_Heightfield]]:
    """The world: everything but the robot, as static chunks, and its heightfields. Boxes (and
    planes, as thin boxes) form one batch at /world, with the view coordinates: one chunk for
    a flat floor or a whole arena."""
    mujoco = mujoco_module()

    rr = rerun_module()
    world_boxes: dict[str, list[object]] = {
        k: [] for k in ("half", "center", "quat", "colour", "label")
    }
    world: list[tuple[str, list[AsComponents]]] = []
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
            heightfields.append(_heightfield(model, g, path, pos, quat, colour))
        else:
            shape = _round_shape(kind, size, pos, quat, colour)
            if shape is not None:
                world.append((path, [shape]))
        # meshes and other shapes of a world: not drawn
    world.insert(0, ("/world", _ground(world_boxes)))
    return [static_chunk(path, *archetypes) for path, archetypes in world], heightfields


def _ground(world_boxes: dict[str, list[object]]) -> list[AsComponents]:
    """What ``/world`` holds: the view coordinates (z up) and the world's boxes, one batch."""
    rr = rerun_module()
    ground: list[AsComponents] = [rr.ViewCoordinates.RIGHT_HAND_Z_UP]
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
    return ground


def _heightfield(
    model: mujoco.MjModel,
    g: int,
    path: str,
    pos: np.ndarray,
    quat: np.ndarray,
    colour: tuple[int, int, int, int],
) -> _Heightfield:
    """Heightfield geom ``g`` of the world at ``path``: its heights in metres, its extent."""
    field = int(model.geom_dataid[g])
    nrow, ncol = int(model.hfield_nrow[field]), int(model.hfield_ncol[field])
    rx, ry, top, _base = (float(v) for v in model.hfield_size[field])
    start = int(model.hfield_adr[field])
    heights = np.asarray(model.hfield_data[start : start + nrow * ncol], dtype=np.float64)
    return _Heightfield(path, pos, quat, heights.reshape(nrow, ncol) * top, (rx, ry), colour)


def _round_shape(
    kind: int,
    size: np.ndarray,
    pos: np.ndarray,
    quat: np.ndarray,
    colour: tuple[int, int, int, int],
) -> AsComponents | None:
    """A world geom of a round ``kind`` (sphere, ellipsoid, capsule, cylinder) as Rerun draws
    it; None for another kind (meshes: not drawn)."""
    mujoco = mujoco_module()

    rr = rerun_module()
    kinds = mujoco.mjtGeom
    if kind in (kinds.mjGEOM_SPHERE, kinds.mjGEOM_ELLIPSOID):
        half = [size[0]] * 3 if kind == kinds.mjGEOM_SPHERE else size
        return rr.Ellipsoids3D(
            half_sizes=[half], centers=[pos], quaternions=[_xyzw(quat)], colors=[colour]
        )
    if kind == kinds.mjGEOM_CAPSULE:  # Rerun's capsule starts at its translation
        base = pos - _rotate(quat, np.array([0.0, 0.0, size[1]]))
        return rr.Capsules3D(
            lengths=[2 * size[1]],
            radii=[size[0]],
            translations=[base],
            quaternions=[_xyzw(quat)],
            colors=[colour],
        )
    if kind == kinds.mjGEOM_CYLINDER:
        return rr.Cylinders3D(
            lengths=[2 * size[1]],
            radii=[size[0]],
            centers=[pos],
            quaternions=[_xyzw(quat)],
            colors=[colour],
        )
    return None


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


def _terrain(field: _Heightfield, path_xy: np.ndarray) -> Mesh3D:
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
