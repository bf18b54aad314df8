"""Configs the validator accepts that used to crash (probe I): CMA-ES at popsize 2 on 300+
parameters, a brain optimizer raising during a run, Nevergrad methods that need a budget or
take one candidate at a time, a tiny ``sustained_displacement`` window, the memory check's
advice, and plugin integer options given as floats or strings. Each runs, or is refused in one
line before anything is written (a failure during a run: one line and RUN/error.log)."""

from __future__ import annotations

import gc
import re
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _helpers import exit_code, one_error_line, tiny_run_toml

from ariel.errors import PluginCheckError
from ariel.evaluation import CHECK_SEED
from ariel.evolution import ConfigError, load_config
from ariel.evolution._checks import check_plugins, check_resources
from ariel.evolution._cmaes import CMAES
from ariel.evolution._ga import GeneticAlgorithm
from ariel.evolution._nevergrad import Nevergrad
from ariel.plugins import (
    body_encoders,
    body_optimizers,
    brain_optimizers,
    check_body_optimizer,
    controllers,
    fitness_function,
    fitness_functions,
)
from ariel.recording import load_run
from ariel.runs._prepare import resolve_plugins
from ariel.simulation.tasks.gait_learning import MAX_WINDOWS, sustained_displacement


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(tiny_run_toml("edge", 1, generations=1))
    return path


# --- F1: CMA-ES at popsize 2 -----------------------------------------------------------------


def _tells(learner: CMAES, times: int) -> None:
    for k in range(times):
        x = learner.ask()
        learner.tell(x, -np.sum(x**2, axis=1) - k)


@pytest.mark.parametrize("n_params", [300, 1000])
def test_cma_es_at_popsize_2_learns_on_300_parameters_and_more(n_params: int) -> None:
    """pycma's two-point step-size adaptation (from 300 parameters) and its selective mirror
    are three injected candidates: the second tell raised at popsize 2."""
    _tells(CMAES(x0=np.zeros(n_params), popsize=2, sigma0=0.5, seed=1, maximise=True), 4)


@pytest.mark.parametrize(("n_params", "popsize"), [(299, 2), (300, 3), (300, 6), (5, 2)])
def test_cma_es_keeps_pycma_s_defaults_where_they_work(n_params: int, popsize: int) -> None:
    """The same candidates as pycma with ariel's options alone: records of configs that ran
    before do not change."""
    import cma

    from ariel.evolution._cmaes import _Randn

    learner = CMAES(x0=np.zeros(n_params), popsize=popsize, sigma0=0.5, seed=3, maximise=False)
    options = {
        "popsize": popsize,
        "seed": np.nan,
        "randn": _Randn(np.random.default_rng(3)),
        "verbose": -9,
        "verb_log": 0,
        "verb_disp": 0,
        "CMA_diagonal": False,
    }
    plain = cma.CMAEvolutionStrategy(np.zeros(n_params), 0.5, options)
    for k in range(3):
        x = learner.ask()
        assert x.tobytes() == np.array(plain.ask(), dtype=np.float64).tobytes()
        cost = np.sum(x**2, axis=1) + k
        learner.tell(x, cost)
        plain.tell(list(x), cost.tolist())


class _FailsSecondTell(CMAES):
    """CMA-ES that raises on its second tell in a run (the pre-run checks' learners have the
    checks' seeds and pass)."""

    def __init__(self, *, seed: int, **keywords: Any) -> None:
        super().__init__(seed=seed, **keywords)
        self.in_a_run = seed not in (1, CHECK_SEED)

    def tell(self, params: np.ndarray, fitness: np.ndarray) -> None:
        if self.in_a_run and self.history.told:
            raise RuntimeError("the learner's own bug")
        super().tell(params, fitness)


@pytest.fixture
def failing_learner():
    brain_optimizers.register("test_fails_tell", _FailsSecondTell)
    yield "test_fails_tell"
    brain_optimizers.unregister("test_fails_tell")


def test_a_brain_optimizer_failing_during_a_run_stops_it_in_one_line_with_error_log(
    tiny: Path, tmp_path: Path, failing_learner: str, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = ["run", str(tiny), "--out", str(out), "--quiet"]
    argv += ["--set", f"brain.optimizer={failing_learner}", "--set", "brain.iterations=2"]
    assert exit_code(argv) == 2
    line = one_error_line(capsys)
    assert f"brain optimizer '{failing_learner}' failed at the batch of evaluation b" in line
    assert "RuntimeError: the learner's own bug" in line and "error.log" in line, line
    log = (out / "error.log").read_text()
    assert "Traceback" in log and f"raised by brain optimizer '{failing_learner}'" in log
    assert load_run(out).info["status"] == "failed"


def _failed_run(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, optimizer: Any
) -> tuple[Path, str]:
    """``ariel run`` of the tiny config with body optimizer ``optimizer`` registered as
    ``name``, which must fail (exit 2): its folder and its one error line."""
    body_optimizers.register(name, optimizer)
    try:
        out = tmp_path / "out"
        argv = ["run", str(tiny), "--out", str(out), "--quiet", "--set", "generations=2"]
        assert exit_code([*argv, "--set", f"body.optimizer={name}"]) == 2
    finally:
        body_optimizers.unregister(name)
    return out, one_error_line(capsys)


class _GAInARun(GeneticAlgorithm):
    """A GA that knows whether it is the pre-run check's (made with its seed) or a run's."""

    def __init__(self, *, seed: int, **keywords: Any) -> None:
        super().__init__(seed=seed, **keywords)
        self.in_a_run = seed != CHECK_SEED


class _StateOfObjects(_GAInARun):
    """A GA whose state in a run holds an object JSON cannot store (the check's passes)."""

    def state(self) -> Any:
        return {**super().state(), "bad": object()} if self.in_a_run else super().state()


def test_a_body_optimizer_failing_during_a_run_stops_it_in_one_line_with_error_log(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Its state is not plain data: one line naming it (a traceback before), resumable."""
    out, line = _failed_run(tiny, tmp_path, capsys, "test_state_of_objects", _StateOfObjects)
    assert line.startswith(
        "ariel: error: body optimizer 'test_state_of_objects' failed between evaluations "
        "(its state() is not plain data (JSON)): TypeError: Object of type object"
    ), line
    assert "error.log" in line and "resume_experiment(" in line, line
    assert "raised by body optimizer" in (out / "error.log").read_text()
    assert load_run(out).info["status"] == "failed"


class _StrayParent(_GAInARun):
    """A GA whose children in a run name a parent of no body (the check's pass)."""

    def ask(self, n: int) -> list[Any]:
        asked = super().ask(n)
        if not (self.in_a_run and self.population):
            return asked
        return [replace(asked[0], parent_ids=["nope"]), *asked[1:]]


def test_a_body_optimizer_s_stray_parent_stops_the_run_before_it_is_stored(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The run 'finished', and verify then called its bodies table damaged (crafted)."""
    out, line = _failed_run(tiny, tmp_path, capsys, "test_stray_parent", _StrayParent)
    assert line.startswith(
        "ariel: error: body optimizer 'test_stray_parent' failed between evaluations: "
        "ValueError: a child's parents ['nope'] are not in its population"
    ), line
    assert load_run(out).generations_done == 1


class _WritesFitness(_GAInARun):
    """A GA whose tell in a run overwrites the fitness it is told (the check's passes)."""

    def tell(self, bodies: Any) -> None:
        if self.in_a_run:
            for body in bodies:
                body.fitness = 999.0
        super().tell(bodies)


class _WritesInAsk(_GAInARun):
    """A GA that keeps the bodies it was told and, in a run, writes to them in its next ask
    (the records of that generation then said 123)."""

    def ask(self, n: int) -> list[Any]:
        if self.in_a_run:
            for body in self.population:
                body.descriptors = {**body.descriptors, "num_limbs": 123.0}
        return super().ask(n)


@pytest.mark.parametrize(
    ("optimizer", "said", "done"),
    [  # its 999 became every record's best fitness, and verify said ok
        (_WritesFitness, "tell changed b000000's fitness (0.0", 0),
        (_WritesInAsk, "'s descriptors['num_limbs'] (", 1),  # generation 0's rows: the loop's
    ],
)
def test_a_body_optimizer_that_writes_to_its_bodies_stops_the_run(
    optimizer: Any, said: str, done: int, tiny: Path, tmp_path: Path, capsys
) -> None:
    out, line = _failed_run(tiny, tmp_path, capsys, "test_writes", optimizer)
    assert "body optimizer 'test_writes' failed between evaluations: ValueError: " in line
    assert said in line and "); it may read the bodies, not write" in line, line
    assert load_run(out).generations_done == done


def test_the_optimizer_check_refuses_a_tell_that_writes() -> None:
    class AlwaysWrites(_WritesFitness):
        in_a_run = property(lambda self: True, lambda self, value: None)  # the check's too

    body_optimizers.register("test_writes_always", AlwaysWrites)
    try:
        with pytest.raises(PluginCheckError, match=r"tell\(\.\.\.\) changed b000000's fitness"):
            check_body_optimizer("test_writes_always")
    finally:
        body_optimizers.unregister("test_writes_always")


@pytest.mark.parametrize(
    ("change", "said"),
    [
        ({"count": 3}, "ask(3) gave 2 genotypes"),
        ({"genotype": object()}, "a genotype is not plain data (JSON): Object of type object"),
        ({"parents": ["b000009"]}, "a child's parents ['b000009'] are not in its population"),
    ],
)
def test_what_a_body_optimizer_asks_for_is_checked(change: dict, said: str) -> None:
    from ariel.evolution._driver import _check_proposals
    from ariel.evolution._optimizer import Proposal

    config = load_config({}, ["body.encoder=graph"])
    proposals = [
        Proposal(change.get("genotype", [1.0, 2.0]), change.get("parents", ["b000001"])),
        Proposal([3.0], []),
    ]
    with pytest.raises(ValueError, match=re.escape(said)):
        _check_proposals(proposals, change.get("count", 2), {"b000001"}, config)


class _NanCandidates(CMAES):
    def ask(self) -> np.ndarray:
        return np.full_like(super().ask(), np.nan)


def test_a_learner_asking_for_non_finite_candidates_is_named() -> None:
    """Not the evaluation task's "controller params contain NaN" from deep in the driver."""
    from ariel.evolution._brain import BrainRun

    brain_optimizers.register("test_nan_candidates", _NanCandidates)
    try:
        run = BrainRun(2, 3, True, np.zeros(2), 0.5, 1, optimizer="test_nan_candidates")
        with pytest.raises(ValueError, match=r"^brain optimizer 'test_nan_candidates' asked for "):
            run.ask()
    finally:
        brain_optimizers.unregister("test_nan_candidates")


class _GlobalHill(CMAES):
    def ask(self) -> np.ndarray:
        return super().ask() + np.random.normal(0.0, 0.1)


class _GlobalGA(GeneticAlgorithm):
    def ask(self, n: int) -> list[Any]:
        first, *rest = super().ask(n)
        return [replace(first, genotype=np.random.random(4).tolist()), *rest]


@pytest.mark.parametrize(
    ("kind", "plugin", "message"),
    [
        ("brain", _GlobalHill, "asks for different candidates with the same seed"),
        ("body", _GlobalGA, "asks for different genotypes with the same seed"),
    ],
)
def test_a_run_checks_its_optimizers_before_anything_is_written(
    kind: str, plugin: Any, message: str
) -> None:
    """The `ariel plugins --check` checks of the body and brain optimizers, as of the others:
    one drawing from numpy's global generator made runs that differ for the same seed."""
    registry = brain_optimizers if kind == "brain" else body_optimizers
    registry.register("test_global", plugin)
    try:
        config = load_config({}, [f"{kind}.optimizer=test_global"])
        with pytest.raises(ConfigError, match=rf"^{kind}\.optimizer: .*{message}"):
            check_plugins(config)
    finally:
        registry.unregister("test_global")


def test_a_plugin_registered_again_under_its_name_is_checked_again() -> None:
    """A notebook cell run again after an edit (replace=True): checked anew, not cached."""

    def good(record: Any) -> float:
        return 1.0

    def bad(record: Any) -> str:
        return "high"

    fitness_functions.register("test_edited", fitness_function(maximise=True)(good))
    try:
        config = load_config({}, ["task.fitness=test_edited"])
        check_plugins(config)
        fitness_functions.register(
            "test_edited", fitness_function(maximise=True)(bad), replace=True
        )
        with pytest.raises(ConfigError, match=r"^task\.fitness: the plugin check failed"):
            check_plugins(config)
    finally:
        fitness_functions.unregister("test_edited")


def test_a_script_read_from_standard_input_is_refused_for_worker_processes(monkeypatch) -> None:
    """`python - < script.py`: forkserver's workers would try to run the file '<stdin>' and
    die, every evaluation an error row; refused before anything is written."""
    from ariel.runs._prepare import _check_plugins_reach_workers, executor_settings

    monkeypatch.setattr(sys.modules["__main__"], "__file__", "<stdin>", raising=False)
    config = load_config({}, ["executor.kind=local", "executor.workers=1"])
    with pytest.raises(ConfigError, match=r"^executor\.kind: this script was read from <stdin>"):
        _check_plugins_reach_workers(config, executor_settings(config))
    serial = load_config({}, ["executor.kind=serial"])
    _check_plugins_reach_workers(serial, executor_settings(serial))  # runs in this process


# --- F2, F4: Nevergrad methods refused before anything is written ----------------------------


@pytest.mark.parametrize(
    ("method", "message"),
    [
        # nevergrad's own "(... raised AssertionError: Error:)" said nothing: left out
        ("NGOpt", r"ask\(\) raised ValueError: method 'NGOpt' needs a budget \(it plans"),
        ("ScrHammersleySearch", r"method 'ScrHammersleySearch' needs a budget"),
        ("LHSSearch", r"method 'LHSSearch' needs a budget"),
        ("Cobyla", r"'nevergrad': method 'Cobyla' evaluates one candidate at a time"),
        ("NelderMead", r"'nevergrad': method 'NelderMead' evaluates one candidate at a time"),
    ],
)
def test_a_nevergrad_method_that_cannot_run_is_one_config_error(method: str, message: str) -> None:
    unraisable: list[Any] = []
    hook, sys.unraisablehook = sys.unraisablehook, unraisable.append
    try:
        config = load_config(
            {}, ["brain.optimizer=nevergrad", f"brain.optimizer_options={{method='{method}'}}"]
        )
        with pytest.raises(ConfigError, match=r"^brain\.optimizer_options: .*" + message) as e:
            resolve_plugins(config)
        gc.collect()
    finally:
        sys.unraisablehook = hook
    assert "\n" not in str(e.value) and "_NonObjectMinimizeBase" not in str(e.value)
    assert not unraisable  # nevergrad's half-made optimizer printed a traceback from __del__


def test_a_nevergrad_method_given_its_budget_still_runs() -> None:
    learner = Nevergrad(
        x0=np.zeros(3), popsize=2, sigma0=0.5, seed=1, maximise=True, method="LHSSearch", budget=8
    )
    x = learner.ask()
    learner.tell(x, -np.sum(x**2, axis=1))
    assert learner.ask().shape == (2, 3)


# --- F3: sustained_displacement's window -----------------------------------------------------


def test_a_window_cutting_the_path_into_too_many_pieces_is_refused() -> None:
    times = np.linspace(0.0, 1.0, 11)
    xy = np.stack([times, np.zeros_like(times)], axis=1)
    assert sustained_displacement(times, xy, window=1.0 / MAX_WINDOWS) == pytest.approx(1.0)
    with pytest.raises(
        ValueError, match=r"^window 1e-07 s cuts the 1 s path into 10,000,000 windows"
    ):
        sustained_displacement(times, xy, window=1e-7)
    many = np.linspace(0.0, 1.0, 2 * MAX_WINDOWS + 1)  # as many windows as samples: fine
    path = np.stack([many, np.zeros_like(many)], axis=1)
    assert sustained_displacement(many, path, window=0.5 / MAX_WINDOWS) == pytest.approx(1.0)


@pytest.mark.parametrize("span", [3.0, 3.0 + 1e-12, 1.0 + 3e-10, 7.123456])
def test_the_shortest_window_the_message_names_is_taken_when_pasted(span: float) -> None:
    """It was rounded to nearest: 3 s of path gave 'at least 3e-05 s', which was refused."""
    from ariel.simulation.tasks.gait_learning import window_count_error

    message = window_count_error(span, 31, 1e-7)
    assert message is not None
    shortest = float(message.rpartition("at least ")[2].removesuffix(" s"))
    assert window_count_error(span, 31, shortest) is None, (span, shortest)


def test_a_tiny_window_is_one_config_error_before_the_plugin_check() -> None:
    config = load_config({}, ["task.fitness=sustained_displacement", "task.options={window=1e-7}"])
    with pytest.raises(ConfigError) as caught:
        resolve_plugins(config)
    line = str(caught.value)
    assert line.startswith("task.options: fitness function 'sustained_displacement': window")
    assert "give a window of at least" in line and "\n" not in line


# --- F5: the memory check's advice fits the cause --------------------------------------------


def test_the_memory_advice_leaves_out_trajectories_when_none_are_kept(monkeypatch) -> None:
    monkeypatch.setattr("ariel.evolution._checks.machine_memory", lambda: 1)
    config = load_config({}, ["record.trajectories=false", "body.options={number_of_modules=6}"])
    encoder = body_encoders.make(config.body.encoder, **config.body.options)
    with pytest.raises(ConfigError) as caught:
        check_resources(config, encoder, brain_only=False, capacity=2, local_workers=True)
    advice = str(caught.value).split("available: ")[1]
    assert "record.trajectories" not in advice and "record.rate_hz" not in advice
    assert "fewer evaluations at once" in advice
    on = load_config({}, ["body.options={number_of_modules=6}"])
    with pytest.raises(ConfigError, match=r"or set record\.trajectories = false$"):
        check_resources(on, encoder, brain_only=False, capacity=2, local_workers=True)


# --- F6: integer plugin options are never truncated ------------------------------------------


@pytest.mark.parametrize(
    ("registry", "name", "options", "option"),
    [
        (body_encoders, "nde", {"number_of_modules": 6.7}, "number_of_modules"),
        (body_encoders, "nde", {"number_of_modules": 6.0}, "number_of_modules"),
        (body_encoders, "nde", {"genotype_size": "64"}, "genotype_size"),
        (body_encoders, "cppn", {"max_modules": 5.5}, "max_modules"),
        (body_encoders, "cppn", {"initial_mutations": 1.5}, "initial_mutations"),
        (body_encoders, "tree", {"max_modules": "5"}, "max_modules"),
        (body_encoders, "tree", {"min_modules": 2.5}, "min_modules"),
        (body_encoders, "tree", {"max_modules": True}, "max_modules"),
        (controllers, "mlp", {"hidden": 2.5}, "hidden"),
    ],
)
def test_an_integer_plugin_option_is_never_truncated(
    registry: Any, name: str, options: dict[str, object], option: str
) -> None:
    with pytest.raises(TypeError, match=rf"^{option} must be a whole number \(an int\), not "):
        registry.make(name, **options)


def test_a_float_module_count_is_one_line_and_writes_nothing(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = ["run", str(tiny), "--out", str(out), "--quiet"]
    assert exit_code([*argv, "--set", "body.options={number_of_modules=6.7}"]) == 2
    line = one_error_line(capsys)
    assert line.endswith(
        "body.options: body encoder 'nde': number_of_modules must be a whole number (an int), "
        "not 6.7"
    ), line
    assert not out.exists()


def test_a_fitness_function_without_a_record_argument_is_named_not_its_options() -> None:
    """It said 'task.options: ... too many positional arguments' with no options given."""

    @fitness_function(maximise=True)
    def no_record() -> float:
        return 1.0

    fitness_functions.register("test_no_record", no_record)
    try:
        with pytest.raises(ConfigError) as caught:
            resolve_plugins(load_config({}, ["task.fitness=test_no_record"]))
    finally:
        fitness_functions.unregister("test_no_record")
    assert str(caught.value) == (
        "task.fitness: fitness function 'test_no_record': it takes no argument for the record: "
        "a fitness function is called as fn(record, **options)"
    )


def test_resume_refuses_ariel_s_own_plugin_replaced_by_another() -> None:
    """Only the user's own plugins were compared: `xy_displacement` registered again as
    another function (replace=True) resumed, two fitness functions in one run."""
    from types import SimpleNamespace

    from ariel.runs._session import _check_same_plugins

    stored = {
        "kind": "fitness",
        "name": "xy_displacement",
        "object": "ariel.evaluation.builtin_plugins:xy_displacement",
    }
    info = {"plugins": {"fitness": stored}, "maximise": True}
    prepared: Any = SimpleNamespace(plugins=SimpleNamespace(maximise=True))
    _check_same_plugins(Path("run"), info, prepared)  # ariel's own, as recorded: resumes
    original = fitness_functions.get("xy_displacement")

    @fitness_function(maximise=True)
    def mine(record: Any) -> float:
        return 0.0

    fitness_functions.register("xy_displacement", mine, replace=True)
    try:
        with pytest.raises(ConfigError, match="resuming would mix two plugins in one run"):
            _check_same_plugins(Path("run"), info, prepared)
    finally:
        fitness_functions.register("xy_displacement", original, replace=True)


def test_exactly_the_most_windows_allowed_is_taken() -> None:
    """The docs allow 'at most 100000 windows'; a 1 s run with a 1e-5 s window was refused,
    its message saying '1e+05 windows, more than the 100000 allowed'."""
    config = load_config(
        {}, ["task.fitness=sustained_displacement", "task.options={window=1e-5}", "task.duration=1"]
    )
    resolve_plugins(config)  # the check adds 1e-9 of the span for float sums: no refusal
    from ariel.simulation.tasks.gait_learning import window_count_error

    message = window_count_error(1.0, 11, 0.99e-5)
    assert message is not None and "into 101,010 windows, more than the 100,000" in message
    # the shortest window named is 1e-05 itself (float error rounded it up to 1.01e-05)
    assert window_count_error(1.0, 11, 9.9999e-6).endswith("at least 1e-05 s")  # type: ignore


def test_the_memory_estimate_counts_the_rerun_recording(monkeypatch) -> None:
    """A generation of 20,000 evaluations took 3.1 GB where the estimate said 0.47: each
    evaluation's share of the generation's Rerun recording was left out (probe G3)."""
    from ariel.evolution._checks import RERUN_BYTES_PER_EVALUATION

    sets = ["body.options={number_of_modules=6}", "record.trajectories=false"]
    on, off = load_config({}, sets), load_config({}, [*sets, "record.rerun=false"])
    encoder = body_encoders.make(on.body.encoder, **on.body.options)
    needed = {
        rerun: check_resources(config, encoder, brain_only=False, capacity=2, local_workers=True)
        for rerun, config in (("on", on), ("off", off))
    }
    evaluations = (
        max(on.body.population, on.body.offspring) * on.brain.popsize * on.brain.iterations
    )
    recording = evaluations * RERUN_BYTES_PER_EVALUATION  # and the poses of those running
    assert recording <= needed["on"] - needed["off"] < 1.1 * recording
    monkeypatch.setattr("ariel.evolution._checks.machine_memory", lambda: 1)
    with pytest.raises(ConfigError, match=r", set record\.rerun = false, or lower the population"):
        check_resources(on, encoder, brain_only=False, capacity=2, local_workers=True)
