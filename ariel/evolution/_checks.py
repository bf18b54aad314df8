"""Checks a run passes before anything is written, and the one line for a plugin that fails.

* `refuse_in_spawned_child`: ``run_experiment`` called from the top level of a script that a
  process pool's worker imports again (spawn / forkserver start methods re-run ``__main__``
  without ``if __name__ == "__main__":``) would start a run in every worker.
* `check_plugins`: the ``ariel plugins --check`` checks of the configured plugins, body and
  brain optimizers included, with the config's options (cached per process: a campaign checks
  each plugin once, and a plugin registered again under its name is checked again).
* `check_resources`: the memory one generation needs, estimated from a sample body of the
  experiment, against what this machine has.
* `plugin_failure`: a plugin that raises during a run stops it with one line naming the plugin
  and the evaluation; the full traceback goes to ``RUN/error.log``.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from ariel.errors import PluginFailedError
from ariel.evaluation import WORKER_CANNOT_START
from ariel.evolution._config import ConfigError, ExperimentConfig
from ariel.evolution._driver import per_body
from ariel.evolution._seeds import derive_rng
from ariel.evolution._tasks import body_spec, evaluation_task, record_steps

if TYPE_CHECKING:
    import mujoco

    from ariel.plugins import BodyEncoder

__all__ = [
    "PluginFailedError",
    "check_plugins",
    "check_resources",
    "machine_memory",
    "no_main_guard_line",
    "refuse_in_spawned_child",
]

ERROR_LOG = "error.log"
_CHECKED: set[str] = set()  # plugins (kind, name, options) that passed in this process


# --------------------------------------------------------------------------------------------
# A run started by a worker that re-imported the script
# --------------------------------------------------------------------------------------------


def refuse_in_spawned_child() -> None:
    """One line on stderr and exit code `WORKER_CANNOT_START` when this process is a
    multiprocessing child (a pool worker) re-importing the script: a script that calls
    ``run_experiment`` without ``if __name__ == "__main__":`` runs again in each worker the
    spawn and forkserver start methods start, which would start a run in each of them."""
    # (multiprocessing.parent_process() is still None while a child re-imports the script.)
    if not _importing_main_again():
        return  # a child that calls run_experiment from a function it was given is fine
    line = (no_main_guard_line() + "\n").encode(errors="replace")
    try:  # one write: the workers' lines never interleave (print writes the newline apart)
        sys.stderr.flush()
        os.write(sys.stderr.fileno(), line)
    except (AttributeError, OSError, ValueError):  # a stand-in stderr without a file
        print(no_main_guard_line(), file=sys.stderr, flush=True)
    # The pool sees this exit code and stops (`LocalPool`); `run_experiment` in the script's
    # own process then ends it quietly. Not an exception: a traceback per worker would bury
    # the line, and forkserver turns any exit of its child into code 1.
    os._exit(WORKER_CANNOT_START)


def no_main_guard_line() -> str:
    """The one line that says the script (``__main__``, or ``__mp_main__`` in a worker) needs
    an ``if __name__ == "__main__":`` guard."""
    main = sys.modules.get("__mp_main__") or sys.modules.get("__main__")
    script = getattr(main, "__file__", None) or "the script"
    return (
        f"ariel: error: a worker process re-imported {script}, whose top level calls "
        'run_experiment: put that code under `if __name__ == "__main__":`'
    )


def _importing_main_again() -> bool:
    """Whether a module-level frame of ``__mp_main__`` (the script, re-imported by spawn or
    forkserver in a worker) is on the stack: the call comes from the script's top level."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == "__mp_main__":
            return True
        frame = frame.f_back
    return False


# --------------------------------------------------------------------------------------------
# The configured plugins, checked with their options
# --------------------------------------------------------------------------------------------


# (config table, the plugin's key, its options' key, `ariel.plugins`' checker and registry)
_CHECKED_PLUGINS = (
    ("body", "encoder", "options", "check_body_encoder", "body_encoders"),
    ("world", "name", "options", "check_world", "worlds"),
    ("brain", "controller", "options", "check_controller", "controllers"),
    ("task", "fitness", "options", "check_fitness", "fitness_functions"),
    ("body", "optimizer", "optimizer_options", "check_body_optimizer", "body_optimizers"),
    ("brain", "optimizer", "optimizer_options", "check_brain_optimizer", "brain_optimizers"),
)


def check_plugins(config: ExperimentConfig, *, brain_only: bool = False) -> None:
    """Run the plugin checkers (`ariel.plugins.check_*`) on the plugins ``config`` names, with
    its options; the first failure is a `ConfigError` naming the plugin and the problem. A
    ``brain_only`` run's body optimizer is not checked: it asks none."""
    # ariel.recording.store._failures imports this module, for ERROR_LOG and plugin_named
    # lazy: the checkers run the engine: mujoco and the GL backend (ariel.utils._gl)
    from ariel import plugins

    for table_name, plugin_key, options_key, checker, registry in _CHECKED_PLUGINS:
        if brain_only and checker == "check_body_optimizer":
            continue
        table = getattr(config, table_name)
        name, options = getattr(table, plugin_key), getattr(table, options_key)
        # The key named: the plugin's options where there are any, else the plugin's own key.
        key = f"{table_name}.{options_key if options else plugin_key}"
        # With what is registered under the name now: a plugin registered again (a notebook
        # cell run again after an edit, replace=True) is checked again.
        registered = _registered_id(getattr(plugins, registry).get, name)
        token = json.dumps([checker, name, options, registered], sort_keys=True, default=repr)
        if token in _CHECKED:
            continue
        check = getattr(plugins, checker)
        try:
            check(name, **options)
        except plugins.PluginCheckError as exc:
            raise ConfigError(f"{key}: the plugin check failed: {exc}") from None
        _CHECKED.add(token)


def _registered_id(get: Callable[[str], object], name: str) -> int | None:
    """The identity of what a registry's ``get`` gives for ``name`` (None: it cannot load
    it; the check then says why)."""
    try:
        return id(get(name))
    except (KeyError, ValueError, ImportError):
        return None


# --------------------------------------------------------------------------------------------
# Memory
# --------------------------------------------------------------------------------------------

_GIB = 2.0**30


def machine_memory() -> int | None:
    """Bytes of memory this machine can give a run now (MemAvailable; else all of it)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as file:
            for line in file:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _sample_model(config: ExperimentConfig, encoder: BodyEncoder) -> mujoco.MjModel | None:
    """A compiled body of this experiment (its first generation-0 body, or the fixed one)."""
    # lazy: the engine imports mujoco and with it the GL backend (ariel.utils._gl)
    from ariel.evaluation import BodyBuildError, build

    genotype = config.body.genotype
    if genotype is None:
        genotype = encoder.random_genotype(derive_rng(config.seed, "body-init", 0))
    try:
        return build(evaluation_task(config, body_spec(config, genotype))).model
    except BodyBuildError:
        return None


#: Memory one evaluation takes in its generation's Rerun recording, made when the generation
#: ends (its trace, the recording's chunks): about 0.1 MB, measured with 200 to 20,000
#: evaluations a generation (probe G3: 93 to 150 KB), which the estimate had left out.
RERUN_BYTES_PER_EVALUATION = 100_000


def check_resources(
    config: ExperimentConfig,
    encoder: BodyEncoder,
    *,
    brain_only: bool,
    capacity: int,
    local_workers: bool,
) -> int | None:
    """The bytes of memory one generation needs, estimated from a sample body (None: no body
    to measure); `ConfigError` when that is more than this machine has (the estimate is in
    the message).

    Counted: the recorded frames of a generation's evaluations, which the driver keeps until
    the generation's tables are written (with ``record.trajectories``); the physics states of
    the evaluations running at once (``local_workers``: on this machine); the compiled bodies;
    with ``record.rerun``, each evaluation's share of the generation's recording
    (`RERUN_BYTES_PER_EVALUATION`).
    """
    model = _sample_model(config, encoder)
    if model is None:  # no body to measure: the run records it as an error body
        return None
    c = config
    timestep = float(model.opt.timestep)
    steps = max(1, round(c.task.duration / timestep))  # as the engine's `num_steps`
    frames = steps // record_steps(c, timestep) + 2
    nu, nbody = int(model.nu), int(model.nbody)
    state = 1 + model.nq + model.nv + model.na + 6 * nbody + model.nmocap * 7 + model.neq
    bodies = 1 if brain_only else max(c.body.population, c.body.offspring)
    popsize = c.brain.popsize
    evaluations = bodies * per_body(c)  # one generation's
    per_frame = 8 * (4 + 2 * nu + (7 * nbody if c.record.rerun else 0))
    kept = evaluations * frames * 8 * (4 + 2 * nu) if c.record.trajectories else 0
    at_once = min(bodies * popsize, max(1, capacity) * popsize)
    running = at_once * (steps * 8 * (state + nu) + frames * per_frame) if local_workers else 0
    models = (c.body.population + c.body.offspring) * (int(model.nbuffer) + 2**16)
    recorded = evaluations * RERUN_BYTES_PER_EVALUATION if c.record.rerun else 0
    needed = 2 * kept + running + models + recorded  # 2x: the frames are copied once
    available = machine_memory()
    if available is None or needed <= available:
        return needed
    parts = [
        f"{evaluations} evaluations a generation x {frames} recorded frames"
        if kept
        else f"{at_once} evaluations at once x {steps} physics steps",
        f"{nu} joints, {nbody} bodies in a sample body",
    ]
    raise ConfigError(
        f"{_largest_key(c)}: one generation would need about {needed / _GIB:.1f} GiB of memory "
        f"({'; '.join(parts)}); this machine has {available / _GIB:.1f} GiB available: "
        f"{_remedies(kept, running, recorded)}"
    )


def _remedies(kept: int, running: int, recorded: int = 0) -> str:
    """What would make the estimate smaller, for the parts it has: the kept frames (only with
    ``record.trajectories``), the physics states of the evaluations at once, the compiled
    bodies (always)."""
    remedies = []
    if kept or running:
        remedies.append("shorten task.duration")
    if running:
        remedies.append("run fewer evaluations at once (lower executor.workers or brain.popsize)")
    if recorded:
        remedies.append("set record.rerun = false")
    if kept:
        remedies += [
            "lower record.rate_hz or the population sizes",
            "set record.trajectories = false",
        ]
    else:
        remedies.append("lower the population sizes")
    if len(remedies) == 1:
        return remedies[0]
    return ", ".join(remedies[:-1]) + (", or " if len(remedies) > 2 else " or ") + remedies[-1]


def _largest_key(config: ExperimentConfig) -> str:
    """The setting that most likely made the estimate too big (named in the message)."""
    defaults = ExperimentConfig()
    ratios = {
        "task.duration": config.task.duration / defaults.task.duration,
        "record.rate_hz": config.record.rate_hz / defaults.record.rate_hz,
        "brain.popsize": config.brain.popsize / defaults.brain.popsize,
        "brain.iterations": config.brain.iterations / defaults.brain.iterations,
        "body.population": config.body.population / defaults.body.population,
        "body.offspring": config.body.offspring / defaults.body.offspring,
    }
    return max(ratios, key=lambda key: (ratios[key], -list(ratios).index(key)))


# --------------------------------------------------------------------------------------------
# A plugin that fails during a run
# --------------------------------------------------------------------------------------------


def plugin_named(config: ExperimentConfig, text: str) -> str:
    labels = (
        f"fitness function {config.task.fitness!r}",
        f"controller {config.brain.controller!r}",
        f"world {config.world.name!r}",
        f"body encoder {config.body.encoder!r}",
        f"brain optimizer {config.brain.optimizer!r}",
        f"body optimizer {config.body.optimizer!r}",
    )
    # The engine notes "raised by <plugin>" on what a plugin raised; else a message naming one.
    found = [label for label in labels if f"raised by {label}" in text]
    found += [label for label in labels if label in text]
    if found:
        return found[0]
    return "a plugin of the run (" + ", ".join(labels) + ")"
