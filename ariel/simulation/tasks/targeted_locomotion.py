"""Fitness helpers for reaching a target. All are to be MINIMISED (lower is better).

Distances are planar (x, y); positions may carry a z coordinate, which is ignored.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ariel.simulation.tasks.gait_learning import xy_displacement
from ariel.utils import accept_aliases

__all__ = [
    "SURVIVAL_MIN_HEIGHT",
    "SURVIVAL_PENALTY",
    "distance_to_target",
    "fitness_delta_distance",
    "fitness_direct_path",
    "fitness_distance_and_efficiency",
    "fitness_speed_to_target",
    "fitness_survival_and_locomotion",
]

SURVIVAL_MIN_HEIGHT = 0.05
"""Core height (m) below which ``fitness_survival_and_locomotion`` counts the robot as fallen."""

# Upstream's keyword names: ``initial_pos`` / ``final_pos`` / ``target_pos`` in the fitness
# functions, and ``initial_position`` for the first argument of ``distance_to_target``.
_POSITIONS = {
    "initial_pos": "initial_position",
    "final_pos": "final_position",
    "target_pos": "target_position",
}
SURVIVAL_PENALTY = 10.0
"""Fitness of a fallen robot in ``fitness_survival_and_locomotion``."""


@accept_aliases(
    initial_position="final_position", final_pos="final_position", target_pos="target_position"
)
def distance_to_target(final_position: ArrayLike, target_position: ArrayLike) -> float:
    """Planar distance from the final position to the target.

    Upstream names the first argument ``initial_position``; that keyword (and ``final_pos`` /
    ``target_pos``) is accepted too.

    Args:
        final_position: the robot's position, ``(x, y)`` or ``(x, y, z)``, in metres.
        target_position: the target's position, in the same form.

    Returns:
        The distance in metres (lower is better).
    """
    return xy_displacement(final_position, target_position)


@accept_aliases(**_POSITIONS)
def fitness_delta_distance(
    initial_position: ArrayLike, final_position: ArrayLike, target_position: ArrayLike
) -> float:
    """Final minus initial distance to the target (negative = progress).

    Upstream's keywords ``initial_pos`` / ``final_pos`` / ``target_pos`` are accepted too.

    Args:
        initial_position: the robot's start position, ``(x, y)`` or ``(x, y, z)``, in metres.
        final_position: the robot's end position, in the same form.
        target_position: the target's position, in the same form.

    Returns:
        The change of distance in metres (lower is better).
    """
    return distance_to_target(final_position, target_position) - distance_to_target(
        initial_position, target_position
    )


@accept_aliases(**_POSITIONS)
def fitness_distance_and_efficiency(
    initial_position: ArrayLike,
    final_position: ArrayLike,
    target_position: ArrayLike,
    total_control_effort: float,
) -> float:
    """``fitness_delta_distance + 0.001 * total_control_effort``.

    Upstream's keywords ``initial_pos`` / ``final_pos`` / ``target_pos`` are accepted too.

    Args:
        initial_position: the robot's start position, ``(x, y)`` or ``(x, y, z)``, in metres.
        final_position: the robot's end position, in the same form.
        target_position: the target's position, in the same form.
        total_control_effort: the controller's effort over the run, however the caller
            measures it (e.g. the sum of absolute controls).

    Returns:
        The penalised change of distance (lower is better).
    """
    delta = fitness_delta_distance(initial_position, final_position, target_position)
    return delta + 0.001 * float(total_control_effort)


@accept_aliases(**_POSITIONS)
def fitness_survival_and_locomotion(
    initial_position: ArrayLike,
    final_position: ArrayLike,
    target_position: ArrayLike,
    min_z_height: float,
) -> float:
    """``10.0`` if the core ever went below 0.05 m (fell), else ``fitness_delta_distance``.

    The threshold and the penalty are `SURVIVAL_MIN_HEIGHT` and `SURVIVAL_PENALTY`. Upstream's
    keywords ``initial_pos`` / ``final_pos`` / ``target_pos`` are accepted too.

    Args:
        initial_position: the robot's start position, ``(x, y)`` or ``(x, y, z)``, in metres.
        final_position: the robot's end position, in the same form.
        target_position: the target's position, in the same form.
        min_z_height: the lowest height of the core during the run, in metres.

    Returns:
        ``SURVIVAL_PENALTY`` or the change of distance in metres (lower is better).
    """
    if min_z_height < SURVIVAL_MIN_HEIGHT:
        return SURVIVAL_PENALTY
    return fitness_delta_distance(initial_position, final_position, target_position)


@accept_aliases(**_POSITIONS)
def fitness_direct_path(
    initial_position: ArrayLike,
    final_position: ArrayLike,
    target_position: ArrayLike,
    total_path_length: float,
) -> float:
    """``fitness_delta_distance + 0.5 * (path length - straight-line displacement)``.

    Upstream's keywords ``initial_pos`` / ``final_pos`` / ``target_pos`` are accepted too.

    Args:
        initial_position: the robot's start position, ``(x, y)`` or ``(x, y, z)``, in metres.
        final_position: the robot's end position, in the same form.
        target_position: the target's position, in the same form.
        total_path_length: the length of the path the robot travelled, in metres.

    Returns:
        The change of distance plus the detour penalty (lower is better).
    """
    delta = fitness_delta_distance(initial_position, final_position, target_position)
    detour = float(total_path_length) - xy_displacement(initial_position, final_position)
    return delta + 0.5 * detour


def fitness_speed_to_target(
    time_to_target: float | None, duration: float, min_distance_to_target: float
) -> float:
    """``clip(time_to_target / duration, 0, 1)`` if the target was reached, else
    ``1 + min_distance_to_target``.

    Args:
        time_to_target: seconds until the target was reached; ``None`` (or inf / NaN) means
            it was not reached.
        duration: the run's length in seconds (> 0).
        min_distance_to_target: the closest the robot came to the target, in metres.

    Returns:
        A value in [0, 1] if the target was reached, else above 1 (lower is better).

    Raises:
        ValueError: ``duration`` is not > 0.
    """
    if not duration > 0:
        raise ValueError(f"duration must be > 0 seconds; got {duration}")
    if time_to_target is None or not math.isfinite(time_to_target):
        return 1.0 + float(min_distance_to_target)
    return float(np.clip(time_to_target / duration, 0.0, 1.0))
