"""What a closed-loop controller sees: observation vectors built from the MuJoCo state."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import mujoco

__all__ = ["hinge_observation"]


def hinge_observation(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Closed-loop input: actuated joint angles and velocities, gravity in the robot's frame.

    Reads only ``qpos``/``qvel`` (current at every control call, no kinematics pass needed).
    Each actuator's joint is its transmission target (``model.actuator_trnid``).

    Args:
        model: The compiled model.
        data: The model's current data.

    Returns:
        ``[q (nu), qdot (nu), g_body (3)]``: the actuated joints' angles and velocities, then
        the world's down direction in the body frame of the free joint that comes first
        (``(0, 0, -1)`` when the first joint is not free).
    """
    joints = model.actuator_trnid[:, 0]
    q = data.qpos[model.jnt_qposadr[joints]]
    qd = data.qvel[model.jnt_dofadr[joints]]
    w, x, y, z = data.qpos[3:7] if model.nq >= 7 and model.jnt_type[0] == 0 else (1, 0, 0, 0)
    # World "down" (0, 0, -1) expressed in the body frame: R^T @ (0, 0, -1).
    g = -np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    return np.concatenate([q, qd, g])
