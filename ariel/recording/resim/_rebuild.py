"""What a replay rebuilds from the run folder alone: the evaluation's row (`_find_row`), the
plugins it needs (`_require_plugins`), its task as the loop built it (`replay_task`: both call
`ariel.evolution._tasks.evaluation_task`) and the simulator it ran on (`_evaluate_as_stored`);
the versions of the software that decide its numbers are `ariel.recording.store`'s
(`version_differences`).

A cell of the run's tables that is not what the loop wrote (a changed or damaged table) is a
`DamagedRunError`, one line, naming the evaluation; so is a config in run.json that no run has
(`check_config`: a section that is not a table) or whose plugins reject the options it records
for them (`check_options`), naming the run folder. Replay and export check both before they
rebuild anything, report and gallery before they draw a body.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ariel import evaluation
from ariel.errors import (
    ArielError,
    ConfigError,
    DamagedRunError,
    DuplicatePluginError,
    MissingPluginError,
    PluginFailedError,
    PluginLoadError,
    UnknownEvaluationError,
    UnknownPluginError,
)
from ariel.evolution import ExperimentConfig, body_spec, evaluation_task, record_steps, shipped_body
from ariel.plugins import REGISTRIES, body_encoders, controllers
from ariel.recording.resim._row_checks import changed, check_body_size, check_row
from ariel.recording.store import (
    Run,
    config_sections,
    damaged,
    json_data,
    load_run,
    one_line,
    section_problem,
    short_ascii,
)
from ariel.utils import load_run_command, mujoco_module

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation import EvaluationResult, EvaluationTask

__all__ = [
    "BEST",
    "BODY_PLUGINS",
    "cell_json",
    "check_config",
    "check_options",
    "load_checked",
    "missing_plugin",
    "replay_task",
]

#: `replay(run, BEST)` replays the run's best evaluation.
BEST = "best"


#: The plugins a replay needs: run.json's ``plugins`` kind -> config key.
_PLUGIN_KEYS = {
    "body_encoder": ("body", "encoder"),
    "controller": ("brain", "controller"),
    "world": ("world", "name"),
    "fitness": ("task", "fitness"),
}


#: The plugins that make a body in its world (`ariel.evaluation.build`): what drawing one needs.
BODY_PLUGINS = ("body_encoder", "world")


def check_config(run: Run) -> None:
    """`DamagedRunError`, one line naming the run folder, where run.json's config is no table
    or one of its sections (`config_sections`) is there but no table (``task = null``): what
    ``ariel verify`` finds too. Every reader of the config (replay, export, report, gallery)
    calls it before it reads a section."""
    config = run.info.get("config")
    if not isinstance(config, dict):
        raise damaged(run.path, "run.json", f"has config {short_ascii(config, 40)}, not a table")
    for section in config_sections():
        problem = section_problem(config, section)
        if problem is not None:
            raise damaged(run.path, "run.json", problem)


def load_checked(run_dir: str | Path) -> Run:
    """`load_run`, and `check_config` of what it loaded."""
    run = load_run(run_dir)
    check_config(run)
    return run


def _experiment(run: Run) -> ExperimentConfig:
    """The run's config as the loop read it; one that does not validate is the one line
    ``ariel verify`` notes, naming the run folder."""
    check_config(run)
    try:
        return ExperimentConfig.from_plain(run.config)
    except ConfigError as exc:
        raise DamagedRunError(
            f"run folder {str(run.path)!r}: run.json's config is not one this ariel reads "
            f"({one_line(exc)})"
        ) from None


def check_options(
    run: Run, kinds: Sequence[str] = tuple(_PLUGIN_KEYS), config: ExperimentConfig | None = None
) -> None:
    """`DamagedRunError`, one line naming the run folder, the plugin and its cause, for the
    first plugin of ``kinds`` (`_PLUGIN_KEYS`' kinds; `BODY_PLUGINS` draws a body) that rejects
    the options the run's config records for it: a factory that raises `TypeError` (an unknown
    keyword) or `ValueError` (a bad value), a fitness function whose signature does not take
    them. A plugin not installed raises as its registry does (`UnknownPluginError`)."""
    config = _experiment(run) if config is None else config
    for kind in kinds:
        section, key = _PLUGIN_KEYS[kind]
        part = getattr(config, section)
        name, options = getattr(part, key), dict(part.options)
        registry = REGISTRIES[kind]
        try:
            if kind != "fitness":
                registry.make(name, **options)
            elif error := evaluation.fitness_options_error(registry.get(name), options):
                raise error  # a fitness function takes them per call
        except (UnknownPluginError, DuplicatePluginError):
            raise
        except (TypeError, ValueError) as exc:
            raise DamagedRunError(
                f"run folder {str(run.path)!r}: its config's {section}.options "
                f"{short_ascii(options)} are rejected by {registry.label} {name!r}: "
                f"{one_line(exc)}; run.json was changed, or this {registry.label} is not the "
                "one that made the run"
            ) from None


def _unloadable(run: Run, kinds: Sequence[str]) -> tuple[str, str, Exception] | None:
    """The first of the run's plugins of ``kinds`` that does not load here: its kind, its
    name and what its registry raised (a `PluginLoadError`: installed, but broken); None
    when all of them load. A name that is no string is `check_options`' to refuse."""
    for kind in kinds:
        section, key = _PLUGIN_KEYS[kind]
        name = run.config.get(section, {}).get(key)
        if not isinstance(name, str):
            continue
        try:
            REGISTRIES[kind].get(name)
        except (KeyError, ValueError, ImportError) as exc:
            return kind, name, exc
    return None


def missing_plugin(run: Run, kinds: Sequence[str] = BODY_PLUGINS) -> str | None:
    """Why the run's plugins of ``kinds`` cannot be made here, in words (the first not
    installed, or not loading); None when all of them load. Report and gallery then draw
    what needs no body."""
    _experiment(run)  # a config that does not validate: one line, as before anything is drawn
    found = _unloadable(run, kinds)
    if found is None:
        return None
    kind, name, _ = found
    return f"{REGISTRIES[kind].label} {short_ascii(name)} is not installed here (or does not load)"


def _require_plugins(run: Run) -> None:
    """`MissingPluginError`, one line, for the first of the run's plugins not installed here,
    or installed but failing to load (reading a run needs none of them; re-simulating it
    needs all); then `check_options` of them all."""
    check_config(run)
    # The built-in plugins load mujoco: import it first, so that a GL backend that cannot
    # load (MUJOCO_GL) fails as itself (`gl_backend_error`), not as a plugin not installed.
    mujoco_module()
    found = _unloadable(run, tuple(_PLUGIN_KEYS))
    if found is not None:
        kind, name, exc = found
        (section, key), label = _PLUGIN_KEYS[kind], REGISTRIES[kind].label
        plugin = f"{label} {name!r} ({section}.{key})"
        if isinstance(exc, PluginLoadError):  # installed, but its import or its object broken
            raise MissingPluginError(
                f"replay re-simulates with the run's plugins: {plugin} is installed here but "
                f"does not load: {one_line(str(exc))}"
            )
        served = (run.info.get("plugins") or {}).get(kind) or {}
        source = served.get("distribution") if isinstance(served, dict) else None
        hint = f"install {one_line(source)}" if source else "install the package that provides it"
        raise MissingPluginError(
            f"replay re-simulates with the run's plugins: {plugin} is not installed here; "
            f"{hint} (report, load_run and view need no plugins)"
        )
    check_options(run)


def _find_row(run: Run, eval_id: str) -> dict[str, Any]:
    evals = run.evaluations
    if eval_id == BEST:
        ok = evals[evals["fitness"].map(math.isfinite)]
        if len(ok):
            index = ok["fitness"].idxmax() if run.maximise else ok["fitness"].idxmin()
            return evals.loc[index].to_dict()
    else:
        found = evals[evals["eval_id"] == eval_id]
        if len(found):
            return found.iloc[0].to_dict()

    quoted = str(run.path)
    ids = "ids look like b000012-i003-c005 ('best' for the best one)"
    if not len(evals):
        where = f"no finished generation in run {quoted!r} yet"
    elif eval_id == BEST:  # every evaluation failed: the best is none of them
        where = f"no evaluation of run {quoted!r} has a finite fitness, so none is 'best'"
        ids = "give an evaluation's id to replay a failed one"
    else:
        where = f"no evaluation {eval_id!r} in the finished generations of run {quoted!r}"
    listing = 'r.evaluations[["generation", "eval_id", "status", "fitness"]].to_string(index=False)'
    raise UnknownEvaluationError(
        f"{where}; {ids}; list them with {load_run_command(run.path, what=listing)}"
    )


def cell_json(run: Run, row: Mapping[str, object], table: str, column: str, text: object) -> object:
    """The JSON in the cell ``column`` of ``table`` (``text``) for evaluation ``row`` of
    ``run``, read with the guarded parser (`json_data`: no JSON nested out of stack); a cell
    that is no JSON text is a changed table: `DamagedRunError`, one line."""
    if not isinstance(text, str | bytes):
        raise changed(run, row, table, f"its {column} is {short_ascii(text, 40)}, not JSON text")
    try:
        return json_data(text)
    except (TypeError, ValueError) as exc:
        raise changed(run, row, table, f"its {column} is not readable JSON ({exc})") from None


def _row_params(row: Mapping[str, object]) -> np.ndarray | None:
    """The row's controller parameters, float64; None where they are not a list of finite
    numbers (a changed table)."""
    try:
        params = np.asarray(row["controller_params"], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        return None
    return params if params.ndim == 1 and np.all(np.isfinite(params)) else None


def _check_params(
    run: Run,
    row: Mapping[str, object],
    task: EvaluationTask,
    model: mujoco.MjModel,
    params: np.ndarray | None,
) -> None:
    """`DamagedRunError` naming the evaluation, the number of parameters its row holds and the
    number its body's controller needs, where the two differ (a changed table)."""
    controller = evaluation.make_plugin(controllers, task.controller, task.controller_options)
    needed = controller.num_parameters(model)
    if params is not None and len(params) == needed:
        return
    found = (
        f"{len(params)} controller parameters"
        if params is not None
        else "controller parameters that are not a list of finite numbers"
    )
    raise changed(
        run,
        row,
        "evaluations",
        f"its row holds {found}, but its body's controller {task.controller!r} needs {needed} "
        f"({model.nu} actuators)",
    )


def replay_task(
    run: Run,
    row: Mapping[str, Any],
    *,
    graph: str | None = None,
    check_params: bool = False,
    unbuildable: bool | None = None,
) -> EvaluationTask:
    """The `EvaluationTask` the loop built for evaluation ``row`` of ``run``.

    ``graph``: the body's decoded robot graph (the bodies table's ``graph``), the form the
    loop's tasks carry (`shipped_body`) for an encoder that decodes to a graph: used as it is
    instead of decoding the genotype again (the NDE's decoding imports torch, ~2 s).
    ``check_params`` (to re-simulate): `DamagedRunError` where the row's controller parameters
    are not as many finite numbers as its body's controller needs (a changed table); without
    it (to draw the body), parameters that are not a list of finite numbers are left out.
    ``unbuildable``: what a body that does not build is, where the row does not record that
    it could not be built (status ``error``): a `DamagedRunError` naming the run folder, the
    table, the evaluation and body and the encoder's reason (True: to draw or export it), or
    the replay's result (False: `replay` says why); default ``not check_params``.
    Either way a row whose cells are not what the loop wrote (`check_row`: ids, plugin names,
    seed; a genotype or graph cell that is not JSON, or larger than a body of the run can be:
    `check_body_size`) is `DamagedRunError`, before anything is built.
    """
    config = _experiment(run)
    seed = check_row(run, row, config)
    spec, table = _body(run, row, config, graph)
    check_body_size(run, row, spec, config, table)
    fields: dict[str, object] = {"seed": seed, "eval_id": str(row["eval_id"])}
    params = _row_params(row)
    try:
        shape = evaluation_task(config, spec)
        model = evaluation.build(shape).model
    except evaluation.BodyBuildError as exc:
        damage = not check_params if unbuildable is None else unbuildable
        # An error row's body cannot be built: evaluating its task gives the same error again.
        if damage and row.get("status") != "error":
            raise _unbuildable(run, row, table, exc) from None
    else:
        fields["record_every"] = record_steps(config, model.opt.timestep)
        if check_params:
            _check_params(run, row, shape, model, params)
    return evaluation_task(config, spec, () if params is None else params, **fields)


def _body(
    run: Run, row: Mapping[str, object], config: ExperimentConfig, graph: str | None
) -> tuple[evaluation.BodySpec, str]:
    """The body `replay_task` builds and the table it was read from: the stored robot graph
    (``bodies``) where there is one and the encoder decodes to one, else the row's genotype
    (``evaluations``; `check_body_size` before it is decoded)."""
    encoder = config.body.encoder
    if graph and encoder != "graph" and not hasattr(body_encoders.get(encoder), "build"):
        check_options(run, ("world",), config)  # the graph is built without the encoder
        return evaluation.BodySpec("graph", cell_json(run, row, "bodies", "graph", graph)), "bodies"
    check_options(run, BODY_PLUGINS, config)
    genotype = cell_json(run, row, "evaluations", "body_genotype", row["body_genotype"])
    spec = body_spec(config, genotype)
    check_body_size(run, row, spec, config, "evaluations")  # before it is decoded
    return shipped_body(config, spec), "evaluations"


def _unbuildable(
    run: Run, row: Mapping[str, object], table: str, exc: BaseException
) -> DamagedRunError:
    """The one line for the body of ``row`` (from ``table``) that does not build, though the
    run built it: the run folder, the evaluation and body, the encoder's reason."""
    stored = "graph" if table == "bodies" else "genotype"
    problem = (
        f"its body {short_ascii(row.get('body_id'))} could not be built from the stored "
        f"{stored} ({one_line(exc)})"
    )
    return changed(run, row, table, problem)


def _evaluate_as_stored(task: EvaluationTask, backend: object) -> EvaluationResult:
    """Evaluate ``task`` on the simulator the row names where it is here, else the CPU engine.

    The engine (`ariel.evaluation`, which imports mujoco) is reached at call time: mujoco
    reads its GL backend (MUJOCO_GL) on import, which the cli chooses first where it renders."""
    prefix = "mujoco-warp:"
    try:
        if isinstance(backend, str) and backend.startswith(prefix):
            try:
                evaluator = evaluation.WarpEvaluator(backend[len(prefix) :])
            except (evaluation.WarpUnavailableError, ValueError):  # not installed, no device
                return evaluation.evaluate(task)
            return evaluator.evaluate_batch([task])[0]
        return evaluation.evaluate(task)
    except ArielError:
        raise
    except Exception as exc:  # a plugin raising on what the run recorded (a fitness option)
        raise PluginFailedError(
            f"re-simulating {task.eval_id} raised {type(exc).__name__}: {one_line(exc)} (a "
            "plugin of the run rejects what run.json records for it: the folder was changed, or "
            "the plugin is not the one that made the run)"
        ) from exc
