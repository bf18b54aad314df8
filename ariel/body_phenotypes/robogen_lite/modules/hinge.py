"""The hinge module: a red stator and a dark-red rotor joined by a position servo.

Total length 0.10 m along the growth axis: stator y in [0, 0.06], rotor y in [0.06, 0.10].
The joint axis is the module's local z; ``rotate(90)`` turns it from yaw into pitch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleType
from ariel.body_phenotypes.robogen_lite.modules.module import Module, rgba

__all__ = [
    "HINGE_SITES",
    "ROTOR_BODY_POS",
    "ROTOR_COLOUR",
    "ROTOR_HALF_EXTENTS",
    "ROTOR_MASS",
    "SERVO_AXIS",
    "SERVO_BIAS",
    "SERVO_CTRLRANGE",
    "SERVO_JOINT_POS",
    "SERVO_KP",
    "SERVO_KV",
    "STATOR_BODY_POS",
    "STATOR_COLOUR",
    "STATOR_HALF_EXTENTS",
    "STATOR_MASS",
    "STATOR_SHRINK",
    "HingeModule",
]

STATOR_MASS = 0.02
ROTOR_MASS = 0.04
STATOR_SHRINK = 0.99  # 1 % smaller so the stator never touches the parent module
STATOR_HALF_EXTENTS = (0.025 * STATOR_SHRINK, 0.03 * STATOR_SHRINK, 0.025 * STATOR_SHRINK)
ROTOR_HALF_EXTENTS = (0.025, 0.02, 0.025)
STATOR_BODY_POS = (0.0, 0.03, 0.0)
ROTOR_BODY_POS = (0.0, 0.08, 0.0)
STATOR_COLOUR = rgba(223, 41, 53)  # red
ROTOR_COLOUR = rgba(160, 24, 33)  # dark red

SERVO_AXIS = (0.0, 0.0, 1.0)
SERVO_JOINT_POS = (0.0, -0.02, 0.0)  # rotor frame: the stator/rotor interface (module y 0.06)
SERVO_KP = 1.0
SERVO_KV = 1.0
# MuJoCo general actuator: force = gain * ctrl + bias0 + bias1 * q + bias2 * qdot
SERVO_BIAS = (0.0, -SERVO_KP, -SERVO_KV)
SERVO_CTRLRANGE = (-math.pi / 2, math.pi / 2)

# face -> (site name, position in the ROTOR frame, quaternion); the rotor's front end.
HINGE_SITES: dict[ModuleFaces, tuple[str, tuple[float, ...], tuple[float, ...]]] = {
    ModuleFaces.FRONT: ("hinge-front", (0.0, 0.02, 0.0), (1.0, 0.0, 0.0, 0.0)),
}


class HingeModule(Module):
    """A hinge: bodies "hinge" (root, massless) > "stator", "rotor"; joint and actuator "servo".

    Mass is physical: stator 0.02 kg + rotor 0.04 kg, nothing on the root body
    (docs/decisions.md, Bodies).
    """

    module_type = ModuleType.HINGE

    def _build(self, body: mujoco.MjsBody) -> Sequence[tuple[ModuleFaces, mujoco.MjsSite]]:
        stator = body.add_body(name="stator", pos=STATOR_BODY_POS)
        stator.add_geom(
            name="stator",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=STATOR_HALF_EXTENTS,
            mass=STATOR_MASS,
            rgba=STATOR_COLOUR,
        )
        rotor = body.add_body(name="rotor", pos=ROTOR_BODY_POS)
        rotor.add_geom(
            name="rotor",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=ROTOR_HALF_EXTENTS,
            mass=ROTOR_MASS,
            rgba=ROTOR_COLOUR,
        )
        rotor.add_joint(
            name="servo", type=mujoco.mjtJoint.mjJNT_HINGE, axis=SERVO_AXIS, pos=SERVO_JOINT_POS
        )
        # The two halves overlap at the joint; they must never collide with each other.
        self.spec.add_exclude(bodyname1="stator", bodyname2="rotor")
        self.spec.add_actuator(
            name="servo",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            target="servo",
            dyntype=mujoco.mjtDyn.mjDYN_NONE,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            gainprm=[SERVO_KP] + [0.0] * 9,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            biasprm=list(SERVO_BIAS) + [0.0] * 7,
            ctrlrange=SERVO_CTRLRANGE,
            ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        )
        sites = [
            (face, rotor.add_site(name=name, pos=pos, quat=quat))
            for face, (name, pos, quat) in HINGE_SITES.items()
        ]
        self.rotate(0)
        return sites
