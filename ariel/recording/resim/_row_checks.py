"""What a replay, an export or a drawing checks of an evaluation's row before it builds
anything from it: the cells of a changed or crafted table are refused in one line
(`DamagedRunError`, naming the run folder, the evaluation, the table and the column), never
used.

- its ids have their shapes (`check_eval_id`: ASCII digits, not too many), and its body id
  is its evaluation id's;
- its plugin names (``body_encoder``, ``controller``, ``world``, ``fitness_fn``) are the run's
  config's: what is rebuilt takes them from the config, and a row that names others was
  changed;
- its ``seed`` is a non-negative integer (numpy refuses a negative one);
- its body is no larger than the run's body encoder makes one (`module_limit`): a crafted
  graph of 20,000 modules would take minutes and GBs to build; a genotype no longer than
  the encoder's shape (``genotype_shape``, the NDE's).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Integral
from typing import TYPE_CHECKING

from ariel.errors import DamagedRunError
from ariel.plugins import body_encoders
from ariel.recording.store import check_body_id, check_eval_id, short_ascii

if TYPE_CHECKING:
    from ariel.evaluation import BodySpec
    from ariel.evolution import ExperimentConfig
    from ariel.recording.store import Run

__all__ = ["MOST_MODULES", "check_body_size", "check_row", "module_limit"]

#: The most modules of a body whose encoder states no limit of its own (no
#: ``number_of_modules`` or ``max_modules``: the ``graph`` encoder without a genotype in the
#: config, a plugin's). Building takes about 10 s for 1,000 modules, 27 s for 2,000.
MOST_MODULES = 1000
#: The largest seed a row may hold (the table's column is int64).
_LARGEST_SEED = 2**63 - 1
#: Row column -> (config section, key) of the plugin names a row repeats.
_NAMES = {
    "body_encoder": ("body", "encoder"),
    "controller": ("brain", "controller"),
    "world": ("world", "name"),
    "fitness_fn": ("task", "fitness"),
}


def changed(run: Run, row: Mapping[str, object], table: str, problem: str) -> DamagedRunError:
    """The one line for evaluation ``row`` of ``run`` whose ``table`` holds ``problem``."""
    return DamagedRunError(
        f"evaluation {short_ascii(row.get('eval_id'))} of run {str(run.path)!r}: {problem}; "
        f"the {table} table was changed or damaged"
    )


def check_row(run: Run, row: Mapping[str, object], config: ExperimentConfig) -> int:
    """`DamagedRunError` where ``row``'s ids, plugin names or seed are not what the loop
    wrote (see the module); else its seed."""
    eval_id = check_eval_id(row.get("eval_id"), run.path)
    body_id = check_body_id(row.get("body_id"), run.path)
    if not eval_id.startswith(body_id + "-"):  # b000012-i003-c005 evaluates body b000012
        raise changed(run, row, "evaluations", f"its body_id {body_id!r} is not its evaluation's")
    for column, (section, key) in _NAMES.items():
        value, wanted = row.get(column), getattr(getattr(config, section), key)
        if value is None or (isinstance(value, float) and math.isnan(value)):
            continue  # not recorded (a drawing's row may lack it): the config's is used
        if not isinstance(value, str) or value != wanted:
            raise changed(
                run,
                row,
                "evaluations",
                f"its {column} {short_ascii(value)} is not the run's {short_ascii(wanted)} "
                f"(run.json's {section}.{key})",
            )
    return _seed(run, row)


def _seed(run: Run, row: Mapping[str, object]) -> int:
    """The row's seed: an integer (numpy's too) from 0 to the column's largest."""
    seed = row.get("seed")
    number = int(seed) if isinstance(seed, Integral) and not isinstance(seed, bool) else -1
    if not 0 <= number <= _LARGEST_SEED:
        raise changed(
            run, row, "evaluations", f"its seed {short_ascii(seed)} is not a non-negative integer"
        )
    return number


def module_limit(config: ExperimentConfig) -> tuple[int, str]:
    """The most modules a body of a run with ``config`` has, and where that limit is from:
    its body encoder's ``number_of_modules`` or ``max_modules``; else, for a run with a
    fixed robot graph (``body.genotype``), that graph's; else `MOST_MODULES`."""
    encoder = body_encoders.make(config.body.encoder, **config.body.options)
    for name in ("number_of_modules", "max_modules"):
        value = getattr(encoder, name, None)
        if isinstance(value, int) and not isinstance(value, bool) and value > 0:
            return value, f"its body encoder {config.body.encoder!r} makes ({name} = {value})"
    nodes = _nodes(config.body.genotype)
    if nodes is not None:
        return max(nodes, 1), "the run's robot graph has (body.genotype)"
    return MOST_MODULES, f"a body of body encoder {config.body.encoder!r} may have here"


def _nodes(graph: object) -> int | None:
    """How many modules (nodes) and links (edges), whichever is more, node-link data holds;
    None for anything else."""
    if not isinstance(graph, Mapping) or not isinstance(graph.get("nodes"), list):
        return None
    edges = graph.get("edges", graph.get("links"))
    return max(len(graph["nodes"]), len(edges) if isinstance(edges, list) else 0)


def _leaves(value: object, most: int) -> int:
    """How many numbers (and other scalars) the JSON ``value`` holds, counted up to
    ``most + 1`` at most."""
    count, pending = 0, [value]
    while pending and count <= most:
        item = pending.pop()
        if isinstance(item, list):
            pending.extend(item)
        elif isinstance(item, Mapping):
            pending.extend(item.values())
        else:
            count += 1
    return count


def check_body_size(
    run: Run, row: Mapping[str, object], body: BodySpec, config: ExperimentConfig, table: str
) -> None:
    """`DamagedRunError` where ``body`` (a genotype of the config's encoder, or the robot
    graph it decodes to: encoder ``graph``) is larger than a body of the run can be
    (`module_limit`; a genotype: the encoder's ``genotype_shape``), before it is built.
    ``table``: where it was read (``evaluations``: a genotype, ``bodies``: a graph)."""
    if body.encoder == "graph":
        most, why = module_limit(config)
        size = _nodes(body.genotype)
        if size is not None and size > most:
            problem = f"its body has {size:,} modules, more than the {most:,} {why}"
            raise changed(run, row, table, problem)
        return
    shape = getattr(body_encoders.make(body.encoder, **dict(body.options)), "genotype_shape", None)
    if isinstance(shape, tuple) and all(isinstance(n, int) for n in shape):
        most = math.prod(shape)
        if _leaves(body.genotype, most) > most:
            problem = (
                f"its body_genotype holds more than the {most:,} genes of body encoder "
                f"{body.encoder!r} ({' x '.join(map(str, shape))})"
            )
            raise changed(run, row, table, problem)
