"""What every plugin check uses: `Checker` (one-line failures naming the plugin), the reference
body and seeds, the plain-data and protocol checks, and the gecko's reference run.

The checks themselves: `ariel.evaluation._checks`, which re-exports these names.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator, Mapping
from typing import Any, NoReturn

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.constructor import validate_robot_graph
from ariel.errors import PluginCheckError
from ariel.evaluation._build import _one_line, build
from ariel.evaluation._rollouts import _open_loop
from ariel.evaluation._task import BodySpec, EvaluationResult, EvaluationTask, _plain
from ariel.evaluation.builtin_plugins import NaCPGController
from ariel.plugins import BodyEncoder

__all__ = ["CHECK_SEED", "Checker", "call_text"]

#: The body every world, controller and fitness check runs (8 hinges, flat world).
CHECK_BODY = BodySpec("prebuilt", "gecko")
#: Simulated seconds of each check's evaluations: enough to move, short enough to be cheap.
CHECK_DURATION = 0.5
CHECK_SEED = 12345
CHECK_CANDIDATES = 3


class Checker:
    """Failure messages that all start with the plugin, e.g. ``controller 'sine': ...``."""

    def __init__(self, label: str, name: str) -> None:
        self.prefix = f"{label} {name!r}"

    def fail(self, what: str) -> NoReturn:
        raise PluginCheckError(f"{self.prefix}: {what}")

    def expect(self, condition: object, what: str) -> None:
        if not condition:
            self.fail(what)

    @contextlib.contextmanager
    def step(self, what: str) -> Iterator[None]:
        """Any exception inside becomes a one-line `PluginCheckError` saying which call raised."""
        try:
            yield
        except PluginCheckError:
            raise
        except Exception as exc:
            raise PluginCheckError(f"{self.prefix}: {what} raised {_one_line(exc)}") from exc


def call_text(options: Mapping[str, object]) -> str:
    return f"make(**{options})" if options else "make()"


def _rng(seed: int = CHECK_SEED) -> np.random.Generator:
    return np.random.default_rng(seed)


def _same(a: object, b: object) -> bool:
    """Equal as plain data (arrays compared by value)."""
    return bool(_plain(a) == _plain(b))


def _plain_round_trip(check: Checker, genotype: Any, what: str) -> Any:
    """``genotype`` as the plain data stored in Parquet and sent to workers (via JSON)."""
    with check.step(f"storing the {what} genotype as plain data (JSON)"):
        plain = _plain(genotype)
        back = json.loads(json.dumps(plain, allow_nan=False))
    check.expect(back == plain, f"the {what} genotype does not survive a JSON round trip")
    return back


def _decoded(check: Checker, encoder: BodyEncoder, genotype: Any, what: str) -> nx.DiGraph:
    with check.step(f"decode({what})"):
        graph = encoder.decode(genotype)
    check.expect(
        isinstance(graph, nx.DiGraph),
        f"decode({what}) returned {type(graph).__name__}, not a networkx.DiGraph",
    )
    with check.step(f"validating the robot graph of decode({what})"):
        validate_robot_graph(graph)
    return graph


def _expect_methods(check: Checker, plugin: object, names: tuple[str, ...]) -> None:
    for method in names:
        check.expect(callable(getattr(plugin, method, None)), f"has no method {method}()")


def _expect_bool(check: Checker, plugin: object, attribute: str, hint: str = "") -> None:
    value = getattr(plugin, attribute, None)
    check.expect(
        isinstance(value, bool), f"needs a bool attribute {attribute!r}, not {value!r}{hint}"
    )


def _expect_same_results(
    check: Checker, first: list[EvaluationResult], again: list[EvaluationResult]
) -> None:
    for a, b in zip(first, again):
        check.expect(a.status == "ok", f"the gecko's evaluation ended {a.status!r}: {a.error}")
        same = (
            a.fitness == b.fitness
            and np.array_equal(a.joint_target, b.joint_target)
            and np.array_equal(a.core_pos, b.core_pos)
        )
        check.expect(same, "the same evaluation task gave different results when run again")


def _gecko_params(count: int = CHECK_CANDIDATES) -> np.ndarray:
    """Parameters of the reference brain for the gecko (world and fitness checks drive it)."""
    model = build(EvaluationTask(body=CHECK_BODY)).model
    return NaCPGController().random_parameters(model, _rng(), count)


def _run_gecko(
    tasks: list[EvaluationTask],
    fitness_fn: Any,  # a FitnessFunction (a marked function's maximise is set at run time)
) -> list[EvaluationResult]:
    """Evaluate ``tasks`` (one body, one world) with the reference brain and ``fitness_fn``.

    The engine's own rollout of a batch, given the objects instead of the tasks' registry
    names, so a replaced "na_cpg" or "xy_displacement" cannot break a world's or a fitness
    function's check.
    """
    return _open_loop(tasks, build(tasks[0]), NaCPGController(), fitness_fn, nthread=1)
