"""Small hand-built bodies in the spirit of upstream's ``john_set``.

Upstream's exact trees for these are not recorded in our reference, so ``baby_a`` and
``baby_b`` are our own plausible designs (trees of hinges and bricks, rotations 0/90), not
copies of upstream's bodies.
"""

from __future__ import annotations

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule

__all__ = ["baby_a", "baby_b"]


def baby_a() -> CoreModule:
    """A three-limbed crawler: a yaw hinge + brick head in front, pitch-hinge + brick arms.

    3 actuators: headservo, left_armservo, right_armservo.

    Returns:
        The body's core module; its ``.spec`` is the body's ``mujoco.MjSpec``.
    """
    core = CoreModule(index=0)
    head_joint = HingeModule(index=1)
    head = BrickModule(index=2)
    left_arm = HingeModule(index=3)
    left_arm.rotate(90)
    left_hand = BrickModule(index=4)
    right_arm = HingeModule(index=5)
    right_arm.rotate(90)
    right_hand = BrickModule(index=6)

    core.sites[ModuleFaces.FRONT].attach_body(body=head_joint.body, prefix="head")
    head_joint.sites[ModuleFaces.FRONT].attach_body(body=head.body, prefix="head_block")
    core.sites[ModuleFaces.LEFT].attach_body(body=left_arm.body, prefix="left_arm")
    left_arm.sites[ModuleFaces.FRONT].attach_body(body=left_hand.body, prefix="left_hand")
    core.sites[ModuleFaces.RIGHT].attach_body(body=right_arm.body, prefix="right_arm")
    right_arm.sites[ModuleFaces.FRONT].attach_body(body=right_hand.body, prefix="right_hand")
    return core


def baby_b() -> CoreModule:
    """A tailed quadruped-ish body: a three-hinge tail behind, two short legs at the sides.

    The tail alternates yaw/pitch/yaw hinges and ends in a brick; each side leg is a pitch
    hinge, a brick and a yaw hinge (toe). 7 actuators.

    Returns:
        The body's core module; its ``.spec`` is the body's ``mujoco.MjSpec``.
    """
    core = CoreModule(index=0)
    tail1 = HingeModule(index=1)
    tail2 = HingeModule(index=2)
    tail2.rotate(90)
    tail3 = HingeModule(index=3)
    tail_tip = BrickModule(index=4)

    core.sites[ModuleFaces.BACK].attach_body(body=tail1.body, prefix="tail1")
    tail1.sites[ModuleFaces.FRONT].attach_body(body=tail2.body, prefix="tail2")
    tail2.sites[ModuleFaces.FRONT].attach_body(body=tail3.body, prefix="tail3")
    tail3.sites[ModuleFaces.FRONT].attach_body(body=tail_tip.body, prefix="tail_tip")

    index = 5
    for face, side in ((ModuleFaces.LEFT, "left"), (ModuleFaces.RIGHT, "right")):
        hip = HingeModule(index=index)
        hip.rotate(90)
        shin = BrickModule(index=index + 1)
        toe = HingeModule(index=index + 2)
        index += 3
        core.sites[face].attach_body(body=hip.body, prefix=f"{side}_hip")
        hip.sites[ModuleFaces.FRONT].attach_body(body=shin.body, prefix=f"{side}_shin")
        shin.sites[ModuleFaces.FRONT].attach_body(body=toe.body, prefix=f"{side}_toe")
    return core
