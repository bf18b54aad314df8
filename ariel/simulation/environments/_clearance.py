"""How high a robot stands above the ground: sample points on its geoms' surfaces (an
estimate of its lowest point over any ground) and the exact clearance by MuJoCo collisions.
`BaseWorld.spawn` uses both to drop a robot to 1 cm above the ground under it.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["collision_clearance", "robot_points"]


# --------------------------------------------------------------------------------------------
# Sample points on a geom's surface, used to find a robot's lowest point over any ground.
# --------------------------------------------------------------------------------------------
def _surface_lattice(per_edge: int = 5) -> np.ndarray:
    """Points of a per_edge^3 lattice on [-1, 1]^3 on the cube surface (corners included)."""
    axis = np.linspace(-1.0, 1.0, per_edge)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid[np.any(np.abs(grid) == 1.0, axis=1)]


_LATTICE = _surface_lattice()
_DIRECTIONS = _LATTICE / np.linalg.norm(_LATTICE, axis=1, keepdims=True)
_RIM_ANGLES = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
_DOWN = np.array([0.0, 0.0, -1.0])


def _geom_points(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    """World-frame sample points of one geom, always including its lowest point on flat ground.

    Boxes: corners plus a 5x5 grid on every face (exact on planes, dense enough on terrain).
    Spheres, capsules, ellipsoids, cylinders: the exact lowest point plus surface samples.
    Anything else (meshes, ...): its bounding box, which is conservative (never too low).
    """
    gtype = model.geom_type[geom]
    size = model.geom_size[geom]
    centre = data.geom_xpos[geom]
    rot = data.geom_xmat[geom].reshape(3, 3)
    G = mujoco.mjtGeom
    if gtype == G.mjGEOM_PLANE:
        return np.empty((0, 3))
    if gtype == G.mjGEOM_BOX:
        return centre + (_LATTICE * size) @ rot.T
    if gtype == G.mjGEOM_SPHERE:
        radius = size[0]
        return np.vstack([centre + radius * _DIRECTIONS, centre + radius * _DOWN])
    if gtype == G.mjGEOM_ELLIPSOID:
        down_local = rot.T @ _DOWN
        support = size**2 * down_local / np.linalg.norm(size * down_local)
        surface = (_DIRECTIONS * size) @ rot.T
        return centre + np.vstack([surface, rot @ support])
    if gtype == G.mjGEOM_CAPSULE:
        radius, half = size[0], size[1]
        ends = centre + np.outer([-half, half], rot[:, 2])
        return np.vstack([end + radius * np.vstack([_DIRECTIONS, _DOWN]) for end in ends])
    if gtype == G.mjGEOM_CYLINDER:
        radius, half = size[0], size[1]
        ends = centre + np.outer([-half, half], rot[:, 2])
        rim = radius * (np.outer(np.cos(_RIM_ANGLES), rot[:, 0]))
        rim += radius * np.outer(np.sin(_RIM_ANGLES), rot[:, 1])
        # Exact lowest rim point: -z projected onto the cap plane.
        across = _DOWN - (_DOWN @ rot[:, 2]) * rot[:, 2]
        norm = np.linalg.norm(across)
        lowest = radius * across / norm if norm > 1e-12 else np.zeros(3)
        return np.vstack([end + np.vstack([rim, lowest, np.zeros(3)]) for end in ends])
    # Meshes and other types: corners and face points of the geom's local bounding box.
    aabb = model.geom_aabb[geom]
    return centre + (aabb[:3] + _LATTICE * aabb[3:]) @ rot.T


def robot_points(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> np.ndarray:
    """`_geom_points` of all ``geoms``, stacked ``(N, 3)``; boxes (all of a robogen body's
    geoms) in one batched product, which computes the same numbers as one box at a time."""
    is_box = model.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_BOX
    boxes = geoms[is_box]
    points = [_geom_points(model, data, int(g)) for g in geoms[~is_box]]
    if len(boxes):
        rot = data.geom_xmat[boxes].reshape(-1, 3, 3)
        local = _LATTICE * model.geom_size[boxes][:, None, :]
        box_points = data.geom_xpos[boxes][:, None, :] + local @ rot.transpose(0, 2, 1)
        points.append(box_points.reshape(-1, 3))
    return np.vstack(points) if points else np.empty((0, 3))


def _only_robot_ground_contacts(
    model: mujoco.MjModel, robot: np.ndarray, ground: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Enable contacts on ``model`` between robot and ground geoms only, with zero margins
    and gaps (a contact then means penetration); returns masks of the robot and ground geoms
    (``(ngeom,)`` bools)."""
    model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    model.geom_contype[:] = 0
    model.geom_conaffinity[:] = 0
    model.geom_contype[robot] = 1
    model.geom_conaffinity[ground] = 1
    for ids in (robot, ground):
        model.geom_margin[ids] = 0.0
        model.geom_gap[ids] = 0.0
    robot_set = np.zeros(model.ngeom, dtype=bool)
    robot_set[robot] = True
    ground_set = np.zeros(model.ngeom, dtype=bool)
    ground_set[ground] = True
    return robot_set, ground_set


def collision_clearance(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    free_z: int,
    robot: np.ndarray,
    ground: np.ndarray,
    estimate: float,
) -> float:
    """Exact vertical clearance of the robot above the ground geoms, by MuJoCo collisions.

    Works on a throw-away compiled model: only robot-vs-ground contacts are enabled, margins
    and gaps are zero, so a contact means penetration. Lowering the robot by s makes it touch
    for s above the clearance and not below it; bisection finds that s. `estimate` (from sample
    points) brackets it; if no bracket is found (e.g. nothing under the robot) it is returned.
    """
    robot_set, ground_set = _only_robot_ground_contacts(model, robot, ground)
    z0 = float(data.qpos[free_z])

    def touches(shift: float) -> bool:
        data.qpos[free_z] = z0 - shift
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        n = data.ncon
        if n == 0:
            return False
        pairs = data.contact.geom[:n]
        hits = (robot_set[pairs[:, 0]] & ground_set[pairs[:, 1]]) | (
            robot_set[pairs[:, 1]] & ground_set[pairs[:, 0]]
        )
        return bool(np.any(hits & (data.contact.dist[:n] < 0.0)))

    # Sample points lie on the geoms (or outside them), so the true clearance is usually just
    # below the estimate; widen the bracket step by step where it is not.
    step = 0.02
    high = estimate + 1e-4
    for _ in range(12):
        if touches(high):
            break
        high += step
        step *= 2
    else:
        return estimate
    step = 0.02
    low = estimate - step
    for _ in range(12):
        if not touches(low):
            break
        step *= 2
        low -= step
    else:
        return estimate
    while high - low > 1e-7:
        middle = 0.5 * (low + high)
        if touches(middle):
            high = middle
        else:
            low = middle
    data.qpos[free_z] = z0
    return 0.5 * (low + high)
