"""Blueprint views that the run's layout (`blueprint`, ``ariel view``) and the live view's
(``ariel watch``) share: the robot's 3D view from its start, and a bar chart of a run's
series per generation.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.recording.rerun._chunks import rerun_module

if TYPE_CHECKING:
    from rerun.blueprint import BarChartView, Spatial3DView

__all__ = ["SUMMARY_SERIES", "robot_view", "summary_bars"]

#: Per-generation series drawn beside an evaluation (bar charts: they show on any timeline):
#: their entities, names and colours. A bar chart has no series name (its legend would show
#: the entity path), so each gets a view of its own, titled with its name and unit.
SUMMARY_SERIES: dict[str, tuple[str, str, tuple[int, int, int, int]]] = {
    "best_fitness": ("/run/fitness/best", "best fitness", (214, 39, 40, 255)),
    "mean_fitness": ("/run/fitness/mean", "mean fitness", (31, 119, 180, 255)),
    "diversity": (
        "/run/diversity/descriptor_distance",
        "descriptor distance",
        (44, 160, 44, 255),
    ),
    "distinct_morphologies": (
        "/run/diversity/distinct_morphologies",
        "distinct bodies",
        (148, 103, 189, 255),
    ),
}


def summary_bars(column: str, unit: str) -> BarChartView:
    """The bar chart of `SUMMARY_SERIES` ``column``, without legend, titled with its name
    ("best fitness per generation") and, for a fitness, its ``unit`` (" (m)", or "")."""
    rrb = rerun_module().blueprint
    entity, name, _ = SUMMARY_SERIES[column]
    title = f"{name}{unit if 'fitness' in column else ''} per generation"
    return rrb.BarChartView(name=title, origin=entity, plot_legend=rrb.PlotLegend(visible=False))


def robot_view(name: str, origin: str) -> Spatial3DView:
    """The 3D view of a robot at ``origin``: the camera looks at the start, from 1.5 m away."""
    rrb = rerun_module().blueprint
    return rrb.Spatial3DView(
        name=name,
        origin=origin,
        eye_controls=rrb.EyeControls3D(
            kind=rrb.components.Eye3DKind.Orbital,
            position=(0.8, -1.2, 0.7),
            look_target=(0.1, 0.0, 0.0),
            eye_up=(0.0, 0.0, 1.0),
        ),
    )
