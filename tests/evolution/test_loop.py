"""The co-evolution loop on a tiny budget: records, lineage, selection, determinism, resume."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ariel.evolution import ConfigError, load_config, resume_experiment, run_experiment
from ariel.evolution._progress import Progress
from ariel.recording import load_run

TINY = {
    "name": "tiny",
    "seed": 5,
    "generations": 3,
    "body": {"options": {"number_of_modules": 6}, "population": 3, "offspring": 3},
    "brain": {"popsize": 4, "iterations": 2},
    "task": {"duration": 1.0},
    "executor": {"kind": "serial"},
}


def tiny(**sections: dict) -> dict:
    config = {k: (dict(v) if isinstance(v, dict) else v) for k, v in TINY.items()}
    for key, value in sections.items():
        if isinstance(value, dict):
            config[key] = {**config.get(key, {}), **value}
        else:
            config[key] = value
    return config


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("runs") / "reference"
    result = run_experiment(tiny(), out=out)
    return result, load_run(out)


def test_a_run_records_every_evaluation_and_body(reference) -> None:
    result, run = reference
    assert result.status == "finished" and run.info["status"] == "finished"
    evals, bodies = run.evaluations, run.bodies
    per_body = 4 * 2
    assert result.evaluations == (3 + 2 * 3) * per_body
    assert len(evals) == result.evaluations
    assert evals["eval_id"].is_unique
    assert set(evals["generation"]) == {0, 1, 2}
    # Every body in the table knows its parents, and those were alive earlier.
    born = bodies.drop_duplicates("body_id").set_index("body_id")["born_generation"]
    for _, row in bodies[bodies["is_new"]].iterrows():
        for parent in row["parent_ids"]:
            assert born[parent] < row["generation"]
    # Body fitness = its best evaluation's fitness.
    for _, row in bodies.iterrows():
        mine = evals[evals["body_id"] == row["body_id"]]
        if row["status"] == "ok":
            assert row["fitness"] == mine["fitness"].max()
            assert mine.set_index("eval_id").loc[row["best_eval_id"], "fitness"] == row["fitness"]
    # mu+lambda: the population keeps 3 bodies and its best never gets worse.
    assert (bodies.groupby("generation")["selected"].sum() == 3).all()
    best = run.generations["best_fitness"].to_numpy()
    assert np.all(np.diff(best) >= 0)
    # Trajectories: one row per recorded frame (10 Hz over 1 s: 11 frames) of every evaluation.
    traj = run.trajectories
    ok = evals[evals["status"] != "error"]
    assert len(traj) == 11 * len(ok)
    sample = traj[traj["eval_id"] == ok["eval_id"].iloc[0]]
    assert sample["t"].iloc[0] == 0 and sample["t"].iloc[-1] == pytest.approx(1.0)
    assert len(sample["joint_angle"].iloc[0]) == ok["n_joints"].iloc[0]


def test_run_json_holds_config_versions_provenance_and_no_absolute_paths(reference) -> None:
    result, run = reference
    info = run.info
    assert info["seed"] == 5 and info["config"]["brain"]["popsize"] == 4
    assert {"ariel", "mujoco", "numpy", "torch", "cma", "pyarrow"} <= set(info["versions"])
    assert info["plugins"]["controller"]["object"].endswith("NaCPGController")
    assert info["generations_done"] == 3
    assert str(Path(result.run_dir).resolve()) not in Path(result.run_dir, "run.json").read_text()


def test_the_same_seed_gives_the_same_run(reference, tmp_path: Path) -> None:
    _, run = reference
    again = load_run(run_experiment(tiny(), out=tmp_path / "again").run_dir)
    columns = ["eval_id", "fitness", "controller_params", "body_genotype", "parent_ids"]
    assert again.evaluations[columns].equals(run.evaluations[columns])


def test_a_different_seed_gives_a_different_run(reference, tmp_path: Path) -> None:
    _, run = reference
    other = load_run(run_experiment(tiny(seed=6), out=tmp_path / "other").run_dir)
    assert not np.array_equal(other.evaluations["fitness"], run.evaluations["fitness"])


def test_an_interrupted_run_resumes_to_the_same_records(
    reference, tmp_path: Path, monkeypatch
) -> None:
    _, run = reference
    original = Progress.end_generation

    def stop_after_generation_one(self, generation, *args, **kwargs):
        original(self, generation, *args, **kwargs)
        if generation == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "end_generation", stop_after_generation_one)
    out = tmp_path / "killed"
    with pytest.raises(KeyboardInterrupt) as caught:
        run_experiment(tiny(), out=out)
    # what a notebook's traceback shows (it said "KeyboardInterrupt" alone, or "Interrupted: 2")
    assert caught.value.__notes__ == [
        f"interrupted: its finished generations are kept; continue it with "
        f"resume_experiment({str(out)!r})"
    ]
    assert load_run(out).info["status"] == "interrupted"
    assert load_run(out).generations_done == 2
    monkeypatch.setattr(Progress, "end_generation", original)
    resumed = resume_experiment(out)
    assert resumed.status == "finished"
    columns = ["eval_id", "fitness", "controller_params"]
    assert load_run(out).evaluations[columns].equals(run.evaluations[columns])
    with pytest.raises(ValueError, match="already finished"):
        resume_experiment(out)


def test_resume_refuses_an_edited_config_and_a_folder_that_is_not_a_run(
    tmp_path: Path, monkeypatch
) -> None:
    import json

    monkeypatch.setattr(Progress, "end_generation", _raise_interrupt)
    out = tmp_path / "edited"
    with pytest.raises(KeyboardInterrupt):
        run_experiment(tiny(), out=out)
    info = json.loads((out / "run.json").read_text())
    info["config"]["brain"]["popsize"] = 5
    (out / "run.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match="config was edited"):
        resume_experiment(out)
    with pytest.raises(ValueError, match="not an ariel run folder"):
        resume_experiment(tmp_path)


def _raise_interrupt(self, generation, *args, **kwargs):
    raise KeyboardInterrupt


def test_bad_input_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "never"
    with pytest.raises(ConfigError, match=r"brain\.controller"):
        run_experiment(tiny(brain={"controller": "nope"}), out=out)
    with pytest.raises(ConfigError, match="generations"):
        run_experiment(tiny(generations=0), out=out)
    assert not out.exists()
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="already exists"):
        run_experiment(tiny(), out=tmp_path / "taken")
    with pytest.raises(FileExistsError, match="not an ariel run folder"):
        run_experiment(tiny(), out=tmp_path / "taken", overwrite=True)
    assert (tmp_path / "taken" / "notes.txt").read_text() == "mine"


def test_a_prebuilt_body_is_not_evolved_the_run_is_brain_only(tmp_path: Path) -> None:
    config = tiny(body={"encoder": "prebuilt", "genotype": "gecko", "options": {}}, generations=2)
    result = run_experiment(config, out=tmp_path / "gecko")
    run = load_run(result.run_dir)
    assert set(run.bodies["body_id"]) == {"b000000"}
    assert len(run.evaluations) == 2 * 4 * 2
    # One CMA-ES run goes on across generations: iterations 0-1, then 2-3.
    assert sorted(set(run.evaluations["iteration"])) == [0, 1, 2, 3]
    assert run.evaluations["n_joints"].eq(8).all()
    assert math.isfinite(result.best_fitness)


def test_generational_survival_replaces_the_parents(tmp_path: Path) -> None:
    run = load_run(
        run_experiment(tiny(body={"survivors": "generational"}), out=tmp_path / "gen").run_dir
    )
    last = run.bodies[run.bodies["generation"] == 2]
    assert last[last["selected"]]["is_new"].all()
    with pytest.raises(ConfigError, match="offspring >= population"):
        run_experiment(tiny(body={"survivors": "generational", "offspring": 2}), out=tmp_path / "x")


def test_default_experiment_budget_is_what_the_config_says() -> None:
    config = load_config(None)
    assert config.generations >= 10


def test_a_bad_fixed_body_is_a_config_error_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "dragon"
    with pytest.raises(ConfigError, match=r"^body.genotype: 'dragon' gives no body"):
        run_experiment(
            tiny(body={"encoder": "prebuilt", "genotype": "dragon", "options": {}}), out=out
        )
    with pytest.raises(ConfigError, match=r"^body.genotype: shape \(1, 1\), expected \(3, 64\)"):
        run_experiment(tiny(body={"genotype": [[0.5]]}), out=out)
    assert not out.exists()
