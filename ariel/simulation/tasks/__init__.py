"""Fitness helpers (plain numpy): gait learning, targeted locomotion, turning in place.

``tasks`` lists the task names (upstream spelling kept) and ``TASK_FUNCTIONS`` maps each to
its helpers.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ariel.simulation.tasks import gait_learning, targeted_locomotion, turning_in_place
from ariel.simulation.tasks.gait_learning import x_speed, xy_displacement, y_speed
from ariel.simulation.tasks.targeted_locomotion import distance_to_target
from ariel.simulation.tasks.turning_in_place import turning_in_place as turning_in_place_fitness

__all__ = [
    "TASK_FUNCTIONS",
    "gait_learning",
    "targeted_locomotion",
    "tasks",
    "turning_in_place",
]

tasks: list[str] = ["Gate Learning", "Targeted Locomotion", "Turning In Place"]

TASK_FUNCTIONS: dict[str, list[Callable[..., Any]]] = {
    "Gate Learning": [xy_displacement, x_speed, y_speed],
    "Targeted Locomotion": [distance_to_target],
    "Turning In Place": [turning_in_place_fitness],
}
