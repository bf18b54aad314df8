"""Memory over a long run: small workers, and a driver that does not keep every body.

Workers: the NDE needs torch (hundreds of MiB resident) to make its weights; a worker that
decoded genotypes itself imported it. The driver now decodes every body once and ships the
graph (`_tasks.shipped_body`), which compiles to the very same model, so fitness is unchanged.
Driver: it compiles each new body (~0.3 MB a model) and keeps the models of living bodies only;
it writes the trajectories table from numpy arrays, not from a million Python floats.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pyarrow as pa
import pytest

import ariel.evolution._bodies as bodies
from ariel.evaluation import BodySpec, EvaluationResult, build, evaluate_batch, make_executor
from ariel.evolution import ExperimentConfig, run_experiment
from ariel.evolution._driver import RunDriver
from ariel.evolution._tasks import body_spec, evaluation_task, shipped_body
from ariel.plugins import body_encoders
from ariel.recording import load_run
from ariel.recording.store._tables import trajectory_columns, trajectory_schema

CONFIG = {
    "name": "workermemory",
    "seed": 5,
    "generations": 2,
    "body": {"options": {"number_of_modules": 8}, "population": 2, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 0.5},
    "executor": {"kind": "serial"},
}
WORKER_RSS_LIMIT_MIB = 250  # the bound; measured: about 90 MiB


def _model_bytes(model: mujoco.MjModel) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def test_a_shipped_nde_body_compiles_to_the_same_model() -> None:
    config = ExperimentConfig.from_plain(CONFIG)
    encoder = body_encoders.make("nde", **config.body.options)
    rng = np.random.default_rng(3)
    for i in range(12):
        genotype = encoder.random_genotype(rng)
        if i % 2:  # far from the initial distribution: odder bodies
            genotype = encoder.mutate(genotype, rng, mutation_std=2.0)
        spec = body_spec(config, genotype)
        shipped = shipped_body(config, spec)
        assert shipped.encoder == "graph" and spec.encoder == "nde"
        direct, via_graph = (
            build(evaluation_task(config, spec)),
            build(evaluation_task(config, shipped)),
        )
        assert _model_bytes(via_graph.model) == _model_bytes(direct.model)
        assert via_graph.descriptors == direct.descriptors
        assert via_graph.joint_names == direct.joint_names


def test_bodies_without_a_graph_to_ship_keep_their_genotype() -> None:
    config = ExperimentConfig.from_plain(CONFIG)
    broken = BodySpec("nde", [[0.5] * 3], config.body.options)  # wrong shape: cannot decode
    assert shipped_body(config, broken) is broken
    prebuilt = ExperimentConfig.from_plain(
        {**CONFIG, "body": {"encoder": "prebuilt", "genotype": "gecko"}}
    )
    gecko = body_spec(prebuilt, "gecko")
    assert shipped_body(prebuilt, gecko) is gecko  # built directly by its encoder
    graph = shipped_body(config, body_spec(config, np.full((3, 64), 0.3)))
    assert shipped_body(config, graph) is graph


def _fitness_bits(run_dir: Path) -> list[tuple[str, str, str]]:
    evaluations = load_run(run_dir).evaluations.sort_values("eval_id")
    return [
        (e, float(f).hex(), s)
        for e, f, s in zip(evaluations["eval_id"], evaluations["fitness"], evaluations["status"])
    ]


def test_a_run_gives_the_same_fitness_as_with_genotypes_shipped(tmp_path: Path) -> None:
    shipped = run_experiment(copy.deepcopy(CONFIG), out=tmp_path / "graphs", progress=False)
    with pytest.MonkeyPatch.context() as patch:  # the former tasks: NDE genotypes
        patch.setattr(bodies, "shipped_body", lambda config, body: body)
        genotypes = run_experiment(
            copy.deepcopy(CONFIG), out=tmp_path / "genotypes", progress=False
        )
    assert shipped.evaluations == genotypes.evaluations > 0
    assert _fitness_bits(tmp_path / "graphs") == _fitness_bits(tmp_path / "genotypes")


def _worker_facts() -> dict[str, Any]:
    """Runs inside a worker: what it has imported, its resident memory, the bodies it built."""
    import sys

    import psutil

    from ariel.evaluation import _engine

    return {
        "torch": sorted(name for name in sys.modules if name.split(".")[0] == "torch"),
        "rss_mib": psutil.Process().memory_info().rss / 2**20,
        "built": len(_engine._BUILD_CACHE),
    }


def test_a_local_worker_evaluating_nde_bodies_never_imports_torch(tmp_path: Path) -> None:
    pytest.importorskip("psutil")
    import ariel.evaluation

    captured: list = []
    original = ariel.evaluation.evaluate_batch

    def capture(batch, **kwargs):
        captured.extend(batch)
        return original(batch, **kwargs)

    with pytest.MonkeyPatch.context() as patch:  # the very tasks the loop hands out
        patch.setattr(ariel.evaluation, "evaluate_batch", capture)
        run_experiment(copy.deepcopy(CONFIG), out=tmp_path / "run", progress=False)
    assert load_run(tmp_path / "run").config["body"]["encoder"] == "nde"
    assert len(captured) == 4 * 3 * 2
    serial = {r.eval_id: r.fitness for r in original(captured)}

    with make_executor("local", workers=1) as executor:
        results = executor.submit(evaluate_batch, captured).result()
        facts = executor.submit(_worker_facts).result()
    assert {r.eval_id: r.fitness for r in results} == serial
    assert all(r.status == "ok" for r in results)
    assert facts["built"] > 0  # this worker compiled the bodies itself
    assert facts["torch"] == []
    assert facts["rss_mib"] < WORKER_RSS_LIMIT_MIB, facts["rss_mib"]


def test_the_driver_keeps_compiled_models_of_living_bodies_only(tmp_path: Path) -> None:
    seen: list[tuple[int, set[int], set[int]]] = []
    original = RunDriver._end

    def watched(driver, generation):
        original(driver, generation)
        alive = {body.number for body in driver.state.population}
        seen.append((generation, set(driver.factory._models), alive))

    config = {**copy.deepcopy(CONFIG), "generations": 4}
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(RunDriver, "_end", watched)
        run_experiment(config, out=tmp_path / "run", progress=False)
    assert [generation for generation, _, _ in seen] == [0, 1, 2, 3]
    for generation, models, alive in seen:
        assert models <= alive, generation  # 2 living bodies, though 2 + 2 x 3 were made
    assert len(load_run(tmp_path / "run").bodies["body_id"].unique()) == 8


def _listed_columns(generation: int, frames: list) -> dict[str, list]:
    """The trajectories columns as Python lists (how the loop built them before)."""
    columns: dict[str, list] = {name: [] for name in trajectory_schema().names}
    for eval_id, result in frames:
        n = result.time.size
        columns["generation"] += [generation] * n
        columns["eval_id"] += [eval_id] * n
        columns["t"] += result.time.tolist()
        for axis, name in enumerate(("core_x", "core_y", "core_z")):
            columns[name] += result.core_pos[:, axis].tolist()
        columns["joint_target"] += result.joint_target.tolist()
        columns["joint_angle"] += result.joint_angle.tolist()
    return columns


def test_trajectory_columns_from_arrays_are_the_table_lists_made() -> None:
    rng = np.random.default_rng(0)
    frames = []
    for k, (frames_n, joints) in enumerate([(5, 3), (1, 0), (4, 8), (0, 2)]):
        result = EvaluationResult(
            eval_id=f"e{k}",
            fitness=0.0,
            status="ok",
            time=rng.random(frames_n),
            core_pos=rng.random((frames_n, 3)),
            joint_target=rng.random((frames_n, joints)),
            joint_angle=rng.random((frames_n, joints)),
        )
        frames.append((f"e{k}", result))
    schema = trajectory_schema()
    arrays = pa.Table.from_pydict(trajectory_columns(7, frames), schema=schema)
    lists = pa.Table.from_pydict(_listed_columns(7, frames), schema=schema)
    assert arrays.num_rows == 10
    assert arrays.equals(lists)
    empty = pa.Table.from_pydict(trajectory_columns(0, []), schema=schema)
    assert empty.num_rows == 0
