"""The spider: four identical two-hinge legs, one on each side face of the core."""

from __future__ import annotations

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule

__all__ = ["spider", "spider_graph"]

# Leg k (prefix "lk") on each core face, in upstream's order.
_LEGS = (
    (ModuleFaces.FRONT, "l1"),
    (ModuleFaces.LEFT, "l2"),
    (ModuleFaces.RIGHT, "l3"),
    (ModuleFaces.BACK, "l4"),
)


def spider() -> CoreModule:
    """Build the spider: per leg a yaw hinge, a pitch hinge (90 deg) and a brick foot.

    Actuators: l1_1servo, l1_2servo, l2_1servo, ..., l4_2servo.

    Returns:
        The spider's core module; its ``.spec`` is the body's ``mujoco.MjSpec``.
    """
    core = CoreModule(index=0)
    index = 1
    for face, leg in _LEGS:
        hip = HingeModule(index=index)
        knee = HingeModule(index=index + 1)
        knee.rotate(90)
        foot = BrickModule(index=index + 2)
        index += 3
        core.sites[face].attach_body(body=hip.body, prefix=f"{leg}_1")
        hip.sites[ModuleFaces.FRONT].attach_body(body=knee.body, prefix=f"{leg}_2")
        knee.sites[ModuleFaces.FRONT].attach_body(body=foot.body, prefix=f"{leg}_3")
    return core


def spider_graph() -> nx.DiGraph:
    """The spider as a robot graph (same tree and module indices as ``spider()``).

    Returns:
        A new robot graph of the spider (13 modules; names as attribute values).
    """
    graph = nx.DiGraph()
    graph.add_node(0, type="CORE", rotation="DEG_0")
    index = 1
    for face, _leg in _LEGS:
        graph.add_node(index, type="HINGE", rotation="DEG_0")
        graph.add_node(index + 1, type="HINGE", rotation="DEG_90")
        graph.add_node(index + 2, type="BRICK", rotation="DEG_0")
        graph.add_edge(0, index, face=face.name)
        graph.add_edge(index, index + 1, face="FRONT")
        graph.add_edge(index + 1, index + 2, face="FRONT")
        index += 3
    return graph
