"""What a run is between generations, as plain data: bodies, the loop's counters, the body
optimizer's state and a brain-only run's brain run (its learner's state).

A checkpoint is this state as JSON (`state_to_plain` / `state_from_plain`): no pickle, so
loading a run folder never runs code from it. Floats round-trip exactly (Python writes the
shortest text that reads back to the same double); NaN and infinities, which JSON lacks, are
written as ``{"$float": "nan"}`` and read back. A brain run is stored as its settings, its
best and its learner's plain-data state (`BrainRun.to_plain`) and rebuilt from them; the
built-in learners store what they were told and tell a fresh learner the same again, which
gives the same state bit for bit.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from ariel.evolution._brain import BrainRun
from ariel.utils import replace_non_finite

__all__ = [
    "BodiesSeen",
    "Body",
    "LoopState",
    "from_json_safe",
    "state_from_plain",
    "state_to_plain",
    "to_json_safe",
]


@dataclass
class Body:
    """One body: identity, genotype (plain data), lineage and its learned brain.

    Attributes:
        number: The body's number, in order of birth (its id is ``body_id``, e.g.
            ``"b000012"`` for 12).
        genotype: The genotype, as plain data.
        parent_ids: The ids of the bodies it was bred from; empty for a random genotype.
        born: The generation it was born in.
        status: ``"ok"``, or ``"error"`` when the genotype gives no buildable body.
        error: Why the body could not be built (the first line of the error); ``""`` when
            ``status`` is ``"ok"``.
        n_params: The number of controller parameters (0 for a body without actuators).
        n_joints: The number of actuated joints.
        joint_names: The names of the actuated joints, in control order.
        descriptors: The morphology descriptors (e.g. ``num_limbs``, ``joints_ratio``).
        graph: The decoded robot graph as node-link JSON; ``""`` for a body without a graph
            form (some prebuilt bodies) or one that could not be built.
        fitness: The fitness of its best evaluation so far; NaN before its first finite one
            (a failed body gets the worst fitness).
        best_params: The controller parameters of that best evaluation; None before one.
        best_eval_id: The id of that best evaluation, e.g. ``"b000012-i003-c005"``; ``""``
            before one.
        evaluations: How many evaluations the body has had.
    """

    number: int
    genotype: object
    parent_ids: list[str]
    born: int
    status: str = "ok"  # "error": the genotype gives no buildable body
    error: str = ""
    n_params: int = 0
    n_joints: int = 0
    joint_names: list[str] = field(default_factory=list)
    descriptors: dict[str, float] = field(default_factory=dict)
    graph: str = ""
    fitness: float = math.nan
    best_params: list[float] | None = None
    best_eval_id: str = ""
    evaluations: int = 0

    @property
    def body_id(self) -> str:
        return f"b{self.number:06d}"


def body_fields(bodies: list[Body]) -> list[dict[str, str]]:
    """Each body's fields as JSON text (NaN equal to NaN), for `changed_field`."""
    return [
        {
            f.name: json.dumps(getattr(body, f.name), sort_keys=True, default=repr)
            for f in fields(body)
        }
        for body in bodies
    ]


class BodiesSeen:
    """``bodies`` as a body optimizer is handed them (`body_fields`): `unchanged` after its
    call says whether it wrote to them, as it may not (the records are written from them)."""

    def __init__(self, bodies: list[Body]) -> None:
        self.bodies, self.before = list(bodies), body_fields(bodies)

    def changed(self) -> str | None:
        """The first field written to since (`changed_field`), or None."""
        return changed_field(self.bodies, self.before)

    def unchanged(self, call: str) -> None:
        """ValueError naming the first field ``call`` (and ``state()``) changed, if any."""
        changed = self.changed()
        if changed is not None:
            raise ValueError(f"{call} changed {changed}; it may read the bodies, not write")


def changed_field(bodies: list[Body], before: list[dict[str, str]]) -> str | None:
    """The first field of ``bodies`` that differs from ``before`` (`body_fields` of them),
    e.g. ``"b000004's fitness (0.0003 -> 999.0)"``, or None. A body optimizer's ``tell``
    reads the bodies it is told about; one that wrote to them would change the records."""
    for body, was in zip(bodies, before, strict=True):
        now = body_fields([body])[0]
        for name, text in now.items():
            if text != was[name]:
                old, new = json.loads(was[name]), json.loads(text)
                if isinstance(old, dict) and isinstance(new, dict):  # name the key that differs
                    key = next(k for k in sorted({*old, *new}) if old.get(k) != new.get(k))
                    name, old, new = f"{name}[{key!r}]", old.get(key), new.get(key)
                return f"{body.body_id}'s {name} ({str(old)[:40]} -> {str(new)[:40]})"
    return None


@dataclass
class LoopState:
    """Everything resume needs. RNG states are not stored: each draw's stream is derived."""

    config_hash: str
    generation: int  # the last finished generation
    next_body: int
    population: list[Body]  # what the body optimizer keeps (GA survivors, archive elites)
    brain: BrainRun | None = None  # brain-only: the run that goes on across generations
    evaluations_done: int = 0  # rows in the evaluations table
    budget_done: int = 0  # progress: evaluations run or skipped (failed bodies)
    wall_seconds: float = 0.0
    # the body optimizer's own state (`BodyOptimizer.state`)
    optimizer: Mapping[str, object] = field(default_factory=dict)


def to_json_safe(value: object) -> Any:
    """``value`` with every non-finite float as ``{"$float": text}`` (JSON has no NaN)."""
    return replace_non_finite(value, lambda x: {"$float": repr(x)})


def from_json_safe(value: object) -> Any:
    """The inverse of `to_json_safe`."""
    if isinstance(value, dict):
        if set(value) == {"$float"}:
            return float(value["$float"])
        return {key: from_json_safe(item) for key, item in value.items()}
    if isinstance(value, list):
        return [from_json_safe(item) for item in value]
    return value


def state_to_plain(state: LoopState) -> dict[str, Any]:
    """``state`` as JSON-able data (see the module docstring)."""
    plain = {f.name: getattr(state, f.name) for f in fields(LoopState)}
    plain["population"] = [
        {f.name: getattr(b, f.name) for f in fields(Body)} for b in state.population
    ]
    plain["brain"] = None if state.brain is None else state.brain.to_plain()
    return to_json_safe(plain)


def state_from_plain(data: object) -> LoopState:
    """A `LoopState` from `state_to_plain`'s data; `ValueError` (one line) for anything else."""
    try:
        plain = from_json_safe(data)
        population = [Body(**body) for body in plain.pop("population")]
        brain = plain.pop("brain")
        return LoopState(
            population=population,
            brain=None if brain is None else BrainRun.from_plain(brain),
            **plain,
        )
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"not a loop state ({type(exc).__name__}: {exc})") from None
