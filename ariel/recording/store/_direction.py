"""Whether run.json's ``maximise`` agrees with its fitness function (`direction_problem`):
run.json is in no manifest, and a flipped ``maximise`` turns every reader's "best" into the
worst, so `ariel verify` asks the plugin where it is installed."""

from __future__ import annotations

from collections.abc import Mapping

from ariel.plugins import fitness_functions

__all__ = ["direction_problem"]


def direction_problem(info: Mapping[str, object], fitness: str) -> str | None:
    """What is wrong with run.json's ``maximise`` (``info``: run.json) given the direction of its
    fitness function ``fitness`` where that is installed here, or None (also where it is not).

    Args:
        info: run.json's data.
        fitness: The name of the run's fitness function (its config's ``task.fitness``).

    Returns:
        One line for `ariel verify`, or None.
    """
    recorded = info.get("maximise")
    if "maximise" in info and not isinstance(recorded, bool):  # what no ariel writes
        return f"run.json has maximise {recorded!r}, not true or false"
    try:
        plugin = fitness_functions.get(fitness)
    except (KeyError, ValueError, ImportError):
        return None  # not installed here: run.json is all there is to go by
    if not isinstance(recorded, bool) or recorded == bool(getattr(plugin, "maximise", True)):
        return None
    wanted = "higher" if not recorded else "lower"
    return (
        f"run.json has maximise {str(recorded).lower()}, but its fitness function {fitness!r} "
        f"(installed here) says {wanted} is better"
    )
