"""Physics that blows up: evaluations get status ``unstable`` and the worst fitness, the run goes
on, and each generation's summary counts them."""

from __future__ import annotations

import io
import math

from ariel.evolution import run_experiment
from ariel.evolution._progress import Progress
from ariel.recording import load_run

# A 5 cm explicit-Euler step makes every robot's physics diverge within the first second.
EXPLODING = {"timestep": 0.05, "mujoco_config": {"integrator": "EULER"}}
TINY = {
    "name": "unstable",
    "seed": 2,
    "generations": 2,
    "body": {"options": {"number_of_modules": 6}, "population": 2, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 1.0},
    "record": {"rerun": False},
    "executor": {"kind": "serial"},
}


def test_unstable_physics_is_recorded_counted_and_the_run_goes_on(tmp_path, monkeypatch) -> None:
    import ariel.evolution

    # The world check refuses this world before a run starts (its gecko check goes unstable,
    # tests/evolution/test_bad_config.py); here the subject is a run that meets instability.
    # (`ariel.runs` takes it from the package's face.)
    monkeypatch.setattr(ariel.evolution, "check_plugins", lambda config, **_: None)
    lines = io.StringIO()
    monkeypatch.setattr(Progress, "__init__", _quiet_lines(Progress.__init__, lines))
    config = {**TINY, "world": {"name": "flat", "options": EXPLODING}}
    result = run_experiment(config, out=tmp_path / "run", progress=True)
    run = load_run(result.run_dir)
    assert result.status == "finished"
    evals = run.evaluations
    assert len(evals) == (2 + 2) * 3 * 2
    unstable = evals[evals["status"] == "unstable"]
    assert len(unstable) == len(evals)
    assert (unstable["fitness"] == -math.inf).all()
    assert unstable["error"].str.contains("unstable").all()
    per_generation = run.generations.set_index("generation")
    assert list(per_generation["unstable"]) == list(evals.groupby("generation").size())
    assert list(per_generation["errors"]) == [0, 0]
    # The per-generation progress line says so too.
    printed = [line for line in lines.getvalue().splitlines() if line.startswith("gen ")]
    assert len(printed) == 2
    assert printed[0].endswith(f"{per_generation.loc[0, 'unstable']} unstable")


def test_a_stable_run_prints_no_failure_counts(tmp_path, monkeypatch) -> None:
    lines = io.StringIO()
    monkeypatch.setattr(Progress, "__init__", _quiet_lines(Progress.__init__, lines))
    run_experiment({**TINY, "generations": 1}, out=tmp_path / "run", progress=True)
    (line,) = [x for x in lines.getvalue().splitlines() if x.startswith("gen ")]
    assert "unstable" not in line and "error" not in line


def _quiet_lines(init, stream: io.StringIO):
    """Progress printing plain lines (no live display) into ``stream``."""

    def patched(self, *args, **kwargs) -> None:
        kwargs["live"] = False
        init(self, *args, **kwargs)
        self.stream = stream

    return patched
