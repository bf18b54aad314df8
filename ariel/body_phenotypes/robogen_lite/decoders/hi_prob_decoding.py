"""High-probability decoder: NDE probability matrices -> robot graph (a tree rooted at the core).

Greedy, as in upstream ARIEL: every module takes its most probable type and rotation, then
modules are attached one at a time by the globally most probable (parent, child, face) among
instantiated parents, free faces and unattached children, until nothing positive is left.

`probability_matrices_to_graph` runs upstream's four steps, which are public as upstream has
them (its scripts and tests call them one by one on ``conn_p_space``, ``type_p_space`` and
``rot_p_space``): `apply_connection_constraints`, `set_module_types_and_rotations`,
`decode_probability_to_graph` and `generate_networkx_graph`.
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
    Blueprint,
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

# Enum members by value, so the hot path avoids Enum lookups.
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


class _GreedyDecoder(Blueprint):
    """Upstream's decoding steps on ``type_p_space`` (N, 4), ``conn_p_space`` (N, N, 6) and
    ``rot_p_space`` (N, 3), shared by `HighProbabilityDecoder` and ``VectorDecoder``.

    The steps work in place on those attributes, as upstream's do; the ``*_to_graph`` entry
    points set them to checked float64 copies of their inputs first, so inputs are never
    mutated.
    """

    #: The entry point named in the error of a step called before its spaces are set.
    _ENTRY = "probability_matrices_to_graph"

    def __init__(self, num_modules: int) -> None:
        if isinstance(num_modules, bool) or not isinstance(num_modules, (int, np.integer)):
            msg = f"num_modules must be an int >= 1; got {type(num_modules).__name__}"
            raise TypeError(msg)
        if num_modules < 1:
            msg = f"num_modules must be >= 1; got {num_modules}"
            raise ValueError(msg)
        super().__init__(int(num_modules))
        self.type_p_space: Any = None
        self.conn_p_space: Any = None
        self.rot_p_space: Any = None

    def _set_spaces(self, type_p: np.ndarray, conn_p: np.ndarray, rot_p: np.ndarray) -> None:
        self.type_p_space, self.conn_p_space, self.rot_p_space = type_p, conn_p, rot_p
        self._graph = {}
        self.graph = nx.DiGraph()

    def _space(self, name: str) -> np.ndarray:
        """The attribute ``name`` as a float array of its shape (stored back, so in-place
        changes show); a one-line ``ValueError`` when it is unset or misshapen."""
        n = self.num_modules
        shape = {
            "type_p_space": (n, NUM_OF_TYPES_OF_MODULES),
            "conn_p_space": (n, n, NUM_OF_FACES),
            "rot_p_space": (n, NUM_OF_ROTATIONS),
        }[name]
        value = getattr(self, name)
        if value is None:
            msg = (
                f"{name} is not set: assign type_p_space, conn_p_space and rot_p_space "
                f"(or call {self._ENTRY}) first"
            )
            raise ValueError(msg)
        arr = np.asarray(value)
        if arr.dtype.kind != "f":
            arr = arr.astype(np.float64)
        if arr.shape != shape:
            msg = f"{name} must have shape {shape} (num_modules={n}); got {arr.shape}"
            raise ValueError(msg)
        setattr(self, name, arr)
        return arr

    def apply_connection_constraints(self) -> None:
        """No module connects to itself; module 0 is the only CORE and is never a child."""
        conn_p = self._space("conn_p_space")
        type_p = self._space("type_p_space")
        idx = np.arange(self.num_modules)
        conn_p[idx, idx, :] = 0.0
        conn_p[:, IDX_OF_CORE, :] = 0.0
        type_p[:, ModuleType.CORE.value] = 0.0
        type_p[IDX_OF_CORE, ModuleType.CORE.value] = 1.0

    def set_module_types_and_rotations(self) -> None:
        """Fill ``type_dict`` and ``rot_dict`` with each module's most probable type and
        allowed rotation (ties: the lowest value). NONE modules lose every connection, and a
        module keeps parent connections only on the faces its type allows."""
        conn_p = self._space("conn_p_space")
        type_p = self._space("type_p_space")
        rot_p = self._space("rot_p_space")
        types = np.argmax(type_p, axis=1)
        is_none = types == ModuleType.NONE.value
        conn_p[is_none, :, :] = 0.0
        conn_p[:, is_none, :] = 0.0
        face_ok = np.broadcast_to(_ALLOWED_FACE_TABLE[types][:, None, :], conn_p.shape)
        np.putmask(conn_p, ~face_ok, 0.0)
        np.putmask(rot_p, ~_ALLOWED_ROT_TABLE[types], 0.0)
        rotations = np.argmax(rot_p, axis=1)
        self.type_dict = {i: _TYPES[t] for i, t in enumerate(types.tolist())}
        self.rot_dict = {i: _ROTS[r] for i, r in enumerate(rotations.tolist())}

    def _grow(self) -> None:
        """Upstream's greedy growth over ``conn_p_space`` (consumed in place); fills ``nodes``
        and ``edges`` (in decoding order, faces as ``ModuleFaces``)."""
        n = self.num_modules
        conn_p = self._space("conn_p_space")
        if len(self.type_dict) != n:
            msg = "type_dict is not set: call set_module_types_and_rotations first"
            raise ValueError(msg)
        none_list = [self.type_dict[i] is ModuleType.NONE for i in range(n)]

        # `active` equals conn_p on the rows of instantiated parents and 0 elsewhere
        # (upstream's conn * available), maintained incrementally.
        instantiated = np.zeros(n, dtype=bool)
        instantiated[IDX_OF_CORE] = True
        active = np.zeros_like(conn_p)
        active[IDX_OF_CORE] = conn_p[IDX_OF_CORE]
        edges: list[tuple[int, int, ModuleFaces]] = []
        row = n * NUM_OF_FACES
        for _ in range(none_list.count(False)):
            flat = int(active.argmax())  # C order, ties -> first
            if not active.flat[flat] > 0.0:
                break
            parent, rest = divmod(flat, row)
            child, face = divmod(rest, NUM_OF_FACES)
            # apply_connection_constraints and set_module_types_and_rotations rule these out.
            if child in (IDX_OF_CORE, parent) or none_list[child] or none_list[parent]:
                msg = (
                    f"decoder picked an invalid edge ({parent} -> {child}, face {face}); "
                    "call apply_connection_constraints and set_module_types_and_rotations first"
                )
                raise ValueError(msg)
            edges.append((parent, child, _FACES[face]))
            instantiated[child] = True
            conn_p[parent, :, face] = 0.0  # the face is now occupied
            active[parent, :, face] = 0.0
            conn_p[:, child, :] = 0.0  # a child has exactly one parent
            active[:, child, :] = 0.0
            active[child] = conn_p[child]  # the new module may now act as a parent

        self.nodes = {i for i in np.flatnonzero(instantiated).tolist() if not none_list[i]}
        self.edges = edges


class HighProbabilityDecoder(_GreedyDecoder):
    """Greedy decoder from NDE probability matrices to a `networkx.DiGraph` robot tree.

    Node ids are the module indices (gaps allowed); node attributes `type` ("CORE", "BRICK",
    "HINGE") and `rotation` ("DEG_0", "DEG_45", "DEG_90"); edge attribute `face` ("FRONT",
    ...). NONE modules and modules that cannot be reached are dropped; node 0 is the core.
    """

    def probability_matrices_to_graph(
        self,
        type_probability_space: Any,
        connection_probability_space: Any,
        rotation_probability_space: Any,
    ) -> nx.DiGraph:
        """Decode (N, 4) type, (N, N, 6) connection and (N, 3) rotation matrices to a tree."""
        n = self.num_modules
        self._set_spaces(
            _as_probability_array(
                "type_probability_space", type_probability_space, (n, NUM_OF_TYPES_OF_MODULES)
            ),
            _as_probability_array(
                "connection_probability_space", connection_probability_space, (n, n, NUM_OF_FACES)
            ),
            _as_probability_array(
                "rotation_probability_space", rotation_probability_space, (n, NUM_OF_ROTATIONS)
            ),
        )
        self.apply_connection_constraints()
        self.set_module_types_and_rotations()
        self.decode_probability_to_graph()
        self.generate_networkx_graph()
        return self.graph

    def decode_probability_to_graph(self) -> None:
        """Grow the tree over ``conn_p_space`` (after the two constraint steps): fills
        ``nodes`` and ``edges``."""
        self._grow()
