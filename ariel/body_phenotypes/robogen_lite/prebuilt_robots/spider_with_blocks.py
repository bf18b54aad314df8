"""Spiders whose legs alternate hinges and bricks: ``body_spider()`` and ``body_spider45()``."""

from __future__ import annotations

import math

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule

__all__ = ["body_spider", "body_spider45"]

_FACES = (
    (ModuleFaces.FRONT, "F"),
    (ModuleFaces.LEFT, "L"),
    (ModuleFaces.BACK, "B"),
    (ModuleFaces.RIGHT, "R"),
)


def body_spider() -> CoreModule:
    """Four legs (FRONT, LEFT, BACK, RIGHT), each hinge > brick > hinge (90 deg) > brick.

    Prefixes spell the path from the core: "C-FH-", "C-FH-B-", "C-FH-B-H-", "C-FH-B-H-B-".
    8 actuators.

    Returns:
        The spider's core module; its ``.spec`` is the body's ``mujoco.MjSpec``.
    """
    core = CoreModule(index=0)
    index = 1
    for face, letter in _FACES:
        hip = HingeModule(index=index)
        thigh = BrickModule(index=index + 1)
        knee = HingeModule(index=index + 2)
        foot = BrickModule(index=index + 3)
        index += 4
        prefix = f"C-{letter}H-"
        core.sites[face].attach_body(body=hip.body, prefix=prefix)
        hip.sites[ModuleFaces.FRONT].attach_body(body=thigh.body, prefix=f"{prefix}B-")
        thigh.sites[ModuleFaces.FRONT].attach_body(body=knee.body, prefix=f"{prefix}B-H-")
        # Like upstream, the knee is rotated after it was attached (attachment is by reference).
        knee.rotate(90)
        knee.sites[ModuleFaces.FRONT].attach_body(body=foot.body, prefix=f"{prefix}B-H-B-")
    return core


def body_spider45() -> CoreModule:
    """``body_spider()`` with the core yawed by 45 degrees (legs on the diagonals).

    Returns:
        The spider's core module, its root body turned 45 degrees about the vertical axis.
    """
    core = body_spider()
    half = math.radians(45.0) / 2.0
    # The core's rotate() only allows 0 (growth-axis rotations make no sense for the root);
    # yawing the whole robot is a different operation, done on the root body directly.
    core.body.quat = [math.cos(half), 0.0, 0.0, math.sin(half)]
    return core
