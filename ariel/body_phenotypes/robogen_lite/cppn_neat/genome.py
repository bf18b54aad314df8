"""A CPPN-NEAT genome (Stanley & Miikkulainen 2002; CPPNs: Stanley 2007), upstream's API.

Node genes (`Node`) and connection genes (`Connection`, keyed by innovation number). Structural
mutation adds a connection or splits one with a new hidden node; crossover lines genes up by
innovation number. `activate` runs the network (feed-forward in topological order; a genome
with a cycle is relaxed for ``len(nodes) + 1`` synchronous steps instead, as upstream).

Every random draw takes a keyword ``rng`` (a ``numpy.random.Generator`` or an int seed);
without one a seed is drawn from Python's ``random``, which upstream uses, so
``random.seed(...)`` in an upstream-style script still repeats a run. Inputs and outputs are
ordered by node id (upstream: by dict order, which crossover could shuffle).
"""

from __future__ import annotations

import random
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ariel.body_phenotypes.robogen_lite.cppn_neat.activations import (
    ACTIVATION_FUNCTIONS,
    DEFAULT_ACTIVATION,
)
from ariel.body_phenotypes.robogen_lite.cppn_neat.connection import Connection
from ariel.body_phenotypes.robogen_lite.cppn_neat.node import Node

__all__ = ["Genome"]

RngLike = np.random.Generator | int | None
Evaluator = Callable[[np.ndarray], np.ndarray]


def _rng(rng: RngLike) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng(random.getrandbits(64))
    return np.random.default_rng(rng)


class Genome:
    """A CPPN as NEAT genes: node genes and connection genes.

    The dicts are kept as given (not copied); `copy` makes an independent genome.

    Args:
        nodes: Node genes, ``{node id: Node}``.
        connections: Connection genes, ``{innovation id: Connection}``.
        fitness: The genome's fitness; `crossover` favours the fitter parent's genes.
        serialized: Stored as ``serialized`` and otherwise unused (upstream's signature).
    """

    def __init__(
        self,
        nodes: dict[int, Node],
        connections: dict[int, Connection],
        fitness: float = 0.0,
        serialized: dict | None = None,
    ) -> None:
        self.nodes = nodes
        self.connections = connections
        self.fitness = fitness
        self.serialized = serialized

    # ---- random genes ----------------------------------------------------------------------

    @staticmethod
    def _get_random_weight(rng: RngLike = None) -> float:
        return float(_rng(rng).uniform(-1.0, 1.0))

    @staticmethod
    def _get_random_bias(rng: RngLike = None) -> float:
        return float(_rng(rng).uniform(-1.0, 1.0))

    @staticmethod
    def _get_random_activation(rng: RngLike = None) -> str:
        names = list(ACTIVATION_FUNCTIONS)
        return names[int(_rng(rng).integers(len(names)))]

    @classmethod
    def random(
        cls,
        num_inputs: int,
        num_outputs: int,
        next_node_id: int = 0,
        next_innov_id: int = 0,
        *,
        rng: RngLike = None,
    ) -> Genome:
        """Inputs ``0..num_inputs-1``, outputs after them (sigmoid, random bias), every input
        connected to every output (random weights, innovations from ``next_innov_id``).

        ``next_node_id`` is accepted for upstream's signature; ids are fixed by the layout.
        """
        if int(num_inputs) < 1 or int(num_outputs) < 1:
            raise ValueError(
                f"a CPPN needs >= 1 input and >= 1 output, not {num_inputs}, {num_outputs}"
            )
        gen = _rng(rng)
        nodes = {i: Node(i, "input", None, 0.0) for i in range(num_inputs)}
        outputs = range(num_inputs, num_inputs + num_outputs)
        for o in outputs:
            nodes[o] = Node(o, "output", DEFAULT_ACTIVATION, cls._get_random_bias(gen))
        connections: dict[int, Connection] = {}
        innov = int(next_innov_id)
        for i in range(num_inputs):
            for o in outputs:
                connections[innov] = Connection(i, o, cls._get_random_weight(gen), True, innov)
                innov += 1
        return cls(nodes, connections, fitness=0.0)

    def copy(self) -> Genome:
        """A deep copy of the genes (the fitness too)."""
        return Genome(
            {k: n.copy() for k, n in self.nodes.items()},
            {k: c.copy() for k, c in self.connections.items()},
            self.fitness,
        )

    # ---- mutation --------------------------------------------------------------------------

    def mutate(
        self,
        node_add_rate: float,
        conn_add_rate: float,
        next_innov_id_getter: Callable[[], int],
        next_node_id_getter: Callable[[], int],
        *,
        rng: RngLike = None,
    ) -> None:
        """Structural mutation in place: add a connection with probability ``conn_add_rate``,
        then split a connection with a new node with probability ``node_add_rate``."""
        gen = _rng(rng)
        if gen.random() < conn_add_rate:
            self._mutate_add_connection(next_innov_id_getter, rng=gen)
        if gen.random() < node_add_rate:
            self._mutate_add_node(next_innov_id_getter, next_node_id_getter, rng=gen)

    def _creates_cycle(self, in_id: int, out_id: int) -> bool:
        """Whether a link ``in_id -> out_id`` would close a loop of enabled connections."""
        stack, seen = [out_id], set()
        while stack:
            node = stack.pop()
            if node == in_id:
                return True
            if node not in seen:
                seen.add(node)
                stack.extend(
                    c.out_id for c in self.connections.values() if c.enabled and c.in_id == node
                )
        return False

    def _mutate_add_connection(
        self,
        next_innov_id_getter: Callable[[], int],
        *,
        rng: RngLike = None,
        feed_forward: bool = False,
    ) -> bool:
        """Link two unlinked nodes (never into an input); True if a connection was added.

        ``feed_forward`` refuses links that close a cycle (upstream allows them).
        """
        gen = _rng(rng)
        ids = sorted(self.nodes)
        targets = [n for n in ids if self.nodes[n].typ != "input"]
        if len(ids) < 2 or not targets:
            return False
        out_id = targets[int(gen.integers(len(targets)))]
        sources = [n for n in ids if n != out_id]
        in_id = sources[int(gen.integers(len(sources)))]
        if any(c.in_id == in_id and c.out_id == out_id for c in self.connections.values()):
            return False
        if feed_forward and self._creates_cycle(in_id, out_id):
            return False
        weight = self._get_random_weight(gen)
        self.add_connection(Connection(in_id, out_id, weight, True, int(next_innov_id_getter())))
        return True

    def _mutate_add_node(
        self,
        next_innov_id_getter: Callable[[], int],
        next_node_id_getter: Callable[[], int],
        *,
        rng: RngLike = None,
    ) -> bool:
        """Split a random enabled connection ``a -> b`` into ``a -> new -> b`` (weights 1 and
        the old weight; the old link is disabled). True if a node was added."""
        gen = _rng(rng)
        enabled = [c for _, c in sorted(self.connections.items()) if c.enabled]
        if not enabled:
            return False
        split = enabled[int(gen.integers(len(enabled)))]
        node_id = int(next_node_id_getter())
        if node_id in self.nodes:
            return False
        split.enabled = False
        activation = self._get_random_activation(gen)
        self.add_node(Node(node_id, "hidden", activation, self._get_random_bias(gen)))
        self.add_connection(
            Connection(split.in_id, node_id, 1.0, True, int(next_innov_id_getter()))
        )
        self.add_connection(
            Connection(node_id, split.out_id, split.weight, True, int(next_innov_id_getter()))
        )
        return True

    def mutate_weights(self, rate: float = 0.8, std: float = 0.5, *, rng: RngLike = None) -> None:
        """Gaussian noise (``std``) on each connection weight and node bias with probability
        ``rate`` (ours: upstream's genome mutates structure only)."""
        gen = _rng(rng)
        for _, conn in sorted(self.connections.items()):
            if gen.random() < rate:
                conn.weight = float(conn.weight + gen.normal(0.0, std))
        for _, node in sorted(self.nodes.items()):
            if node.typ != "input" and gen.random() < rate:
                node.bias = float(node.bias + gen.normal(0.0, std))

    # ---- crossover -------------------------------------------------------------------------

    def crossover(
        self, other: Genome, is_maximisation: bool = True, *, rng: RngLike = None
    ) -> Genome:
        """A child genome: matching genes from either parent at random, disjoint and excess
        genes from the fitter parent (from both when equally fit). Input and output nodes are
        always kept. ``is_maximisation`` says which fitness is better."""
        gen = _rng(rng)
        a_better = (
            self.fitness >= other.fitness if is_maximisation else (self.fitness <= other.fitness)
        )
        fitter, weaker = (self, other) if a_better else (other, self)
        tie = self.fitness == other.fitness
        if tie and len(self.connections) < len(other.connections):
            fitter, weaker = other, self
        child_conns: dict[int, Connection] = {}
        for innov in sorted(set(fitter.connections) | set(weaker.connections)):
            a, b = fitter.connections.get(innov), weaker.connections.get(innov)
            if a is not None and b is not None:
                child_conns[innov] = (a if gen.random() < 0.5 else b).copy()
            elif a is not None:
                child_conns[innov] = a.copy()
            elif tie and b is not None:
                child_conns[innov] = b.copy()
        pool = {**weaker.nodes, **fitter.nodes}
        used = {n for c in child_conns.values() for n in (c.in_id, c.out_id)}
        used |= {n for n, node in pool.items() if node.typ in ("input", "output")}
        child_nodes = {n: pool[n].copy() for n in sorted(used) if n in pool}
        return Genome(child_nodes, child_conns, fitness=0.0)

    def add_connection(self, connection: Connection) -> None:
        if connection.innov_id in self.connections:
            raise ValueError(f"Connection with innovation {connection.innov_id} already exists")
        self.connections[connection.innov_id] = connection

    def add_node(self, node: Node) -> None:
        if node._id in self.nodes:
            raise ValueError(f"Node {node._id} already exists in genome")
        self.nodes[node._id] = node

    # ---- activation ------------------------------------------------------------------------

    def _ids(self, typ: str) -> list[int]:
        return sorted(n for n, node in self.nodes.items() if node.typ == typ)

    def get_node_ordering(self) -> list[int]:
        """Node ids in a topological order of the enabled connections (Kahn's algorithm);
        ``ValueError`` if they form a cycle."""
        indegree = dict.fromkeys(self.nodes, 0)
        successors: dict[int, list[int]] = {n: [] for n in self.nodes}
        for _, conn in sorted(self.connections.items()):
            if conn.enabled and conn.in_id in self.nodes and conn.out_id in self.nodes:
                successors[conn.in_id].append(conn.out_id)
                indegree[conn.out_id] += 1
        ready = [n for n in sorted(self.nodes) if indegree[n] == 0]
        order: list[int] = []
        while ready:
            node = ready.pop(0)
            order.append(node)
            for nxt in successors[node]:
                indegree[nxt] -= 1
                if indegree[nxt] == 0:
                    ready.append(nxt)
        if len(order) != len(self.nodes):
            raise ValueError("the genome's enabled connections form a cycle: no feed-forward order")
        return order

    def compile(self) -> Evaluator:
        """A function ``(B, num_inputs) -> (B, num_outputs)`` evaluating this network on a batch
        (a snapshot: later changes to the genome do not affect it).

        Feed-forward networks run layer by layer (a node's layer is one more than its deepest
        source's), one matrix product per layer, so a call costs a handful of numpy operations
        whatever the number of nodes.
        """
        ids = sorted(self.nodes)
        col = {n: i for i, n in enumerate(ids)}
        inputs, outputs = self._ids("input"), self._ids("output")
        weights = np.zeros((len(ids), len(ids)))
        sources: dict[int, list[int]] = {n: [] for n in ids}
        for _, conn in sorted(self.connections.items()):
            if conn.enabled and conn.in_id in col and conn.out_id in col:
                weights[col[conn.in_id], col[conn.out_id]] += conn.weight
                sources[conn.out_id].append(conn.in_id)
        bias = np.array([float(self.nodes[n].bias) for n in ids])
        in_cols, out_cols = [col[n] for n in inputs], [col[n] for n in outputs]
        try:
            order = self.get_node_ordering()
        except ValueError:
            order = None
        if order is not None:
            depth: dict[int, int] = {}
            for n in order:
                below = [depth[s] for s in sources[n]]
                depth[n] = 0 if self.nodes[n].typ == "input" else 1 + max(below, default=0)
            steps = [
                self._groups([n for n in ids if depth[n] == layer], col)
                for layer in range(1, max(depth.values(), default=0) + 1)
            ]
            sweeps = 1
        else:  # a cycle: every node from the previous sweep's values, len(nodes) + 1 times
            steps = [self._groups([n for n in ids if self.nodes[n].typ != "input"], col)]
            sweeps = len(ids) + 1

        # Each group's weight columns and biases, gathered once here rather than per call (the
        # same arrays, so the same products and sums on every call).
        layers = [[(c, weights[:, c], bias[c], act) for c, act in groups] for groups in steps]

        def evaluate(batch: np.ndarray) -> np.ndarray:
            x = np.asarray(batch, dtype=np.float64)
            if x.ndim != 2 or x.shape[1] != len(in_cols):
                raise ValueError(f"expected inputs of shape (B, {len(in_cols)}), got {x.shape}")
            values = np.zeros((x.shape[0], len(ids)))
            values[:, in_cols] = x
            for _ in range(sweeps):
                for groups in layers:
                    previous = values.copy() if sweeps > 1 else values
                    for cols, w, b, act in groups:
                        values[:, cols] = act(previous @ w + b)
            return values[:, out_cols]

        return evaluate

    def _groups(
        self, nodes: list[int], col: dict[int, int]
    ) -> list[tuple[np.ndarray, Callable[[Any], np.ndarray]]]:
        """``nodes`` grouped by activation: (column indices, function) per activation."""
        by_name: dict[str, list[int]] = {}
        for n in nodes:
            by_name.setdefault(self.nodes[n].activation or DEFAULT_ACTIVATION, []).append(col[n])
        return [(np.array(c), ACTIVATION_FUNCTIONS[name]) for name, c in by_name.items()]

    def activate(self, inputs: Sequence[float]) -> list[float]:
        """The outputs (in node-id order) for one input vector."""
        n_in = len(self._ids("input"))
        if len(inputs) != n_in:
            raise ValueError(f"Expected {n_in} inputs, got {len(inputs)}")
        return [float(v) for v in self.compile()(np.asarray([inputs], dtype=np.float64))[0]]

    # ---- plain data ------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data: ``{"nodes": {"0": {"_id", "typ", "activation", "bias"}, ...},
        "connections": [{"in_id", "out_id", "weight", "enabled", "innov_id"}, ...]}``."""
        return {
            "nodes": {
                str(k): {"_id": n._id, "typ": n.typ, "activation": n.activation, "bias": n.bias}
                for k, n in sorted(self.nodes.items())
            },
            "connections": [
                {
                    "in_id": c.in_id,
                    "out_id": c.out_id,
                    "weight": c.weight,
                    "enabled": c.enabled,
                    "innov_id": c.innov_id,
                }
                for _, c in sorted(self.connections.items())
            ],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], fitness: float = 0.0) -> Genome:
        """Inverse of `to_dict` (upstream ignored ``fitness`` here; it is kept)."""
        try:
            nodes = {
                int(k): Node(int(v["_id"]), v["typ"], v["activation"], float(v["bias"]))
                for k, v in data["nodes"].items()
            }
            conns = [
                Connection(
                    int(c["in_id"]),
                    int(c["out_id"]),
                    float(c["weight"]),
                    bool(c["enabled"]),
                    int(c["innov_id"]),
                )
                for c in data["connections"]
            ]
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ValueError(
                f"not a CPPN genome dict (as Genome.to_dict() writes): {exc!r}"
            ) from None
        for node in nodes.values():
            if node.typ not in ("input", "hidden", "output"):
                raise ValueError(
                    f"node {node._id} has type {node.typ!r}; allowed: input, hidden, output"
                )
            if node.typ != "input" and node.activation not in ACTIVATION_FUNCTIONS:
                raise ValueError(
                    f"node {node._id} has activation {node.activation!r}; "
                    f"allowed: {', '.join(ACTIVATION_FUNCTIONS)}"
                )
        return cls(nodes, {c.innov_id: c for c in conns}, fitness=fitness)

    def __repr__(self) -> str:
        hidden = len(self._ids("hidden"))
        links = len(self.connections)
        return f"Genome({len(self.nodes)} nodes ({hidden} hidden), {links} connections)"
