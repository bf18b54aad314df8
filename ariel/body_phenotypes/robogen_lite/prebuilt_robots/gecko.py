"""The gecko: a core, a two-hinge spine and four legs (8 hinges, upstream's exact body).

``gecko()`` attaches in upstream's order, so actuators come out as neckservo, spineservo,
fl_legservo, fl_flipperservo, fr_legservo, fr_flipperservo, bl_legservo, br_legservo.
"""

from __future__ import annotations

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces
from ariel.body_phenotypes.robogen_lite.graph_io import robot_graph
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule

__all__ = ["gecko", "gecko_graph"]


def gecko() -> CoreModule:
    """Build the gecko (32 bodies incl. world when compiled alone, 8 actuators, 1.81 kg).

    Returns:
        The gecko's core module, every other module attached; its ``.spec`` is the body's
        ``mujoco.MjSpec``.

    Example:
        ```python
        from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko

        model = gecko().spec.compile()
        print(model.nu)  # 8 actuators
        ```
    """
    core = CoreModule(index=0)

    neck = HingeModule(index=1)
    abdomen = BrickModule(index=2)
    spine = HingeModule(index=3)
    butt = BrickModule(index=4)

    fl_leg = HingeModule(index=5)
    fl_leg.rotate(90)
    fl_leg2 = HingeModule(index=15)
    fl_leg2.rotate(90)
    fl_flipper = BrickModule(index=6)

    fr_leg = HingeModule(index=7)
    fr_leg.rotate(-90)
    fr_leg2 = HingeModule(index=17)
    fr_leg2.rotate(90)
    fr_flipper = BrickModule(index=8)

    bl_leg = HingeModule(index=9)
    bl_leg.rotate(45)
    bl_flipper = BrickModule(index=10)

    br_leg = HingeModule(index=11)
    br_leg.rotate(-45)
    br_flipper = BrickModule(index=12)

    # Top-down, in upstream's order (it fixes the actuator order). The prefixes are upstream's,
    # including the leg's second hinge being called "..._flipper".
    core.sites[ModuleFaces.FRONT].attach_body(body=neck.body, prefix="neck")
    neck.sites[ModuleFaces.FRONT].attach_body(body=abdomen.body, prefix="abdomen")
    abdomen.sites[ModuleFaces.FRONT].attach_body(body=spine.body, prefix="spine")
    spine.sites[ModuleFaces.FRONT].attach_body(body=butt.body, prefix="butt")
    core.sites[ModuleFaces.LEFT].attach_body(body=fl_leg.body, prefix="fl_leg")
    fl_leg.sites[ModuleFaces.FRONT].attach_body(body=fl_leg2.body, prefix="fl_flipper")
    fl_leg2.sites[ModuleFaces.FRONT].attach_body(body=fl_flipper.body, prefix="fl_flipper2")
    core.sites[ModuleFaces.RIGHT].attach_body(body=fr_leg.body, prefix="fr_leg")
    fr_leg.sites[ModuleFaces.FRONT].attach_body(body=fr_leg2.body, prefix="fr_flipper")
    fr_leg2.sites[ModuleFaces.FRONT].attach_body(body=fr_flipper.body, prefix="fr_flipper2")
    butt.sites[ModuleFaces.LEFT].attach_body(body=bl_leg.body, prefix="bl_leg")
    bl_leg.sites[ModuleFaces.FRONT].attach_body(body=bl_flipper.body, prefix="bl_flipper")
    butt.sites[ModuleFaces.RIGHT].attach_body(body=br_leg.body, prefix="br_leg")
    br_leg.sites[ModuleFaces.FRONT].attach_body(body=br_flipper.body, prefix="br_flipper")
    return core


def gecko_graph() -> nx.DiGraph:
    """The gecko as a robot graph (for ``construct_mjspec_from_graph`` and descriptors).

    Node ids are the gecko's module indices. Graph rotations can only be 0/45/90 degrees, so
    the right legs' -90 and -45 become 90 and 45: same shape and mass, but those two joint
    axes are not mirrored as in ``gecko()``.

    Returns:
        A new robot graph of the gecko (15 modules; names as attribute values).
    """
    nodes = {
        0: ("CORE", "DEG_0"),
        1: ("HINGE", "DEG_0"),
        2: ("BRICK", "DEG_0"),
        3: ("HINGE", "DEG_0"),
        4: ("BRICK", "DEG_0"),
        5: ("HINGE", "DEG_90"),
        15: ("HINGE", "DEG_90"),
        6: ("BRICK", "DEG_0"),
        7: ("HINGE", "DEG_90"),
        17: ("HINGE", "DEG_90"),
        8: ("BRICK", "DEG_0"),
        9: ("HINGE", "DEG_45"),
        10: ("BRICK", "DEG_0"),
        11: ("HINGE", "DEG_45"),
        12: ("BRICK", "DEG_0"),
    }
    edges = [
        (0, 1, "FRONT"),
        (1, 2, "FRONT"),
        (2, 3, "FRONT"),
        (3, 4, "FRONT"),
        (0, 5, "LEFT"),
        (5, 15, "FRONT"),
        (15, 6, "FRONT"),
        (0, 7, "RIGHT"),
        (7, 17, "FRONT"),
        (17, 8, "FRONT"),
        (4, 9, "LEFT"),
        (9, 10, "FRONT"),
        (4, 11, "RIGHT"),
        (11, 12, "FRONT"),
    ]
    return robot_graph(nodes, edges)
