"""Joint names for people: ``robot1_0-10-2-servo`` reads "right branch, hinge 1".

The robogen-lite constructor names a hinge's joint after where the hinge attaches:
``{prefix}{parent}-{child}-{face}-servo`` (`constructor.attachment_prefix`; the prefix,
``robot1_``, is the world's spawn): the hinge is module ``child`` of the robot graph, on face
number ``face`` of module ``parent``. Module ids mean nothing to a reader, so `joint_labels`
names a hinge by

- its branch: the face of the core (``front``, ``back``, ``right``, ``left``: the core's own
  directions, +y its front) that the chain of modules from the core to the hinge leaves by;
- its number in that branch: the branch's hinges counted 1, 2, ... in the order the
  constructor attaches them (breadth-first from the core: the order of the actuators), so
  hinge 1 is the one nearest the core.

``robot1_0-10-2-servo`` (hinge 10 on the core's RIGHT face) is "right branch, hinge 1". The
core carries one module per face and each branch numbers its own hinges, so the labels of one
body are unique. Without the body's graph (or for a name the graph does not hold) the branch
is unknown: "hinge module 10" (module 10 of the graph). Other names (a
prebuilt body's hand-named joints, ``robot1_fl_legservo``) lose the prefix and the ``servo``
suffix: "fl leg". Should two labels still be equal, those two keep their names without the
prefix.

Used by ``ariel report`` (joints.png), the Rerun recordings' joint series and graphs
(`module_labels`: a hinge node carries its joint's label, shortened to "right 1") and the
analysis notebooks.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, TypeAlias, cast

import networkx as nx

from ariel.body_phenotypes.robogen_lite.config import IDX_OF_CORE, ModuleType
from ariel.recording.store import json_data

if TYPE_CHECKING:
    from ariel.body_phenotypes.robogen_lite.constructor import RobotTree

__all__ = ["GraphData", "GraphJson", "joint_labels", "module_labels"]

#: A robot graph in networkx's node-link form, parsed: ``nodes`` (each an ``id`` and a
#: ``type``) and ``edges`` (or ``links``), as read back from JSON (values unchecked).
GraphData: TypeAlias = Mapping[str, Any]
#: A robot graph as the records hold it: its node-link JSON text (the bodies table's
#: ``graph``) or that text parsed.
GraphJson: TypeAlias = str | GraphData

#: ``{prefix}{parent}-{child}-{face}-servo``, the constructor's hinge joint names.
_ROBOGEN = re.compile(r"(?:^|_)(\d+)-(\d+)-(\d+)-servo$")
#: The spawn's prefix: ``robot1_``.
_PREFIX = re.compile(r"^robot\d*_")


def _without_prefix(name: str) -> str:
    return _PREFIX.sub("", name, count=1) or name


def _plain(name: str) -> str:
    """A hand-made joint name without prefix and ``servo`` suffix: ``fl_legservo`` -> "fl leg"."""
    short = _without_prefix(name)
    text = re.sub(r"[-_ ]*servo$", "", short, flags=re.IGNORECASE)
    text = " ".join(re.split(r"[-_ ]+", text)).strip()
    return text or short


def _tree(graph: object) -> RobotTree | None:
    """The body's `RobotTree` from node-link JSON (a string or its dict) or a DiGraph; None
    where it cannot be read as a robot graph."""
    # lazy: the constructor imports mujoco, which loads its GL backend (MUJOCO_GL) on import
    from ariel.body_phenotypes.robogen_lite.constructor import validate_robot_graph

    try:
        if isinstance(graph, str | bytes):
            graph = json_data(graph)  # guarded: a table's cell nested out of stack is refused
        if isinstance(graph, Mapping):
            edges = "links" if "edges" not in graph and "links" in graph else "edges"
            data = {**graph, "directed": True, "multigraph": False}
            data.setdefault(edges, [])
            graph = nx.node_link_graph(data, directed=True, multigraph=False, edges=edges)
        return validate_robot_graph(cast("nx.DiGraph", graph))  # anything else: TypeError
    except (TypeError, ValueError, KeyError, nx.NetworkXError):
        return None


def _hinge_places(tree: RobotTree) -> dict[tuple[int, int, int], tuple[str, int]]:
    """(parent, hinge, face value) -> (branch, number): ("right", 1) for every hinge of
    ``tree``."""
    branch_of: dict[int, str] = {}
    counted: dict[str, int] = {}
    places = {}
    for node in tree.order:  # breadth-first from the core: the constructor's order
        if node == IDX_OF_CORE:
            continue
        parent, face = tree.parent[node]
        branch_of[node] = face.name.lower() if parent == IDX_OF_CORE else branch_of[parent]
        if tree.types[node] is ModuleType.HINGE:
            branch = branch_of[node]
            counted[branch] = counted.get(branch, 0) + 1
            places[(parent, node, face.value)] = (branch, counted[branch])
    return places


def joint_labels(names: Sequence[str], graph: GraphJson | nx.DiGraph | None = None) -> list[str]:
    """A short label for each joint of one body, unique within it (the rule: module docstring).

    Args:
        names: The joints as the model names them (``joint_names`` of an evaluation).
        graph: The body's robot graph (the bodies table's ``graph``, node-link JSON, or a
            networkx DiGraph), None where it is not at hand; a graph that cannot be read as a
            robot graph counts as none.

    Returns:
        One label per name, in order: ``"right branch, hinge 1"`` for a constructor's hinge
        the graph places, ``"hinge module 10"`` for one it does not, and a hand-made name
        without its prefix and ``servo`` suffix (``"fl leg"``). Where labels would still
        clash, the names themselves.

    Example:
        ```python
        from ariel.recording import joint_labels

        print(joint_labels(["robot1_0-10-2-servo", "robot1_fl_legservo"]))
        # ['hinge module 10', 'fl leg']  (no graph: the branch is unknown)
        ```

    Raises:
        TypeError: When ``names`` is one string, not a list of them (it was read a character
            at a time).
    """
    if isinstance(names, str | bytes):
        raise TypeError(f"joint_labels: names must be a list of joint names, not {names!r:.40}")
    names = [str(name) for name in names]
    tree = _tree(graph) if graph is not None and len(names) else None
    places = _hinge_places(tree) if tree is not None else {}
    labels = []
    for name in names:
        found = _ROBOGEN.search(name)
        if found is None:
            labels.append(_plain(name))
            continue
        parent, hinge, face = (int(group) for group in found.groups())
        place = places.get((parent, hinge, face))
        labels.append(f"{place[0]} branch, hinge {place[1]}" if place else f"hinge module {hinge}")
    seen: dict[str, int] = {}
    for label in labels:
        seen[label] = seen.get(label, 0) + 1
    labels = [
        label if seen[label] == 1 else _without_prefix(name) for label, name in zip(labels, names)
    ]
    return labels if len(set(labels)) == len(labels) else names


def module_labels(node_ids: Sequence[str], types: Sequence[str], graph: GraphJson) -> list[str]:
    """Short labels of a body's modules for its graph drawings, legible in a small view: a
    hinge by its branch and number ("right 1": the joint legends' "right branch, hinge 1"),
    any other module by its type alone ("core", "brick"; the colour says it too, and module
    ids mean nothing to a reader). ``node_ids`` and ``types`` (CORE, BRICK, HINGE) as the
    graph lists them; ``graph``: the same graph (node-link JSON or its dict). A hinge the
    graph does not place is "hinge <id>"."""
    tree = _tree(graph) if len(node_ids) else None
    places = _hinge_places(tree) if tree is not None else {}
    by_hinge = {str(hinge): f"{branch} {n}" for (_, hinge, _), (branch, n) in places.items()}
    return [
        by_hinge.get(str(i)) or (f"hinge {i}" if t.upper() == "HINGE" else t.lower())
        for i, t in zip(node_ids, types)
    ]
