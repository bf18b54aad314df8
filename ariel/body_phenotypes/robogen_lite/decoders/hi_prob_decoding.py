"""High-probability decoder: NDE probability matrices -> robot graph (a tree rooted at the core).

Greedy, as in upstream ARIEL: every module takes its most probable type and rotation, then
modules are attached one at a time by the globally most probable (parent, child, face) among
instantiated parents, free faces and unattached children, until nothing positive is left.
"""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.config import (
    ALLOWED_FACES,
    ALLOWED_ROTATIONS,
    IDX_OF_CORE,
    NUM_OF_FACES,
    NUM_OF_ROTATIONS,
    NUM_OF_TYPES_OF_MODULES,
    ModuleFaces,
    ModuleRotationsIdx,
    ModuleType,
)
from ariel.body_phenotypes.robogen_lite.decoders._blueprint import (
    draw_graph,
    load_graph_from_json,
    save_graph_as_json,
)

# The graph file helpers are importable from here too: course material imports them so.
__all__ = ["HighProbabilityDecoder", "draw_graph", "load_graph_from_json", "save_graph_as_json"]

# Lookup tables indexed by ModuleType value: which faces / rotations each type may use.
_ALLOWED_FACE_TABLE = np.zeros((NUM_OF_TYPES_OF_MODULES, NUM_OF_FACES), dtype=bool)
_ALLOWED_ROT_TABLE = np.zeros((NUM_OF_TYPES_OF_MODULES, NUM_OF_ROTATIONS), dtype=bool)
for _type, _faces in ALLOWED_FACES.items():
    _ALLOWED_FACE_TABLE[_type.value, [f.value for f in _faces]] = True
for _type, _rots in ALLOWED_ROTATIONS.items():
    _ALLOWED_ROT_TABLE[_type.value, [r.value for r in _rots]] = True
del _type, _faces, _rots

# Enum members and names by value, so the hot path avoids Enum lookups.
_TYPES = list(ModuleType)
_ROTS = list(ModuleRotationsIdx)
_FACES = list(ModuleFaces)


def _as_probability_array(name: str, value: Any, expected: tuple[int, ...]) -> np.ndarray:
    """Copy `value` into a float64 array after checking shape and values (one-line errors)."""
    if hasattr(value, "detach") and hasattr(value, "cpu"):  # torch tensor, without torch
        value = value.detach().cpu().numpy()
    try:
        arr = np.array(value, dtype=np.float64)  # always a copy: inputs are never mutated
    except (ValueError, TypeError) as exc:
        msg = f"{name} must be a numeric array of shape {expected}: {exc}"
        raise ValueError(msg) from None
    if arr.shape != expected:
        msg = f"{name} must have shape {expected} (num_modules={expected[0]}); got {arr.shape}"
        raise ValueError(msg)
    if not np.all(np.isfinite(arr)):
        msg = f"{name} contains NaN or inf values"
        raise ValueError(msg)
    if arr.size and (arr.min() < 0.0 or arr.max() > 1.0):
        msg = f"{name} values must lie in [0, 1]; got range [{arr.min():.6g}, {arr.max():.6g}]"
        raise ValueError(msg)
    return arr


class HighProbabilityDecoder:
    """Greedy decoder from NDE probability matrices to a `networkx.DiGraph` robot tree.

    Node ids are the module indices (gaps allowed); node attributes `type` ("CORE", "BRICK",
    "HINGE") and `rotation` ("DEG_0", "DEG_45", "DEG_90"); edge attribute `face` ("FRONT",
    ...). NONE modules and modules that cannot be reached are dropped; node 0 is the core.
    """

    def __init__(self, num_modules: int) -> None:
        if isinstance(num_modules, bool) or not isinstance(num_modules, (int, np.integer)):
            msg = f"num_modules must be an int >= 1; got {type(num_modules).__name__}"
            raise TypeError(msg)
        if num_modules < 1:
            msg = f"num_modules must be >= 1; got {num_modules}"
            raise ValueError(msg)
        self.num_modules = int(num_modules)
        self._graph: dict[int, Any] = {}
        self.graph = nx.DiGraph()
        self.type_dict: dict[int, ModuleType] = {}
        self.rot_dict: dict[int, ModuleRotationsIdx] = {}
        self.nodes: set[int] = set()
        self.edges: list[tuple[int, int, ModuleFaces]] = []

    def probability_matrices_to_graph(
        self,
        type_probability_space: Any,
        connection_probability_space: Any,
        rotation_probability_space: Any,
    ) -> nx.DiGraph:
        """Decode (N, 4) type, (N, N, 6) connection and (N, 3) rotation matrices to a tree."""
        n = self.num_modules
        type_p = _as_probability_array(
            "type_probability_space", type_probability_space, (n, NUM_OF_TYPES_OF_MODULES)
        )
        conn_p = _as_probability_array(
            "connection_probability_space", connection_probability_space, (n, n, NUM_OF_FACES)
        )
        rot_p = _as_probability_array(
            "rotation_probability_space", rotation_probability_space, (n, NUM_OF_ROTATIONS)
        )
        self._graph = {}
        self.graph = nx.DiGraph()

        # Constraints: no self-connection; the core is module 0 only and is never a child.
        idx = np.arange(n)
        conn_p[idx, idx, :] = 0.0
        type_p[:, ModuleType.CORE.value] = 0.0
        type_p[IDX_OF_CORE, ModuleType.CORE.value] = 1.0
        conn_p[:, IDX_OF_CORE, :] = 0.0

        # Most probable type (ties -> lowest index); NONE modules take no part.
        types = np.argmax(type_p, axis=1)
        is_none = types == ModuleType.NONE.value
        conn_p[is_none, :, :] = 0.0
        conn_p[:, is_none, :] = 0.0
        # A module may only be a parent through the faces its type allows.
        conn_p = np.where(_ALLOWED_FACE_TABLE[types][:, None, :], conn_p, 0.0)
        rot_p = np.where(_ALLOWED_ROT_TABLE[types], rot_p, 0.0)
        rotations = np.argmax(rot_p, axis=1)

        types_list = types.tolist()
        rotations_list = rotations.tolist()
        self.type_dict = {i: _TYPES[t] for i, t in enumerate(types_list)}
        self.rot_dict = {i: _ROTS[r] for i, r in enumerate(rotations_list)}

        # Greedy growth. `active` equals conn_p on the rows of instantiated parents and 0
        # elsewhere (upstream's conn * available), maintained incrementally.
        none_list = is_none.tolist()
        num_candidates = none_list.count(False)
        instantiated = np.zeros(n, dtype=bool)
        instantiated[IDX_OF_CORE] = True
        active = np.zeros_like(conn_p)
        active[IDX_OF_CORE] = conn_p[IDX_OF_CORE]
        edges: list[tuple[int, int, ModuleFaces]] = []
        row = n * NUM_OF_FACES
        for _ in range(num_candidates):
            flat = int(active.argmax())  # C order, ties -> first
            if active.flat[flat] == 0.0:
                break
            parent, rest = divmod(flat, row)
            child, face = divmod(rest, NUM_OF_FACES)
            # Sanity checks; the constraints above make these impossible.
            if child == IDX_OF_CORE or none_list[child] or none_list[parent]:
                msg = f"decoder picked an invalid edge ({parent} -> {child}, face {face})"
                raise ValueError(msg)
            edges.append((parent, child, _FACES[face]))
            instantiated[child] = True
            conn_p[parent, :, face] = 0.0  # the face is now occupied
            active[parent, :, face] = 0.0
            conn_p[:, child, :] = 0.0  # a child has exactly one parent
            active[:, child, :] = 0.0
            active[child] = conn_p[child]  # the new module may now act as a parent

        self.type_p_space = type_p
        self.conn_p_space = conn_p
        self.rot_p_space = rot_p
        self.nodes = {int(i) for i in np.flatnonzero(instantiated)}
        self.edges = edges

        graph = self.graph
        for i in sorted(self.nodes):
            graph.add_node(
                i, type=_TYPES[types_list[i]].name, rotation=_ROTS[rotations_list[i]].name
            )
        for parent, child, face in edges:
            graph.add_edge(parent, child, face=face.name)
        return graph
