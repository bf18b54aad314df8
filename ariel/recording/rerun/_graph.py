"""A body's morphology graph as the recordings draw it at ``/graph``: `GraphNodes` coloured by
module type, labelled short ("core", "brick", a hinge by branch and number: "right 1") and
placed as a tree from the core down (`tree_positions`), and directed `GraphEdges` (parent ->
child).
"""

from __future__ import annotations

import json
from collections import OrderedDict
from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

import numpy as np

from ariel.recording.rerun._chunks import _CACHE_LOCK, rerun_module, static_chunk
from ariel.recording.rerun._joint_names import GraphData, GraphJson, module_labels
from ariel.recording.rerun._scene import _OTHER_COLOUR, module_colours
from ariel.recording.store import json_data

if TYPE_CHECKING:
    from rerun import AsComponents
    from rerun.chunk import Chunk

__all__ = ["GRAPH_STEP", "graph_archetypes", "graph_colour", "tree_positions"]


def _graph_parts(
    graph_json: GraphJson,
) -> tuple[list[str], list[str], list[tuple[str, str]]]:
    """Node ids, their module types and (parent, child) edges of a node-link graph."""
    # the text read with the guarded parser (no JSON nested out of stack)
    data = cast(GraphData, json_data(graph_json)) if isinstance(graph_json, str) else graph_json
    nodes = data.get("nodes", [])
    ids = [str(node["id"]) for node in nodes]
    types = [str(node.get("type", "?")).upper() for node in nodes]
    links = data.get("edges", data.get("links", []))
    edges = [(str(e["source"]), str(e["target"])) for e in links]
    return ids, types, edges


#: Scene units between neighbouring leaves of a drawn morphology (across) and between a module
#: and its children (down): room for a label such as "right 1" beside the next.
GRAPH_STEP = (110.0, 70.0)


def tree_positions(
    ids: Sequence[str], edges: Sequence[tuple[object, object]]
) -> list[tuple[float, float]]:
    """Where to draw each node of a morphology (``ids``, parent -> child ``edges``): a tree
    drawn top-down, the root (the core) on top at x = 0, each module one row below its parent,
    the leaves side by side in depth-first order and a parent centred over its children, so
    no two labels overlap (the viewer's force layout piles them up). A graph that is not one
    tree (never a robot's) is drawn as rows of four."""
    children: dict[str, list[str]] = {str(i): [] for i in ids}
    parents: set[str] = set()
    tree = True
    for source, target in edges:
        source, target = str(source), str(target)
        if source not in children or target not in children or target in parents:
            tree = False
            break
        children[source].append(target)
        parents.add(target)
    roots = [i for i in children if i not in parents]
    order: list[str] = []
    depth: dict[str, int] = {}
    if tree and len(roots) == 1:
        stack = [(roots[0], 0)]
        while stack:  # depth-first, children in their order
            node, d = stack.pop()
            if node in depth:
                break
            depth[node] = d
            order.append(node)
            stack.extend((child, d + 1) for child in reversed(children[node]))
    if len(order) != len(children):
        step_x, step_y = GRAPH_STEP
        return [(step_x * (k % 4), step_y * (k // 4)) for k in range(len(ids))]
    x: dict[str, float] = {}
    leaves = 0
    for node in order:
        if not children[node]:
            x[node] = float(leaves)
            leaves += 1
    for node in reversed(order):  # children before their parent
        if children[node]:
            x[node] = float(np.mean([x[child] for child in children[node]]))
    root_x = x[roots[0]]
    step_x, step_y = GRAPH_STEP
    return [(step_x * (x[str(i)] - root_x), step_y * depth[str(i)]) for i in ids]


def graph_colour(module_type: str) -> tuple[int, int, int, int]:
    """A module type's colour for a graph label: its module colour, darkened where it is too
    light to read on the viewer's white graph background (the core's yellow)."""
    r, g, b, a = module_colours().get(module_type, _OTHER_COLOUR)
    brightness = (0.299 * r + 0.587 * g + 0.114 * b) / 255
    scale = min(1.0, 0.5 / brightness) if brightness else 1.0
    return round(r * scale), round(g * scale), round(b * scale), a


def graph_archetypes(graph_json: GraphJson) -> list[AsComponents]:
    rr = rerun_module()
    ids, types, edges = _graph_parts(graph_json)
    if not ids:
        return []
    return [
        rr.GraphNodes(
            ids,
            labels=module_labels(ids, types, graph_json),
            colors=[graph_colour(t) for t in types],
            positions=tree_positions(ids, edges),
            show_labels=True,
        ),
        rr.GraphEdges(edges, graph_type="directed"),
    ]


_GRAPHS: OrderedDict[str, Chunk | None] = OrderedDict()  # graph JSON -> its static /graph chunk


def _graph_chunk(graph_json: GraphJson) -> Chunk | None:
    """The static ``/graph`` chunk of a morphology (cached: a body's evaluations share it)."""
    key = graph_json if isinstance(graph_json, str) else json.dumps(graph_json, sort_keys=True)
    with _CACHE_LOCK:
        if key in _GRAPHS:
            _GRAPHS.move_to_end(key)
            return _GRAPHS[key]
    archetypes = graph_archetypes(graph_json)
    chunk = static_chunk("/graph", *archetypes) if archetypes else None
    with _CACHE_LOCK:
        _GRAPHS[key] = chunk
        while len(_GRAPHS) > 64:
            _GRAPHS.popitem(last=False)
    return chunk
