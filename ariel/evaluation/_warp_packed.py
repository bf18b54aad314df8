"""Which brain batches of a Warp call share a packed model, and their device inputs.

Open-loop groups (one body's batch each) whose controller has a device kernel, whose world and
body can be packed (`ariel.evaluation._warp_pack.packable`) and whose controller options and
timing agree are packed together, at most `MAX_ROBOTS` bodies per model, when there are two or
more of them; the rest run alone. World ``w`` of a packed model holds task ``w`` of every
group; a group with fewer tasks than the largest fills its worlds with copies of its last task
(their results are dropped).
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ariel.evaluation._engine import TaskGroup
from ariel.evaluation._task import EvaluationTask
from ariel.evaluation._warp_cpg import CPGInputs, cpg_inputs, device_cpg_reason, net_inputs
from ariel.evaluation._warp_pack import (
    MAX_ROBOTS,
    PackedModel,
    _body_reason,
    _world_key,
    _world_reason,
)

if TYPE_CHECKING:
    from ariel.evaluation.builtin_plugins import NaCPGController

__all__ = ["RobotView", "pack_plan", "packed_inputs", "robot_views"]


def _unpackable(group: TaskGroup) -> str | None:
    """Why an open-loop group cannot share a model with other bodies; None if it can."""
    head = group.tasks[0]
    reason = device_cpg_reason(group.controller)
    return reason or _world_reason(_world_key(head)) or _body_reason(group.built)


def _pack_key(group: TaskGroup) -> str:
    """Groups of one key may share a packed model."""
    head = group.tasks[0]
    timing = [head.duration, head.control_period, head.smoothing, head.record_every]
    controller = [head.controller, head.controller_options]
    return json.dumps([head.world, head.world_options, *controller, *timing, head.record_bodies])


def pack_plan(
    groups: Sequence[TaskGroup],
) -> tuple[list[TaskGroup], list[list[TaskGroup]], dict[str, int]]:
    """``(alone, packs, reasons)``: groups that run alone, lists of groups packed together,
    and why open-loop groups could not be packed (reason -> groups), when a call holds
    several bodies' open-loop batches."""
    alone: list[TaskGroup] = []
    by_key: dict[str, list[TaskGroup]] = {}
    reasons: dict[str, int] = {}
    several = sum(g.controller.open_loop for g in groups) > 1
    for group in groups:
        reason = _unpackable(group) if group.controller.open_loop else "closed loop"
        if reason is None:
            by_key.setdefault(_pack_key(group), []).append(group)
            continue
        alone.append(group)
        if several and group.controller.open_loop:
            reasons[reason] = reasons.get(reason, 0) + 1
    packs: list[list[TaskGroup]] = []
    for together in by_key.values():
        if len(together) < 2:
            alone.extend(together)
            continue
        models = math.ceil(len(together) / MAX_ROBOTS)  # as few models as bits allow, even sizes
        bounds = np.linspace(0, len(together), models + 1).round().astype(int).tolist()
        packs.extend(together[a:b] for a, b in itertools.pairwise(bounds))
    return alone, packs, reasons


def packed_inputs(
    pieces: Sequence[Sequence[EvaluationTask]],
    packed: PackedModel,
    controller: NaCPGController,
    call_times: np.ndarray,
) -> CPGInputs:
    """The device CPG's inputs: robot ``k`` of world ``w`` runs ``pieces[k][w]`` (padded)."""
    nworld = max(len(tasks) for tasks in pieces)
    nets = []
    for tasks, robot in zip(pieces, packed.robots, strict=True):
        padded = list(tasks) + [tasks[-1]] * (nworld - len(tasks))
        params, state = net_inputs(padded, robot.built.model, controller)
        nets.append((robot.ctrl.start, params, state))
    return cpg_inputs(controller, nets, call_times)


@dataclass(frozen=True)
class RobotView:
    """One robot's part of a model's frames: its qpos, qvel, controls, core and bodies."""

    qpos: slice
    qvel: slice
    ctrl: slice
    core: int
    bodies: slice

    @classmethod
    def lone(cls) -> RobotView:
        """The whole of a one-robot model's frames."""
        every = slice(None)
        return cls(every, every, every, 0, every)


def robot_views(packed: PackedModel) -> list[RobotView]:
    """Each robot's `RobotView` of a packed model's frames (bodies in the layout's order)."""
    views, start = [], 0
    for k, robot in enumerate(packed.robots):
        n = len(robot.robot_bodies)
        views.append(RobotView(robot.qpos, robot.qvel, robot.ctrl, k, slice(start, start + n)))
        start += n
    return views
