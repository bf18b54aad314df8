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
RESULTS_VERSION = 2

#: Whose records each raise changed: None, every config's; else the body optimizers whose
#: records differ (a run of any other gives the same records under both versions).
CHANGED: dict[int, frozenset[str] | None] = {
    1: None,  # settling before the measured time; the NA-CPG's starting amplitude
    2: frozenset({"novelty"}),  # the novelty table keeps the scores selection used
}


def results_version(info: Mapping[str, object]) -> object:
    """The results version whose records the run's config gives (run.json ``info``): the
    ``results_version`` of the ariel that made it (before that key, 1 where its config has
    ``task.settle``, added by the change that made version 1, else 0), raised past each later
    version whose change left this config's records as they were (`CHANGED`): a GA run of
    version 1 gives version 2's records, a novelty run of version 1 does not."""
    config = info.get("config")
    config = config if isinstance(config, dict) else {}
    if "results_version" in info:
        version = info["results_version"]
    else:
        task = config.get("task")
        version = 1 if isinstance(task, dict) and "settle" in task else 0
    if not isinstance(version, int) or isinstance(version, bool):
        return version  # not one any ariel wrote: shown as it is, matching none
    body = config.get("body")
    optimizer = body.get("optimizer", "ga") if isinstance(body, dict) else "ga"
    optimizer = None if info.get("brain_only") else optimizer  # a brain-only run has none
    while version + 1 in CHANGED:
        changed = CHANGED[version + 1]
        if changed is None or optimizer in changed:
            break
        version += 1
    return version
