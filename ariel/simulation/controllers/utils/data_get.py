"""`get_state_from_data`: a robot's state for a closed-loop brain, without its position."""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["get_state_from_data"]


def get_state_from_data(data: mujoco.MjData) -> np.ndarray:
    """A robot's orientation and joint angles, without its position.

    Assumes the robot's free joint comes first in ``qpos`` (one robot spawned in a world), as
    upstream does.

    Args:
        data: The simulation data.

    Returns:
        ``[qx, qy, qz, hinge angles...]``: the imaginary part of the free joint's quaternion
        (negated first when ``w < 0``, so each orientation has one sign) and ``qpos[7:]``.

    Raises:
        ValueError: If ``qpos`` has fewer than 7 values.
    """
    if data.qpos.shape[0] < 7:
        raise ValueError(
            f"qpos has {data.qpos.shape[0]} values; a spawned robot (free joint first) has >= 7"
        )
    quat = data.qpos[3:7].copy()
    if quat[0] < 0:
        quat = -quat
    return np.concatenate([quat[1:], data.qpos[7:]])
