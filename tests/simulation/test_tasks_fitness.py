"""Fitness helpers on hand-computed numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ariel.simulation import tasks
from ariel.simulation.tasks.gait_learning import x_speed, xy_displacement, y_speed
from ariel.simulation.tasks.targeted_locomotion import (
    distance_to_target,
    fitness_delta_distance,
    fitness_direct_path,
    fitness_distance_and_efficiency,
    fitness_speed_to_target,
    fitness_survival_and_locomotion,
)
from ariel.simulation.tasks.turning_in_place import turning_in_place


def test_gait_learning() -> None:
    assert xy_displacement([0, 0], [3, 4]) == pytest.approx(5.0)
    assert xy_displacement([1, 1, 9.0], [4, 5, -2.0]) == pytest.approx(5.0)  # z ignored
    assert x_speed([0, 0], [-3, 4], 2.0) == pytest.approx(1.5)
    assert y_speed([0, 0], [-3, 4], 2.0) == pytest.approx(2.0)
    assert x_speed([0, 0], [3, 4], 0.0) == 0.0
    assert y_speed([0, 0], [3, 4], -1.0) == 0.0
    with pytest.raises(ValueError, match="at least x and y"):
        xy_displacement([1.0], [2.0, 3.0])


def test_targeted_locomotion() -> None:
    start, end, target = [0, 0, 0.1], [3, 0, 0.1], [6, 4]
    assert distance_to_target(end, target) == pytest.approx(5.0)
    # initial distance sqrt(36 + 16) = 7.2111; final 5 -> progress is negative
    delta = 5.0 - math.sqrt(52.0)
    assert fitness_delta_distance(start, end, target) == pytest.approx(delta)
    assert fitness_distance_and_efficiency(start, end, target, 200.0) == pytest.approx(delta + 0.2)
    assert fitness_survival_and_locomotion(start, end, target, 0.04) == 10.0
    assert fitness_survival_and_locomotion(start, end, target, 0.05) == pytest.approx(delta)
    # path 5 m long for a 3 m displacement: 0.5 * 2 m detour
    assert fitness_direct_path(start, end, target, 5.0) == pytest.approx(delta + 1.0)


def test_speed_to_target() -> None:
    assert fitness_speed_to_target(3.0, 15.0, 0.0) == pytest.approx(0.2)
    assert fitness_speed_to_target(20.0, 15.0, 0.0) == 1.0
    assert fitness_speed_to_target(None, 15.0, 0.7) == pytest.approx(1.7)
    assert fitness_speed_to_target(math.inf, 15.0, 0.7) == pytest.approx(1.7)
    with pytest.raises(ValueError, match="duration"):
        fitness_speed_to_target(1.0, 0.0, 0.0)


def test_turning_in_place() -> None:
    assert turning_in_place([]) == 0.0
    assert turning_in_place([[1.0, 2.0]]) == 0.0
    assert turning_in_place([[0, 0], [1, 0]]) == 0.0  # one displacement: no heading change
    # A unit square walked counter-clockwise back to the start: three 90 degree turns, no drift.
    square = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]
    assert turning_in_place(square) == pytest.approx(3 * math.pi / 2)
    # Straight line: no turning; z column ignored.
    line = np.column_stack([np.arange(5.0), np.zeros(5), np.ones(5)])
    assert turning_in_place(line) == 0.0
    # Two left turns of 90 degrees (pi in total), ending 1 m from the start:
    path = [[0, 0], [1, 0], [1, 1], [0, 1]]
    assert turning_in_place(path) == pytest.approx(math.pi / (1 + 1.0))
    # Unwrapping: headings 170 -> -170 degrees is a 20 degree turn, not 340.
    a, b = math.radians(170), math.radians(-170)
    zigzag = [
        [0, 0],
        [math.cos(a), math.sin(a)],
        [math.cos(a) + math.cos(b), math.sin(a) + math.sin(b)],
    ]
    drift = math.hypot(zigzag[2][0], zigzag[2][1])
    assert turning_in_place(zigzag) == pytest.approx(math.radians(20) / (1 + drift))
    with pytest.raises(ValueError, match="shape"):
        turning_in_place([1.0, 2.0, 3.0])


def test_task_table() -> None:
    assert tasks.tasks == ["Gate Learning", "Targeted Locomotion", "Turning In Place"]
    assert tasks.TASK_FUNCTIONS["Gate Learning"] == [xy_displacement, x_speed, y_speed]
    assert tasks.TASK_FUNCTIONS["Targeted Locomotion"] == [distance_to_target]
    assert tasks.TASK_FUNCTIONS["Turning In Place"] == [turning_in_place]


def test_sustained_displacement_counts_a_steady_gait_and_not_one_fall() -> None:
    from ariel.simulation.tasks.gait_learning import sustained_displacement

    t = np.linspace(0.0, 8.0, 81)
    steady = np.stack([0.05 * t, 0.0 * t], axis=1)  # 5 cm/s for 8 s
    assert sustained_displacement(t, steady) == pytest.approx(0.4)
    assert sustained_displacement(t, steady) == pytest.approx(
        xy_displacement(steady[0], steady[-1])
    )
    # Standing still, then one 0.3 m tip-over between t = 6 and 7 s: one window of eight.
    fall = np.stack([np.clip(t - 6.0, 0.0, 1.0) * 0.3, 0.0 * t], axis=1)
    assert xy_displacement(fall[0], fall[-1]) == pytest.approx(0.3)
    assert sustained_displacement(t, fall) == 0.0
    # The same gait with a late fall on top: the gait counts, the fall does not.
    both = steady + fall
    assert sustained_displacement(t, both) == pytest.approx(0.4)
    # Backwards-creeping after a big lunge forward: typical window goes backwards -> 0.
    creep = np.stack([np.where(t < 1.0, t * 1.0, 1.0 - 0.01 * (t - 1.0)), 0.0 * t], axis=1)
    assert sustained_displacement(t, creep) == 0.0
    # Direction does not matter (a diagonal gait), z is ignored, a short span is its displacement.
    diagonal = np.stack([0.03 * t, -0.04 * t, np.sin(t)], axis=1)
    assert sustained_displacement(t, diagonal) == pytest.approx(0.4)
    assert sustained_displacement(t[:5], steady[:5]) == pytest.approx(0.02)
    with pytest.raises(ValueError, match="xy must be"):
        sustained_displacement(t, steady[:10])
    with pytest.raises(ValueError, match="window must be > 0"):
        sustained_displacement(t, steady, window=0.0)
