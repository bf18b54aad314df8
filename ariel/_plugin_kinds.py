"""The interfaces of the plugin kinds (`ariel.plugins`): one protocol per kind, as the engine
and the evolution loop call a plugin, and the `fitness_function` decorator.

Pure typing: importing this module imports no engine, MuJoCo or numpy (they are named for
type checkers only). `ariel.plugins` gives every name here; import them from there.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, runtime_checkable

if TYPE_CHECKING:
    import mujoco
    import networkx as nx
    import numpy as np

__all__ = [
    "BodyEncoder",
    "ClosedLoopController",
    "ControllerPlugin",
    "FitnessFunction",
    "OpenLoopController",
    "Policy",
    "World",
    "WorldFactory",
    "fitness_function",
]

F = TypeVar("F", bound=Callable[..., Any])


# --------------------------------------------------------------------------------------------
# Protocols, one per kind. The evaluation engine may refine the controller protocol.
# --------------------------------------------------------------------------------------------


@runtime_checkable
class BodyEncoder(Protocol):
    """Genotype operations of one body encoding; made by ``body_encoders.make(name, **options)``.

    Genotypes are plain data (numpy arrays, lists, dicts of those) so they can be stored in
    Parquet and sent to workers. Every operation draws only from the ``rng`` it is given.
    ``evolvable`` says whether ``mutate``/``crossover`` work: an encoder of fixed bodies (e.g.
    ``prebuilt``) sets it False and raises `NotImplementedError` from both (see `cannot_vary`);
    the co-evolution loop then evolves brains only. An encoder may also define
    ``build(genotype) -> CoreModule`` for bodies a graph cannot express; the engine then
    builds with it and uses ``decode`` only for the morphology descriptors. An encoder of
    array genotypes may declare their ``genotype_shape`` (e.g. ``(3, 64)``): a fixed genotype
    (``body.genotype``, perhaps from a file) is then checked against it before a run starts.
    """

    name: str
    evolvable: bool

    def random_genotype(self, rng: np.random.Generator) -> Any:
        """A new random genotype."""
        ...

    def mutate(self, genotype: Any, rng: np.random.Generator, **options: Any) -> Any:
        """A mutated copy of ``genotype`` (the input is left unchanged)."""
        ...

    def crossover(self, a: Any, b: Any, rng: np.random.Generator) -> Any:
        """One child genotype from parents ``a`` and ``b``."""
        ...

    def decode(self, genotype: Any) -> nx.DiGraph:
        """The robot graph (the tutorial's module graph: a tree rooted at the core, node 0)."""
        ...


@runtime_checkable
class World(Protocol):
    """A world: an ``MjSpec`` to compile and a ``spawn`` that places a robot in it."""

    spec: mujoco.MjSpec

    def spawn(self, robot_spec: mujoco.MjSpec, *args: Any, **kwargs: Any) -> Any:
        """Attach ``robot_spec`` to the world (position, rotation: see the world's docs)."""
        ...


class WorldFactory(Protocol):
    """What the ``worlds`` registry holds: ``worlds.make(name, **options)`` gives a `World`."""

    def __call__(self, **options: Any) -> World: ...


@runtime_checkable
class ControllerPlugin(Protocol):
    """A brain family; made by ``controllers.make(name, **options)``.

    Parameters are flat float vectors; a batch is a ``(B, P)`` array. ``model`` is the compiled
    ``mujoco.MjModel`` of the robot in its world (``model.nu`` actuators). Whether the plugin
    is `OpenLoopController` or `ClosedLoopController` is said by ``open_loop``.
    """

    open_loop: bool

    def num_parameters(self, model: mujoco.MjModel) -> int:
        """Length P of one parameter vector for this body."""
        ...

    def random_parameters(
        self, model: mujoco.MjModel, rng: np.random.Generator, n: int
    ) -> np.ndarray:
        """``(n, P)`` random parameter vectors (e.g. CMA-ES initial means)."""
        ...


@runtime_checkable
class OpenLoopController(ControllerPlugin, Protocol):
    """Controls as a function of time only: the engine precomputes them, vectorised."""

    def targets(
        self, params: np.ndarray, sample_times: np.ndarray, model: mujoco.MjModel, *, seed: int
    ) -> np.ndarray:
        """Actuator targets ``(B, T, nu)`` for params ``(B, P)`` at ``sample_times`` ``(T,)``.

        ``seed`` is exactly one Python ``int``, the evaluation's seed (for e.g. an oscillator's
        random initial state: ``np.random.default_rng(seed)``). The engine groups a batch's
        candidates by seed and calls this once per distinct seed, so each row must depend only
        on its own parameters and the seed. An optional ``iter_targets(params, sample_times,
        model, *, seed, chunks)`` yields the same array in pieces along time.
        """
        ...


class Policy(Protocol):
    """One closed-loop brain with fixed parameters."""

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """Actuator targets ``(nu,)`` for one observation vector (built by the engine)."""
        ...


@runtime_checkable
class ClosedLoopController(ControllerPlugin, Protocol):
    """Controls from observations; the engine calls the policy once per control period."""

    def make_policy(self, params: np.ndarray, model: mujoco.MjModel) -> Policy:
        """A policy for one parameter vector ``(P,)``."""
        ...


@runtime_checkable
class FitnessFunction(Protocol):
    """Scores one evaluation's trajectory record; ``maximise`` says which way is better. An
    optional ``unit`` (a string such as ``"m"``) labels the fitness axes of `ariel report`."""

    maximise: bool

    def __call__(self, trajectory: Any) -> float: ...


def fitness_function(*, maximise: bool, unit: str | None = None) -> Callable[[F], F]:
    """Decorator that marks a plain function as a fitness function.

    It sets the function's ``maximise`` and ``unit`` attributes and returns the function
    itself; register it under a name to use it (``fitness_functions.register``).

    Args:
        maximise: True if larger values are better, False if smaller ones are.
        unit: The fitness's unit, e.g. ``"m"`` (it labels the fitness axes of ``ariel
            report``); None (the default) where it has none.

    Returns:
        The decorator: it takes the function and returns it, marked.

    Raises:
        TypeError: ``maximise`` is not a bool, or ``unit`` is neither a string nor None.

    Example:
        ```python
        from ariel.plugins import fitness_function, fitness_functions


        @fitness_functions.register("final_height")
        @fitness_function(maximise=True, unit="m")
        def final_height(record) -> float:  # the core's height at the end of the run
            return float(record.core_pos[-1, 2])


        print(final_height.maximise, final_height.unit)  # True m
        ```
    """
    if not isinstance(maximise, bool):
        raise TypeError(f"maximise must be True or False, not {maximise!r}")
    if unit is not None and not isinstance(unit, str):
        raise TypeError(f"unit must be a string or None, not {unit!r}")

    def mark(fn: F) -> F:
        fn.maximise = maximise  # type: ignore[attr-defined]
        fn.unit = unit  # type: ignore[attr-defined]
        return fn

    return mark
