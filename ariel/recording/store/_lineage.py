"""A run's lineage as a record in the ALife data standard's phylogeny format.

The standard (https://alife-data-standards.github.io/alife-data-standards/phylogeny): one row
per taxon, here per body ever evaluated, with ``id`` (a non-negative integer), ``ancestor_list``
(the ids of its direct ancestors in brackets, ``[3, 7]``; ``[none]`` for a taxon without one,
as the standard's example writes it) and the conventional ``origin_time`` and
``destruction_time``. Any further column is an extra property the standard allows.

Definitions (time in generations; ``t`` stands for the end of generation ``t``, after its
selection):

- ``id``: the body's number, the digits of its ``body_id`` (``b000052`` -> 52); every body id
  a run writes has that shape, and the number is unique in the run. ``body_id`` is kept.
- ``ancestor_list``: the body's parents (``parent_ids`` of the bodies table), each once, in
  the order recorded (a crossover of a body with itself lists it once); ``[none]`` for a
  random genotype: a founder. The GA's and MAP-Elites' founders are generation 0's bodies;
  random search makes founders in every generation.
- ``origin_time``: the generation the body was made and evaluated in (its first row of the
  bodies table: its ``born_generation``).
- ``destruction_time``: the first generation after whose selection the body is no longer in
  the population (a GA's survivors, a MAP-Elites archive's elites: the bodies table's
  ``selected``). A body discarded by the selection of its own generation has
  ``destruction_time == origin_time``. A body still in the population after the last finished
  generation has none: ``<NA>`` here (a nullable integer column, never NaN or inf), an empty
  cell in the CSV; `write_lineage_csv` writes ``inf`` instead when asked (what Empirical's
  phylotrackpy writes, and needs to read a taxon as alive), or ``none`` (as the standard's
  example does).

  So a body is alive at generation ``g`` when ``origin_time <= g < destruction_time``: alive
  exactly when it is in the population after ``g``'s selection.
- ``origin_evaluation`` / ``destruction_evaluation``: the run's evaluations done by the end of
  those generations (every row of the evaluations table, failed ones included, counted up to
  and including the generation); ``<NA>`` where ``destruction_time`` is.
- ``fitness``, ``status`` and the morphology descriptors (``num_modules``, ...): the bodies
  table's, from the body's last row (a brain-only run's one body keeps learning).
"""

from __future__ import annotations

import math
import os
import re
from collections import deque
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ariel.body_phenotypes.robogen_lite.config import DESCRIPTOR_NAMES
from ariel.errors import DamagedRunError
from ariel.recording.store._escape import csv_safe, short_ascii
from ariel.recording.store._files import atomic_write, output_file_problem
from ariel.recording.store._ids import BODY_ID
from ariel.utils import flag_argument, path_argument

if TYPE_CHECKING:
    from ariel.recording.store._campaign import Campaign
    from ariel.recording.store._load import Run

__all__ = [
    "ALIVE_MARKS",
    "LINEAGE_COLUMNS",
    "STATISTICS_COLUMNS",
    "ancestors",
    "campaign_lineages",
    "format_ancestor_list",
    "lineage",
    "lineage_statistics",
    "lineage_statistics_by_run",
    "parse_ancestor_list",
    "write_lineage_csv",
]

#: The first columns of a `lineage` frame, in order (the descriptors follow).
LINEAGE_COLUMNS = (
    "id",
    "ancestor_list",
    "origin_time",
    "destruction_time",
    "origin_evaluation",
    "destruction_evaluation",
    "body_id",
    "fitness",
    "status",
)
#: The columns of `lineage_statistics`, in order.
STATISTICS_COLUMNS = (
    "generation",
    "alive",
    "surviving_lineages",
    "best_id",
    "best_fitness",
    "best_depth",
)
#: What `write_lineage_csv` may write for a body still alive: an empty cell (the default),
#: ``inf`` (Empirical / phylotrackpy) or ``none`` (the standard's example).
ALIVE_MARKS = ("", "inf", "none")
#: ``ancestor_list`` of a taxon without ancestors, as the standard's example writes it.
NO_ANCESTORS = "[none]"

_ANCESTORS = re.compile(r"\[\s*(.*?)\s*\]")


def _number(body_id: object, where: Path) -> int:
    """The number in a body id (``b000052`` -> 52, `BODY_ID`: ASCII digits, not too many);
    `DamagedRunError` for anything else."""
    found = BODY_ID.fullmatch(body_id) if isinstance(body_id, str) else None
    if found is None:
        raise DamagedRunError(
            f"{str(where)!r}: its bodies table holds a body id that is not one: "
            f"{short_ascii(body_id)} "
            "(body ids look like b000012); the folder was changed by hand or crafted"
        )
    return int(found.group(1))


def format_ancestor_list(ids: list[int]) -> str:
    """The standard's ``ancestor_list`` cell of ``ids``.

    Args:
        ids: The ancestors' ids.

    Returns:
        ``"[3, 7]"``; ``"[none]"`` when ``ids`` is empty.
    """
    return f"[{', '.join(str(i) for i in ids)}]" if ids else NO_ANCESTORS


def parse_ancestor_list(text: str) -> list[int]:
    """The ids in an ``ancestor_list`` cell: ``"[3, 7]"`` -> ``[3, 7]``, ``"[none]"`` -> ``[]``.

    Also reads the forms other tools write: ``[NONE]``, ``['none']``, ``['3', '7']``.

    Args:
        text: The cell.

    Returns:
        The ancestor ids, in the order listed.

    Raises:
        ValueError: When ``text`` is not an ancestor list.
    """
    found = _ANCESTORS.fullmatch(text.strip()) if isinstance(text, str) else None
    if found is None:
        raise ValueError(f"not an ancestor_list: {text!r} (expected '[3, 7]' or '[none]')")
    items = [item.strip().strip("'\"") for item in found.group(1).split(",")]
    if len(items) == 1 and items[0].lower() in ("", "none"):
        return []
    try:
        return [int(item) for item in items]
    except ValueError:
        raise ValueError(f"not an ancestor_list: {text!r} (ids are integers)") from None


def _evaluations_done(run: Run) -> list[int]:
    """Evaluations done by the end of each finished generation (cumulative counts)."""
    counts = run.evaluations.groupby("generation").size()
    done, total = [], 0
    for generation in range(run.generations_done):
        total += int(counts.get(generation, 0))
        done.append(total)
    return done


def lineage(run: Run) -> pd.DataFrame:
    """The lineage of ``run``'s bodies in the ALife phylogeny format (see the module's
    docstring for every column's definition).

    Args:
        run: A run's records (`ariel.recording.load_run`); its ``bodies`` and ``evaluations``
            tables are read. A folder's path is a `TypeError` saying to load it.

    Returns:
        A DataFrame with one row per body ever evaluated, ordered by ``id``: the
        `LINEAGE_COLUMNS`, then one column per morphology descriptor. ``destruction_time`` and
        ``destruction_evaluation`` are nullable integers (``<NA>``: still alive).
        ``attrs`` holds the run's fitness direction (``"maximise"``) and its finished
        generations (``"generations"``), for `lineage_statistics`.

    Raises:
        TypeError: For what is not a run (a path: ``lineage(load_run(path))``).
        DamagedRunError: When a body id is not one (or two share a number), or a parent is
            not a body of the run.

    Example:
        ```python
        from ariel.recording import lineage, load_run, write_lineage_csv

        frame = lineage(load_run("data/runs/my-run"))  # or: load_run(...).lineage()
        write_lineage_csv(frame, "my-run-phylogeny.csv")  # or: ariel export RUN --lineage FILE
        ```
    """
    if not hasattr(run, "bodies"):  # a path: the run is read by load_run, once, checked
        what = f"the path {str(run)!r}" if isinstance(run, str | os.PathLike) else type(run)
        raise TypeError(f"lineage takes a run, load_run(path), not {what}")
    bodies = run.bodies.sort_values("generation", kind="stable")
    done = _evaluations_done(run)
    last_generation = run.generations_done - 1
    known = {_number(body_id, run.path) for body_id in bodies["body_id"]}
    rows = []
    lives: list[tuple[int, int, list[int]]] = []  # (number, born, parents) of each body
    for body_id, group in bodies.groupby("body_id", sort=False):
        first, last = group.iloc[0], group.iloc[-1]
        kept = group.loc[group["selected"].astype(bool), "generation"]
        origin = int(first["generation"])  # its born_generation: made and evaluated in it
        # The first generation whose selection did not keep it: after its last kept one.
        alive = bool(last["selected"]) and int(last["generation"]) == last_generation
        destruction = None if alive else (int(kept.max()) + 1 if len(kept) else origin)
        if not 0 <= origin < len(done) or not (destruction is None or destruction < len(done)):
            raise DamagedRunError(  # rows of one body that no run writes (a body id twice)
                f"{str(run.path)!r}: body {body_id}'s rows in its bodies table are not a life "
                "in the run's finished generations; the bodies table was changed or damaged"
            )
        number = _number(body_id, run.path)
        parents = _parents(first["parent_ids"], known, body_id, run.path)
        lives.append((number, origin, parents))
        rows.append(
            {
                "id": number,
                "ancestor_list": format_ancestor_list(parents),
                "origin_time": origin,
                "destruction_time": destruction,
                "origin_evaluation": done[origin],
                "destruction_evaluation": None if destruction is None else done[destruction],
                "body_id": body_id,
                "fitness": float(last["fitness"]),
                "status": last["status"],
                **{name: last[name] for name in DESCRIPTOR_NAMES},
            }
        )
    frame = pd.DataFrame(rows, columns=[*LINEAGE_COLUMNS, *DESCRIPTOR_NAMES])
    for column in ("id", "origin_time", "origin_evaluation"):
        frame[column] = frame[column].astype("int64")
    for column in ("destruction_time", "destruction_evaluation"):
        frame[column] = frame[column].astype("Int64")
    frame["fitness"] = frame["fitness"].astype("float64")
    for name in DESCRIPTOR_NAMES:  # the bodies table's own dtypes (nullable counts)
        frame[name] = frame[name].astype(bodies[name].dtype)
    frame = frame.sort_values("id", kind="stable").reset_index(drop=True)
    _check_parents_came_first(lives, run.path)
    if frame["id"].duplicated().any():  # b0000052 beside b000052: a crafted table
        raise DamagedRunError(
            f"{str(run.path)!r}: two body ids with one number in its bodies table"
        )
    frame.attrs["maximise"] = bool(run.maximise) if len(frame) else True
    frame.attrs["generations"] = run.generations_done
    return frame


def _check_parents_came_first(lives: list[tuple[int, int, list[int]]], where: Path) -> None:
    """Every parent (of ``lives``: each body's number, generation born and parents) was born
    in an earlier generation than its child: no body is its own ancestor (a crafted cycle sent
    the report's lineage walk into a KeyError)."""
    born = {number: origin for number, origin, _ in lives}
    for child, origin, parents in lives:
        for parent in parents:
            if born[parent] >= origin:
                raise DamagedRunError(
                    f"{str(where)!r}: body {child} has parent {parent}, born no earlier than "
                    "it; the bodies table was changed or damaged"
                )


def _parents(
    parent_ids: Iterable[object] | None, known: set[int], body_id: str, where: Path
) -> list[int]:
    """A body's parent numbers, each once, in the order recorded; each must be a body."""
    numbers: list[int] = []
    for parent in list(parent_ids) if parent_ids is not None else []:
        number = _number(parent, where)
        if number not in known:
            raise DamagedRunError(
                f"{str(where)!r}: body {body_id} has parent {parent}, which is no body of the "
                "run's finished generations; the bodies table was changed or damaged"
            )
        if number not in numbers:
            numbers.append(number)
    return numbers


def write_lineage_csv(
    frame: pd.DataFrame,
    path: str | os.PathLike[str],
    *,
    overwrite: bool = False,
    still_alive: str = "",
) -> Path:
    """Write ``frame`` (a `lineage` frame) as the standard's CSV: a header row, then a row per
    taxon, ``ancestor_list`` as ``[3, 7]`` / ``[none]`` (quoted where it holds a comma).

    Written whole, to a temporary name, fsynced, then renamed
    (`ariel.recording.store._files.atomic_write`): a killed writer leaves no half file, and a file
    in a folder that is a symbolic link is refused, and so is a file inside a run or campaign
    folder (`output_file_problem`: its records are never written over).

    Args:
        frame: The lineage: columns ``id`` and ``ancestor_list`` at least.
        path: The CSV file to write.
        overwrite: Whether an existing file at ``path`` may be replaced.
        still_alive: What an empty ``destruction_time`` or ``destruction_evaluation`` (a
            body still alive) is written as; one of `ALIVE_MARKS`: an empty cell (the
            default), ``"inf"`` (what phylotrackpy's ``Systematics.load_from_file`` needs to
            see a taxon alive: it reads an empty cell as 0) or ``"none"``.

    Returns:
        The path written.

    Raises:
        FileExistsError: When ``path`` exists and ``overwrite`` is False.
        TypeError: For an argument of the wrong type (``overwrite="no"``: True or False).
        ValueError: When ``frame`` lacks ``id`` or ``ancestor_list``, ``still_alive`` is not
            one of `ALIVE_MARKS`, or ``path`` is a folder or inside a run or campaign folder.
    """
    if not isinstance(frame, pd.DataFrame):  # `run.lineage`, not called: an AttributeError
        raise TypeError(
            "write_lineage_csv: frame must be a lineage frame (run.lineage()), not "
            f"{type(frame).__name__}"
        )
    path = path_argument("path", path, function="write_lineage_csv")
    flag_argument("overwrite", overwrite, function="write_lineage_csv")
    missing = [column for column in ("id", "ancestor_list") if column not in frame.columns]
    if missing:
        raise ValueError(f"not a lineage frame: no column {missing[0]!r}")
    if still_alive not in ALIVE_MARKS:
        raise ValueError(f"still_alive must be one of {ALIVE_MARKS}, not {still_alive!r}")
    if os.path.lexists(path) and not overwrite:
        raise FileExistsError(
            f"{str(path)!r} already exists; pass overwrite=True to replace it, or choose "
            "another file"
        )
    problem = output_file_problem(path)
    if problem is not None:
        raise ValueError(problem)
    table = frame.copy()
    for column in ("destruction_time", "destruction_evaluation"):
        if column in table.columns:
            table[column] = [still_alive if _missing(v) else str(int(v)) for v in table[column]]
    text = csv_safe(table).to_csv(index=False, lineterminator="\n")
    atomic_write(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))
    return path


def _missing(value: object) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))


def _check_lineage(frame: object, columns: tuple[str, ...]) -> None:
    """`TypeError` in one line unless ``frame`` is a DataFrame with ``columns``."""
    wanted = f"pass lineage(run), or a frame with columns {', '.join(columns)}"
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"not a lineage but a {type(frame).__name__}: {wanted}")
    missing = [column for column in columns if column not in frame.columns]
    if missing:
        raise TypeError(f"not a lineage: the frame has no column {missing[0]!r}; {wanted}")


def _parent_map(frame: pd.DataFrame) -> dict[int, list[int]]:
    """id -> its ancestors' ids, from ``ancestor_list``."""
    return {
        int(i): parse_ancestor_list(text)
        for i, text in zip(frame["id"], frame["ancestor_list"], strict=True)
    }


def ancestors(frame: pd.DataFrame, id: int | str) -> list[int]:
    """The ancestors of taxon ``id`` in ``frame``: its parents, then their parents, and so on
    back to the founders; each id once, nearest first (breadth first; in an asexual lineage,
    the chain parent, grandparent, ..., founder).

    Args:
        frame: A lineage (`lineage`, or any frame with ``id`` and ``ancestor_list``).
        id: The taxon's ``id``, or a ``body_id`` (``"b000052"``).

    Returns:
        The ancestors' ids; empty for a founder.

    Raises:
        KeyError: When ``frame`` has no such taxon.
    """
    _check_lineage(frame, ("id", "ancestor_list", *(("body_id",) if isinstance(id, str) else ())))
    if isinstance(id, str):
        found = frame.loc[frame["body_id"] == id, "id"]
        if not len(found):
            raise KeyError(f"no body {id!r} in the lineage")
        id = int(found.iloc[0])
    parents = _parent_map(frame)
    if id not in parents:
        raise KeyError(f"no taxon {id} in the lineage")
    chain: list[int] = []
    seen, queue = {id}, deque(parents[id])
    while queue:
        current = queue.popleft()
        if current in seen:
            continue
        seen.add(current)
        chain.append(current)
        queue.extend(parents.get(current, []))
    return chain


def _depths(parents: Mapping[int, list[int]]) -> dict[int, int]:
    """id -> the parent steps on its longest chain back to a founder (0 for a founder).
    Ancestors not in ``parents`` are left out, as the standard reads them; a cycle is a
    `ValueError`."""
    depth: dict[int, int] = {}
    on_path: set[int] = set()
    for start in parents:
        if start in depth:
            continue
        stack = [(start, iter(parents[start]))]
        on_path.add(start)
        while stack:
            node, pending = stack[-1]
            parent = next((p for p in pending if p in parents and p not in depth), None)
            if parent is None:
                known = [depth[p] for p in parents[node] if p in depth]
                depth[node] = 1 + max(known) if known else 0
                on_path.discard(node)
                stack.pop()
            elif parent in on_path:
                raise ValueError(f"the lineage has a cycle through taxon {parent}")
            else:
                on_path.add(parent)
                stack.append((parent, iter(parents[parent])))
    return depth


def _founders(
    parents: Mapping[int, list[int]], depth: Mapping[int, int]
) -> dict[int, frozenset[int]]:
    """id -> the founders (taxa without ancestors in ``parents``) it descends from: itself,
    for a founder."""
    roots: dict[int, frozenset[int]] = {}
    for node in sorted(parents, key=depth.__getitem__):  # parents before their children
        known = [p for p in parents[node] if p in parents]
        roots[node] = frozenset().union(*(roots[p] for p in known)) if known else frozenset({node})
    return roots


def lineage_statistics(
    frame: pd.DataFrame, *, maximise: bool | None = None, generations: int | None = None
) -> pd.DataFrame:
    """Per generation, how many lineages survive and how deep the best body's ancestry is.

    A body is alive at generation ``g`` when ``origin_time <= g < destruction_time`` (an empty
    ``destruction_time``: still alive), that is when it is in the population after ``g``'s
    selection. A founder is a taxon without ancestors (``[none]``): a GA's or MAP-Elites'
    generation-0 body; random search makes every body a founder.

    Columns: ``generation``; ``alive`` (bodies alive); ``surviving_lineages`` (distinct
    founders with a living descendant, a living founder counting as its own descendant; a
    body of two parents descends from the founders of both); ``best_id`` and
    ``best_fitness`` (the living body of the best finite ``fitness``, the lowest ``id`` on a
    tie; ``<NA>`` / NaN when none is finite; a body has one fitness here, so a brain-only run's
    one body has its last in every generation); ``best_depth`` (parent steps on the longest
    chain from the best body back to a founder: 0 for a founder, its number of ancestors in an
    asexual lineage).

    Args:
        frame: A lineage (`lineage`): ``id``, ``ancestor_list``, ``origin_time``,
            ``destruction_time`` and ``fitness``.
        maximise: Whether higher fitness is better; None takes ``frame.attrs["maximise"]``
            (set by `lineage`).
        generations: The run's finished generations (the living are alive through the
            last); None takes ``frame.attrs["generations"]`` (set by `lineage`), else the
            last generation in which a body was made or died.

    Returns:
        A DataFrame, one row per generation from the first ``origin_time`` to the last.

    Raises:
        ValueError: When ``maximise`` is None and ``frame`` does not record it, or the
            lineage has a cycle.
        TypeError: When ``maximise`` is not True, False or None.

    Example:
        ```python
        from ariel.recording import lineage_statistics, load_run

        stats = lineage_statistics(load_run("data/runs/my-run").lineage())
        print(stats[["generation", "surviving_lineages", "best_depth"]])
        ```
    """
    flag_argument("maximise", maximise, none=True, function="lineage_statistics")
    _check_lineage(frame, ("id", "ancestor_list", "origin_time", "destruction_time", "fitness"))
    if maximise is None:
        maximise = frame.attrs.get("maximise")
        if not isinstance(maximise, bool):
            raise ValueError("the frame does not say the fitness direction: pass maximise=")
    parents = _parent_map(frame)
    depth = _depths(parents)
    roots = _founders(parents, depth)
    ids = np.asarray(frame["id"], dtype=np.int64)
    origin = np.asarray(frame["origin_time"], dtype=np.float64)
    end = frame["destruction_time"].astype("Float64").fillna(np.inf).to_numpy(np.float64)
    fitness = np.asarray(frame["fitness"], dtype=np.float64)
    if generations is None:
        generations = frame.attrs.get("generations")
    if isinstance(generations, int):
        last = generations - 1
    else:  # the last generation a body was made in, or was alive in before it died
        last = int(max(np.max(origin, initial=-1), np.max(end[np.isfinite(end)] - 1, initial=-1)))
    rows = []
    for generation in range(int(np.min(origin, initial=0)), last + 1):
        living = np.flatnonzero((origin <= generation) & (generation < end))
        scored = living[np.isfinite(fitness[living])]
        best = None
        if len(scored):  # the best fitness, then the lowest id
            order = np.lexsort((ids[scored], -fitness[scored] if maximise else fitness[scored]))
            best = int(scored[order[0]])
        rows.append(
            {
                "generation": generation,
                "alive": len(living),
                "surviving_lineages": len(frozenset().union(*(roots[int(ids[k])] for k in living))),
                "best_id": None if best is None else int(ids[best]),
                "best_fitness": math.nan if best is None else float(fitness[best]),
                "best_depth": None if best is None else depth[int(ids[best])],
            }
        )
    out = pd.DataFrame(rows, columns=list(STATISTICS_COLUMNS))
    for column in ("best_id", "best_depth"):
        out[column] = out[column].astype("Int64")
    return out


def lineage_statistics_by_run(
    frames: Mapping[str, pd.DataFrame],
    *,
    maximise: bool | None = None,
    generations: int | None = None,
) -> pd.DataFrame:
    """`lineage_statistics` of several runs (a campaign's), one table.

    Args:
        frames: Run id -> that run's lineage (`lineage`; `campaign_lineages` makes them).
        maximise: Whether higher fitness is better; None takes each frame's
            ``attrs["maximise"]``.
        generations: Each run's finished generations; None takes each frame's
            ``attrs["generations"]`` (see `lineage_statistics`).

    Returns:
        The runs' statistics one after another, a ``run_id`` column first.
    """
    if not isinstance(frames, Mapping):
        raise TypeError(
            f"lineage_statistics_by_run takes run id -> lineage (a dict, as "
            f"campaign_lineages(campaign) makes), not a {type(frames).__name__}"
        )
    tables = []
    for run_id, frame in frames.items():
        table = lineage_statistics(frame, maximise=maximise, generations=generations)
        table.insert(0, "run_id", run_id)
        tables.append(table)
    if not tables:
        return pd.DataFrame(columns=["run_id", *STATISTICS_COLUMNS])
    return pd.concat(tables, ignore_index=True)


def campaign_lineages(campaign: Campaign) -> dict[str, pd.DataFrame]:
    """The lineage of every run of ``campaign``, by run id.

    Args:
        campaign: A campaign's records (`ariel.recording.load_campaign`).

    Returns:
        Run id (run.json's ``run_id``, else the run folder's name) -> `lineage` of that run,
        in the campaign's order.
    """
    out = {}
    for run in campaign.runs.values():
        run_id = run.info.get("run_id")
        out[run_id if isinstance(run_id, str) else run.path.name] = lineage(run)
    return out
