"""The camera of the report's body pictures: the robot from the front-left, 30 degrees above."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ariel.utils import mujoco_module

if TYPE_CHECKING:
    import mujoco  # lazy: loads its GL backend (MUJOCO_GL) on import; renderers choose it first

__all__ = ["three_quarter_view"]


class _Built(Protocol):
    """What the camera needs of a built body (`ariel.evaluation.build`'s result)."""

    model: mujoco.MjModel
    core_geom: int


def three_quarter_view(built: _Built, size: float) -> dict[str, Any]:
    """ "ortho-cam" overrides that frame the robot from the front-left, 30 degrees above."""
    mujoco = mujoco_module()

    model = built.model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    target = data.subtree_com[model.geom_bodyid[built.core_geom]].copy()
    azimuth, elevation = math.radians(135.0), math.radians(-30.0)  # the tracking video's view
    forward = np.array(
        [
            math.cos(elevation) * math.cos(azimuth),
            math.cos(elevation) * math.sin(azimuth),
            math.sin(elevation),
        ]
    )
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    frame = np.column_stack([right, up, -forward])  # a camera looks along its -z axis
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, frame.ravel())
    return {
        "cam_pos": target - 3.0 * forward,
        "cam_quat": quat,
        "cam_fovy": max(0.4, 1.8 * size),  # orthographic: the visible height in metres
    }
