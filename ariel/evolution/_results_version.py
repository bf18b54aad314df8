"""Which records a config gives (`RESULTS_VERSION`), and which a run's maker gave
(`results_version`): `ariel resume` refuses a run of another, and `ariel compare` keeps runs of
different versions in different conditions."""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["RESULTS_VERSION", "results_version"]

#: Raised whenever a change makes one config give other records (the golden records
#: regenerated on purpose); run.json keeps the maker's. Generations of two algorithms in one
#: run would match neither's uninterrupted run, and runs of two in one condition would be
#: two samples taken for one.
RESULTS_VERSION = 1


def results_version(info: Mapping[str, object]) -> object:
    """The results version of the ariel that made the run (run.json ``info``): its
    ``results_version``; before that key, 1 where its config has ``task.settle`` (added by the
    change that made version 1: settling, the NA-CPG's starting amplitude), else 0."""
    if "results_version" in info:
        return info["results_version"]
    config = info.get("config")
    task = config.get("task") if isinstance(config, dict) else None
    return 1 if isinstance(task, dict) and "settle" in task else 0
