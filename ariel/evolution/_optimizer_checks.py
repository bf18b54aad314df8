"""`check_body_optimizer` and `check_brain_optimizer`: the optimizers' contracts, tested without
physics; and `check_all` over every plugin kind (`ariel plugins --check`): the engine's
plugins (`ariel.evaluation.check_engine_plugins`), then the optimizers.

The check drives the optimizer for three generations on made-up bodies (genotypes are short
vectors from a checker encoder; a body's fitness and descriptors are functions of its
genotype), so it takes milliseconds and tests only the optimizer: it must make a
`BodyOptimizer`, ask for the number of genotypes asked for (plain data, parents taken from what
it keeps), keep bodies it was told about, ask the same for the same seed, and give plain-data
state from which a fresh optimizer asks exactly what it would have.

The brain optimizer check runs a learner for a few iterations on a made-up fitness of its
candidates (a sphere, one candidate failing with NaN): it must make a `BrainOptimizer`, ask
``popsize`` finite candidates of the parameter count, ask the same for the same seed, and give
plain-data state from which a fresh learner asks exactly what it would have.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel.body_phenotypes.robogen_lite.descriptors import DESCRIPTOR_NAMES
from ariel.evaluation import CHECK_SEED, Checker, call_text, check_engine_plugins, check_rows
from ariel.evolution._brain import BrainOptimizer
from ariel.evolution._config import BodyConfig
from ariel.evolution._optimizer import BodyOptimizer, Proposal
from ariel.evolution._state import BodiesSeen, Body, from_json_safe, to_json_safe
from ariel.plugins import body_optimizers, brain_optimizers

if TYPE_CHECKING:
    import networkx as nx

__all__ = ["check_all", "check_body_optimizer", "check_brain_optimizer"]

_GENERATIONS = 3
_SIZE = 4  # bodies asked for per generation


class _VectorEncoder:
    """Genotypes of four numbers; every operation draws only from the rng it is given."""

    name = "check-vectors"
    evolvable = True

    def random_genotype(self, rng: np.random.Generator) -> list[float]:
        return rng.uniform(-1.0, 1.0, 4).tolist()

    def mutate(
        self, genotype: list[float], rng: np.random.Generator, **options: object
    ) -> list[float]:
        return (np.asarray(genotype, dtype=float) + rng.normal(0.0, 0.2, 4)).tolist()

    def crossover(self, a: list[float], b: list[float], rng: np.random.Generator) -> list[float]:
        return np.where(rng.random(4) < 0.5, a, b).tolist()

    def decode(self, genotype: list[float]) -> nx.DiGraph:
        raise NotImplementedError("the optimizer check makes no bodies")


def _body(number: int, proposal: Proposal, generation: int) -> Body:
    """A made-up body: fitness and descriptors are functions of the genotype."""
    g = np.asarray(proposal.genotype, dtype=float)
    descriptors = {name: float(abs(g[i % 4])) % 1.0 for i, name in enumerate(DESCRIPTOR_NAMES)}
    descriptors["num_limbs"] = float(int(abs(g[0]) * 4) % 8)
    body = Body(number, proposal.genotype, list(proposal.parent_ids), generation)
    body.descriptors, body.n_joints = descriptors, int(abs(g[1]) * 6) % 12
    body.fitness = float(-np.sum(g**2))
    return body


def _make(
    check: Checker, factory: Callable[..., BodyOptimizer], options: dict[str, object]
) -> BodyOptimizer:
    settings = BodyConfig(population=_SIZE, offspring=_SIZE, tournament=2)
    with check.step(f"making it ({call_text(options)})"):
        optimizer = factory(
            encoder=_VectorEncoder(), seed=CHECK_SEED, maximise=True, settings=settings, **options
        )
    check.expect(
        isinstance(optimizer, BodyOptimizer),
        "is no BodyOptimizer (needs population, ask, tell, state, restore)",
    )
    return optimizer


def _generation(
    check: Checker, optimizer: BodyOptimizer, generation: int, told: dict[str, Body]
) -> list[str]:
    """One ask/tell round; returns the genotypes asked for (as JSON text)."""
    kept = {b.body_id for b in optimizer.population}
    held = BodiesSeen(optimizer.population)
    with check.step(f"ask({_SIZE}) in generation {generation}"):
        proposals = list(optimizer.ask(_SIZE))
    changed = held.changed()
    check.expect(changed is None, f"ask(...) changed {changed}: it may read the bodies, not write")
    check.expect(len(proposals) == _SIZE, f"ask({_SIZE}) gave {len(proposals)} genotypes")
    asked = []
    for proposal in proposals:
        with check.step("storing an asked genotype as plain data (JSON)"):
            asked.append(json.dumps(proposal.genotype, allow_nan=False))
        unknown = set(proposal.parent_ids) - kept
        check.expect(not unknown, f"a child's parents {sorted(unknown)} are not in its population")
    bodies = [_body(len(told) + k, p, generation) for k, p in enumerate(proposals)]
    told.update({b.body_id: b for b in bodies})
    seen = BodiesSeen([*optimizer.population, *bodies])
    with check.step(f"tell(...) in generation {generation}"):
        optimizer.tell(bodies)
    changed = seen.changed()
    check.expect(changed is None, f"tell(...) changed {changed}: it may read the bodies, not write")
    population = optimizer.population
    check.expect(population, f"keeps no body after generation {generation}")
    check.expect(
        {b.body_id for b in population} <= set(told),
        "keeps bodies it was never told about",
    )
    return asked


# Any: an `ArchiveOptimizer` in all but the members this check does not read (`stats`, ...).
def _check_description(check: Checker, optimizer: Any) -> None:
    """The archive's description: plain data (JSON) of a known kind, a cell per row's cell."""
    with check.step("archive_description() as plain data (JSON)"):
        described = json.loads(json.dumps(optimizer.archive_description(), allow_nan=False))
    kind = described.get("kind") if isinstance(described, dict) else None
    check.expect(kind in ("grid", "cvt"), f"archive_description() has kind {kind!r}")
    key = "bins" if kind == "grid" else "centroids"
    check.expect(
        {"measures", "ranges", key} <= set(described),
        f"archive_description() of a {kind} lacks measures, ranges or {key}",
    )
    cells = np.prod(described["bins"]) if kind == "grid" else len(described["centroids"])
    rows = optimizer.archive_rows()
    check.expect(
        all(0 <= row["cell"] < cells for row in rows),
        f"archive_rows() has a cell outside the {cells} cells described",
    )


def check_body_optimizer(name: str, /, **options: object) -> None:
    """Check body optimizer ``name`` made with ``options``; raise `PluginCheckError` if broken.

    Three generations of four bodies on made-up genotypes (milliseconds, no physics): it asks
    for as many genotypes as asked, as plain data, with parents from its population; keeps
    only bodies it was told about; asks the same for the same seed; and its plain-data
    ``state()`` restores to the same next ``ask``. A run checks its own this way before
    anything is written.

    Args:
        name: The body optimizer's registry name (an entry point's name works too).
        **options: Keyword arguments passed to its factory (``body.optimizer_options``).

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the optimizer itself, or an unknown ``name``, included).
    """
    check = Checker("body optimizer", name)
    with check.step("loading it"):
        factory = body_optimizers.get(name)
    runs = []
    for _ in range(2):  # the same seed twice: the same genotypes
        optimizer, told = _make(check, factory, options), {}
        runs.append([_generation(check, optimizer, g, told) for g in range(_GENERATIONS)])
    check.expect(runs[0] == runs[1], "asks for different genotypes with the same seed")
    if hasattr(optimizer, "archive_description"):  # a quality-diversity archive
        _check_description(check, optimizer)
    with check.step("state()"):
        state = json.loads(json.dumps(optimizer.state(), allow_nan=False))
    restored = _make(check, factory, options)
    with check.step("restore(state, population)"):
        restored.restore(state, optimizer.population)
    with check.step(f"ask({_SIZE}) after restore"):
        again = [json.dumps(p.genotype) for p in restored.ask(_SIZE)]
    expected = [json.dumps(p.genotype) for p in optimizer.ask(_SIZE)]
    check.expect(again == expected, "asks for other genotypes after restore(state(), population)")


_BRAIN = {"popsize": 6, "sigma0": 0.5, "maximise": True}  # and x0: five parameters
_ITERATIONS = 4


def _brain_fitness(params: np.ndarray, iteration: int) -> np.ndarray:
    """A sphere around 1 (maximised); in iteration 1 the last candidate fails (NaN)."""
    fitness = -np.sum((params - 1.0) ** 2, axis=1)
    if iteration == 1:
        fitness[-1] = np.nan
    return fitness


def _learn(
    check: Checker, factory: Callable[..., BrainOptimizer], options: dict[str, object], seed: int
) -> tuple[BrainOptimizer, list[bytes]]:
    """A learner made and run for `_ITERATIONS` iterations: (learner, its asks as bytes)."""
    x0 = np.linspace(-0.5, 0.5, 5)
    with check.step(f"making it ({call_text(options)})"):
        learner = factory(x0=x0, seed=seed, **_BRAIN, **options)
    check.expect(
        isinstance(learner, BrainOptimizer),
        "is no BrainOptimizer (needs ask, tell, state, restore)",
    )
    asked = []
    for iteration in range(_ITERATIONS):
        with check.step(f"ask() in iteration {iteration}"):
            params = np.asarray(learner.ask(), dtype=np.float64)
        check.expect(
            params.shape == (_BRAIN["popsize"], len(x0)),
            f"ask() gave shape {params.shape}, not (popsize, parameters) = "
            f"({_BRAIN['popsize']}, {len(x0)})",
        )
        check.expect(np.isfinite(params).all(), "ask() gave non-finite candidates")
        asked.append(params.tobytes())
        with check.step(f"tell(...) in iteration {iteration}"):
            learner.tell(params, _brain_fitness(params, iteration))
    return learner, asked


def check_brain_optimizer(name: str, /, **options: object) -> None:
    """Check brain optimizer ``name`` made with ``options``; raise `PluginCheckError` if broken.

    Four iterations of a made-up fitness of five parameters, one candidate failing with NaN:
    it asks for ``popsize`` finite candidates, asks the same for the same seed, and its
    plain-data ``state()`` restores to the same next ``ask``. A run checks its own this way
    before anything is written.

    Args:
        name: The brain optimizer's registry name (an entry point's name works too).
        **options: Keyword arguments passed to its factory (``brain.optimizer_options``).

    Raises:
        PluginCheckError: The first broken part of the contract, in one line naming the plugin
            (an exception raised by the learner itself, or an unknown ``name``, included).
    """
    check = Checker("brain optimizer", name)
    with check.step("loading it"):
        factory = brain_optimizers.get(name)
    learner, asked = _learn(check, factory, options, CHECK_SEED)
    check.expect(
        _learn(check, factory, options, CHECK_SEED)[1] == asked,
        "asks for different candidates with the same seed",
    )
    with check.step("state()"):
        state = from_json_safe(
            json.loads(json.dumps(to_json_safe(learner.state()), allow_nan=False))
        )
    with check.step(f"making it ({call_text(options)})"):
        restored = factory(x0=np.linspace(-0.5, 0.5, 5), seed=CHECK_SEED, **_BRAIN, **options)
    with check.step("restore(state)"):
        restored.restore(state)
    with check.step("ask() after restore"):
        again = np.asarray(restored.ask(), dtype=np.float64).tobytes()
    expected = np.asarray(learner.ask(), dtype=np.float64).tobytes()
    check.expect(again == expected, "asks for other candidates after restore(state())")


def check_all() -> list[tuple[str, str, str | None]]:
    """Check every registered name of every plugin kind, entry points included, with default
    options: body encoders, worlds, controllers and fitness functions
    (`ariel.evaluation.check_engine_plugins`), then body and brain optimizers. What
    ``ariel plugins --check`` prints; also ``ariel.plugins.check_all``.

    Nothing is raised for a broken plugin: an entry point that fails to load, or clashes with
    another provider, is reported as its row's error.

    Returns:
        One ``(kind, name, error or None)`` row per name, kinds in `ariel.plugins.REGISTRIES`
        order and names sorted; ``error`` is the one-line failure message, None for a plugin
        that passed.
    """
    return check_engine_plugins() + check_rows(
        (
            ("body_optimizer", body_optimizers, check_body_optimizer),
            ("brain_optimizer", brain_optimizers, check_brain_optimizer),
        )
    )
