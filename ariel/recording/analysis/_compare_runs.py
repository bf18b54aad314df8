"""The runs `compare` compares and their conditions: a campaign folder's runs (`_campaign_runs`),
several folders of one campaign file pooled (`_pooled_campaign_runs`), or plain run folders
grouped by how their configs differ or by ``--label`` (`_folder_runs`, `condition_names`); each
run counted once (`unique_folders`, `_run_identity`), and those with a finished generation
checked comparable (`_comparable_runs`). Each run becomes a `RunCurve`.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from ariel.evolution import results_version
from ariel.recording.analysis import _compare_lineage as lineages
from ariel.recording.analysis._compare_design import (
    QD_COLUMNS,
    CompareError,
    Source,
    check_comparable,
    condition_settings,
)
from ariel.recording.store import (
    Run,
    fitness_maximise,
    load_campaign,
    load_run,
    one_line,
    short_ascii,
)

if TYPE_CHECKING:
    import pandas as pd

    from ariel.recording.store import Campaign, JsonObject

__all__ = [
    "LABEL",
    "NAME_LIMIT",
    "RunCurve",
    "condition_names",
    "unique_folders",
]

_Item = TypeVar("_Item")

#: The longest automatic condition name of plain run folders (`condition_names`).
NAME_LIMIT = 60
#: A ``--label``: 1 to 64 ASCII letters, digits, ``_``, ``.`` or ``-``.
LABEL = re.compile(r"[A-Za-z0-9_.-]{1,64}")


@dataclass
class RunCurve:
    """One run's part of a comparison: its condition, seed, and evaluations table (``fitness``,
    ``status``, ``generation``, ``eval_id``, descriptor columns); ``info``: its run.json (for
    software and commit); ``generations``: its per-generation QD columns (``generation`` and
    any of `QD_COLUMNS`), or None; ``lineage``: its per-generation lineage measures
    (`_compare_lineage.run_lineage`), or None (a brain-only run)."""

    condition: str
    seed: int
    evaluations: pd.DataFrame
    path: str = ""
    info: JsonObject = field(default_factory=dict)
    generations: pd.DataFrame | None = None
    lineage: pd.DataFrame | None = None


def _qd_generations(run: Run) -> pd.DataFrame | None:
    """The run's per-generation QD columns (MAP-Elites runs), or None."""
    if not len(run.archive):
        return None
    generations = run.generations
    columns = [c for c in QD_COLUMNS if c in generations.columns]
    return generations[["generation", *columns]] if columns else None


def _curve(condition: str, seed: int, run: Run) -> RunCurve:
    found = (run.evaluations, str(run.path), run.info, _qd_generations(run))
    return RunCurve(condition, seed, *found, lineages.run_lineage(run))


def _overrides(changes: Mapping[str, object]) -> str:
    return ", ".join(f"{k} = {json.dumps(v)}" for k, v in changes.items())


def _campaign_runs(path: Path) -> tuple[str, Source, bool, list[tuple[RunCurve, Run]]]:
    """(title, source, whether the conditions share seeds, the runs) of a campaign folder."""
    campaign = _undamaged(load_campaign(path))
    found = [(_curve(c, seed, run), run) for (c, seed), run in campaign.runs.items()]
    source = _campaign_source(path, campaign, len(found))
    title = str(campaign.info.get("campaign_id", path.name))
    return title, source, campaign.seeding == "shared", found


def _undamaged(campaign: Campaign) -> Campaign:
    """``campaign``, unless a run of it is damaged: `CompareError` naming it (a comparison
    without it would be silently of fewer seeds)."""
    if campaign.damaged:
        (condition, seed), line = next(iter(campaign.damaged.items()))
        more = len(campaign.damaged) - 1
        others = f" (and {more} more run(s))" if more else ""
        raise CompareError(
            f"run {condition!r} seed {seed} of campaign {str(campaign.path)!r}{others} cannot "
            f"be compared: {line}"
        )
    return campaign


def _campaign_source(path: Path, campaign: Campaign, runs: int) -> Source:
    """What `compare` says it compared for the campaign in ``path`` (``runs`` of its runs)."""
    info = campaign.info
    base = info.get("base")
    return Source(
        what=f"campaign {info.get('campaign_id', path.name)} ({path}), "
        f"{runs} runs, seeding = {campaign.seeding!r}",
        overrides={c["name"]: _overrides(c.get("set", {})) for c in info.get("conditions", [])},
        base=f"{base} (from the campaign file {info.get('file', '?')})"
        if base
        else f"the base of the campaign file {info.get('file', '?')}",
    )


def _campaign_key(campaign: Campaign) -> tuple[object, ...]:
    """What campaign folders must share to be pooled: the campaign file's name, seeding and
    conditions (each with its settings)."""
    info = campaign.info
    conditions = [
        (c["name"], json.dumps(c.get("set", {}), sort_keys=True))
        for c in info.get("conditions", [])
    ]
    return (info.get("name"), campaign.seeding, tuple(conditions))


def _pooled_campaign_runs(
    paths: Sequence[Path],
) -> tuple[str, Source, bool, list[tuple[RunCurve, Run]]]:
    """Several folders of one campaign file run on different seeds (a campaign extended with
    more seeds), pooled as one campaign: the same conditions and seeding, no seed twice."""
    campaigns = [_undamaged(load_campaign(p)) for p in paths]
    first = _campaign_key(campaigns[0])
    for path, campaign in zip(paths[1:], campaigns[1:]):
        if _campaign_key(campaign) != first:
            raise CompareError(
                f"{str(path)!r} is not the same campaign as {str(paths[0])!r} (name, seeding "
                "and conditions must match): compare several campaign folders only to pool "
                "one campaign's seeds"
            )
    _check_pooled_settings(paths, campaigns)
    found: list[tuple[RunCurve, Run]] = []
    seen: dict[tuple[str, int], Path] = {}
    for path, campaign in zip(paths, campaigns):
        for (condition, seed), run in campaign.runs.items():
            if (condition, seed) in seen:
                raise CompareError(
                    f"condition {condition!r} seed {seed} is in both "
                    f"{str(seen[condition, seed])!r} and {str(path)!r}: pooled campaign folders "
                    "must have different seeds"
                )
            seen[condition, seed] = path
            found.append((_curve(condition, seed, run), run))
    source = _campaign_source(paths[0], campaigns[0], len(found))
    ids = [str(c.info.get("campaign_id", p.name)) for p, c in zip(paths, campaigns)]
    source.what = (
        f"campaign {campaigns[0].info.get('name', '?')} pooled from {len(paths)} folders "
        f"({', '.join(f'{i} ({p})' for i, p in zip(ids, paths))}), {len(found)} runs, "
        f"seeding = {campaigns[0].seeding!r}"
    )
    return " + ".join(ids), source, campaigns[0].seeding == "shared", found


def _check_pooled_settings(paths: Sequence[Path], campaigns: Sequence[Campaign]) -> None:
    """`CompareError` where a condition's runs in the pooled folders ran with other settings
    (a campaign-wide ``set`` or ``--set`` of one folder): their seeds are no one sample.
    ``generations`` may differ: they are compared at a common budget."""
    first: dict[str, tuple[Path, dict[str, str]]] = {}
    for path, campaign in zip(paths, campaigns):
        for (condition, _seed), run in campaign.runs.items():
            settings = condition_settings(run.info.get("config", {}))
            settings.pop("generations", None)
            if condition not in first:
                first[condition] = (path, settings)
                continue
            where, before = first[condition]
            differ = sorted(k for k in {*before, *settings} if before.get(k) != settings.get(k))
            if differ:
                raise CompareError(
                    f"condition {condition!r} ran with other settings in {str(path)!r} than in "
                    f"{str(where)!r} ({', '.join(differ[:4])}{' ...' if len(differ) > 4 else ''}"
                    "): pooled campaign folders must run one campaign file the same way"
                )


def _times(n: int) -> str:
    return "twice" if n == 2 else f"{n} times"


def _once(items: Sequence[_Item], key: Callable[[_Item], Hashable | None]) -> list[list[_Item]]:
    """``items`` grouped by ``key`` (None: an item of its own), in the order each group's
    first item comes: the first of each group is the one counted."""
    groups: dict[tuple[str, object], list[_Item]] = {}
    for i, item in enumerate(items):
        found = key(item)
        groups.setdefault(("own", i) if found is None else ("key", found), []).append(item)
    return list(groups.values())


def unique_folders(paths: Sequence[Path], what: str = "run") -> tuple[list[Path], list[str]]:
    """(``paths`` less those naming a folder given before: ``R R``, ``R sub/../R``, a link to
    ``R``, compared by their resolved paths; a note for each folder given more than once)."""
    groups = _once(paths, lambda p: os.path.realpath(p))
    notes = [
        f"the same {what} was given {_times(len(group))}: "
        f"{', '.join(repr(str(p)) for p in group)} (one folder); counted once"
        for group in groups
        if len(group) > 1
    ]
    return [group[0] for group in groups], notes


def _run_identity(run: Run) -> Hashable | None:
    """What makes two run folders one run (a copy of a folder): its run id, when run.json
    was created, its seed and its config. None without a run id. (A run id alone is not one
    run: ``ariel run --out a/seed1`` and ``--out b/seed1`` both have the run id ``seed1``.)"""
    run_id = run.info.get("run_id")
    if not run_id:
        return None
    config = json.dumps(run.info.get("config", run.config), sort_keys=True, default=str)
    return (str(run_id), str(run.info.get("created")), str(run.info.get("seed")), config)


def _short_keys(keys: Sequence[str]) -> dict[str, str]:
    """Each dotted key's shortest ending that no other of ``keys`` ends with
    (``body.population`` -> ``population``; ``body.options`` and ``brain.options`` stay)."""
    short = {}
    for key in keys:
        parts = key.split(".")
        for depth in range(1, len(parts) + 1):
            ending = ".".join(parts[-depth:])
            if not any(o != key and (o == ending or o.endswith(f".{ending}")) for o in keys):
                break
        short[key] = ending
    return short


def condition_names(keys: Sequence[str], flats: Sequence[Mapping[str, str]]) -> list[str]:
    """Each run's condition name from its values of the differing ``keys``
    (``brain.inherit=false``). Where one would be longer than `NAME_LIMIT`, every name uses
    the keys' last components (`_short_keys`), and one still too long is cut and ends in
    ``~`` and 8 hex digits of a hash of its whole name: the same settings, the same name.
    Never merges two conditions (the whole names then)."""
    whole = [",".join(f"{k}={f.get(k, '-')}" for k in keys) for f in flats]
    if max(map(len, whole), default=0) <= NAME_LIMIT:
        return whole
    short_keys = _short_keys(keys)
    names = []
    for name, flat in zip(whole, flats):
        short = ",".join(f"{short_keys[k]}={flat.get(k, '-')}" for k in keys)
        if len(short) > NAME_LIMIT:
            digest = hashlib.sha256(name.encode()).hexdigest()[:8]
            short = f"{short[: NAME_LIMIT - 9]}~{digest}"
        names.append(short)
    return names if len(set(names)) == len(set(whole)) else whole


def _settings_text(keys: Sequence[str], flats: Sequence[Mapping[str, str]]) -> str:
    """The values of ``keys`` in the runs of one condition (``a = 1 | 2`` where they differ)."""
    parts = []
    for key in keys:
        values = list(dict.fromkeys(f.get(key, "-") for f in flats))
        parts.append(f"{key} = {' | '.join(values)}")
    return ", ".join(parts)


def _shown_label(name: object) -> str:
    """A refused label as typed ('é', not '\\xe9'), one line and cut: it came from the
    command line, in the terminal's own characters."""
    return short_ascii(name) if not isinstance(name, str) else f"'{one_line(name[:60])}'"


def _checked_labels(labels: Mapping[str | Path, str], paths: Sequence[Path]) -> dict[str, str]:
    """``labels`` (run folder -> condition name) by resolved path, checked: every label a
    name (`LABEL`), every folder one of ``paths``, one label per folder, every folder
    labelled (`CompareError`, one line)."""
    given = {os.path.realpath(p): p for p in paths}
    found: dict[str, str] = {}
    for folder, name in labels.items():
        if not isinstance(name, str) or not LABEL.fullmatch(name):
            raise CompareError(
                f"--label {_shown_label(name)}: a label is 1 to 64 ASCII letters, digits, '_', "
                "'.' or '-'"
            )
        resolved = os.path.realpath(os.path.expanduser(folder))  # "~/runs/a", as the paths
        if resolved not in given:
            raise CompareError(
                f"--label {name}={str(folder)!r}: that folder is not one of the run folders "
                "compared; give it as well"
            )
        if found.get(resolved, name) != name:
            raise CompareError(
                f"{str(given[resolved])!r} has two labels, {found[resolved]!r} and {name!r}"
            )
        found[resolved] = name
    missing = [p for r, p in given.items() if r not in found]
    if missing:
        raise CompareError(
            f"{str(missing[0])!r} has no --label: label every run folder or none"
            f"{f' ({len(missing)} unlabelled)' if len(missing) > 1 else ''}"
        )
    return found


def _folder_runs(
    paths: Sequence[Path], labels: Mapping[str, str] | None = None
) -> tuple[str, Source, list[tuple[RunCurve, Run]], list[str]]:
    """Plain run folders (each once: `unique_folders` first), each condition named by the
    config values that tell it apart (`condition_names`) or by ``labels`` (resolved run
    folder -> name, `_checked_labels`); with a note for each run given twice. A copy of a
    run folder (`_run_identity`) counts once."""
    loaded = [(p, load_run(p)) for p in paths]
    notes = []
    kept = []
    for group in _once(loaded, lambda item: _run_identity(item[1])):
        kept.append(group[0])
        if len(group) == 1:
            continue
        if labels is not None:
            named = {labels[os.path.realpath(p)] for p, _ in group}
            if len(named) > 1:
                raise CompareError(
                    f"{str(group[0][0])!r} and {str(group[1][0])!r} are the same run (run id "
                    f"{group[0][1].info.get('run_id')!r}) but have different labels"
                )
        notes.append(
            f"the same run was given {_times(len(group))}: "
            f"{', '.join(repr(str(p)) for p, _ in group)} (run id "
            f"{group[0][1].info.get('run_id')!r}: a copy); counted once"
        )
    runs = [run for _, run in kept]
    # A run of another results version is another condition, whatever its config says.
    flats = [
        {
            **condition_settings(run.config, run.brain_only),
            "results_version": str(results_version(run.info)),
        }
        for run in runs
    ]
    keys = sorted({k for f in flats for k in f})
    differing = [k for k in keys if len({f.get(k) for f in flats}) > 1]
    if labels is not None:
        names = [labels[os.path.realpath(p)] for p, _ in kept]
    elif differing:
        names = condition_names(differing, flats)
    else:
        names = [str(run.config.get("name", "runs")) for run in runs]
    found = []
    for name, run in zip(names, runs):
        seed = int(run.info.get("seed", run.config.get("seed", 0)))
        found.append((_curve(name, seed, run), run))
    overrides = {
        name: _settings_text(differing, [f for n, f in zip(names, flats) if n == name])
        for name in dict.fromkeys(names)
    }
    how = "by --label" if labels is not None else "by the config values that differ"
    source = Source(
        what=f"{len(runs)} run folders: {', '.join(str(p) for p, _ in kept)}",
        overrides=overrides if differing else {},
        base=f"none: plain run folders, each condition named {how}",
    )
    return f"{len(runs)} run{'s' * (len(runs) != 1)}", source, found, notes


def _direction(runs: Sequence[Run]) -> tuple[bool, str]:
    """(whether the fitness is maximised, its name), of runs `check_comparable` let through."""
    directions = {fitness_maximise(r.info) for r in runs}
    if len(directions) > 1:
        raise CompareError("the runs disagree on the fitness direction (maximise in run.json)")
    return directions.pop(), str(runs[0].config.get("task", {}).get("fitness", "?"))


def _comparable_runs(
    found: Sequence[tuple[RunCurve, Run]], names: Sequence[str], notes: list[str]
) -> tuple[list[tuple[RunCurve, Run]], bool, str]:
    """(the runs of ``found`` with a finished generation, whether their fitness is maximised,
    its name), a note naming the runs left out for having none added to ``notes``:
    `CompareError` where none has one or they are not comparable (`check_comparable`, each run
    named by ``names``, in step with ``found``)."""
    done = [i for i, (_, run) in enumerate(found) if run.generations_done > 0]
    if not done:
        raise CompareError("no run with a finished generation to compare")
    waiting = [str(names[i]) for i in range(len(found)) if i not in done]
    if waiting:
        notes.append(
            f"{len(waiting)} of {len(found)} runs left out: no finished generation yet "
            f"({', '.join(waiting[:5])}{', ...' if len(waiting) > 5 else ''})"
        )
    found = [found[i] for i in done]
    check_comparable([(names[i], found[j][1].config) for j, i in enumerate(done)])
    maximise, fitness_fn = _direction([r for _, r in found])
    return found, maximise, fitness_fn
