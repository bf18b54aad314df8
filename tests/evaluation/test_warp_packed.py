"""A generation's different bodies in one Warp launch (packed models), on Warp's CPU device:
each robot's results are its lone ones (the CPU engine's to MuJoCo Warp's float32 tolerance,
the same 1e-3 m of core position as tests/evaluation/test_warp.py), and a second generation of
other bodies in the same size bucket compiles no kernel."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _helpers import count_warp_module_loads

from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch
from ariel.evaluation.builtin_plugins import NaCPGController

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")
pytestmark = pytest.mark.warp

from ariel.evaluation._warp import WarpEvaluator  # noqa: E402
from ariel.evaluation._warp_packed import pack_plan  # noqa: E402

OPTIONS = {"number_of_modules": 12}


def generation(bodies: int, seed: int, **fields: object) -> list[EvaluationTask]:
    """Random NDE bodies (several sizes), 2 or 3 brains each, as a generation's batches."""
    from ariel.plugins import body_encoders

    encoder = body_encoders.make("nde", **OPTIONS)
    rng = np.random.default_rng(seed)
    tasks = []
    for k in range(bodies):
        body = BodySpec("nde", encoder.random_genotype(rng), OPTIONS)
        model = build(EvaluationTask(body=body)).model
        for p in NaCPGController().random_parameters(model, rng, 2 + k % 2):
            fields = {"duration": 0.3, "seed": 3 + k, "record_bodies": k % 3 == 0, **fields}
            tasks.append(EvaluationTask(body=body, params=p, eval_id=f"e{len(tasks)}", **fields))
    return tasks  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def evaluator() -> WarpEvaluator:
    return WarpEvaluator("cpu")


@pytest.mark.parametrize("bodies", [2, 8, 32])
def test_each_packed_robot_gives_its_lone_result(evaluator, bodies) -> None:
    tasks = generation(bodies, seed=bodies)
    packed, cpu = evaluator.evaluate_batch(tasks), evaluate_batch(tasks)
    assert len(evaluator._bodies) and any(
        getattr(b.built, "robots", None) for b in evaluator._bodies.values()
    )  # it did run packed
    for a, b in zip(packed, cpu, strict=True):
        assert a.eval_id == b.eval_id and a.status == b.status == "ok"
        assert a.backend == "mujoco-warp:cpu"
        np.testing.assert_array_equal(a.joint_target, b.joint_target)
        assert np.abs(a.core_pos - b.core_pos).max() < 1e-3
        assert abs(a.fitness - b.fitness) < 1e-3
        assert (a.body_pos is None) == (b.body_pos is None)
        if a.body_pos is not None:
            assert np.abs(a.body_pos - b.body_pos).max() < 1e-3


def test_a_body_packed_with_others_moves_as_alone_on_the_device(evaluator) -> None:
    tasks = generation(2, seed=5)
    together = evaluator.evaluate_batch(tasks)
    first = [t for t in tasks if t.body == tasks[0].body]
    alone = evaluator.evaluate_batch(first)  # one body: its own model, not packed
    for a, b in zip(together, alone):
        assert np.abs(a.core_pos - b.core_pos).max() < 1e-4
        np.testing.assert_array_equal(a.joint_target, b.joint_target)


def test_what_cannot_share_a_model_runs_alone(evaluator) -> None:
    from ariel.evaluation._engine import prepare_groups

    tasks = generation(3, seed=8)
    other_timing = [t for t in tasks if t.body == tasks[-1].body]
    tasks = [t for t in tasks if t.body != tasks[-1].body]
    tasks += [replace(t, duration=0.2) for t in other_timing]
    _, groups = prepare_groups(tasks)
    alone, packs, reasons = pack_plan(groups)
    assert [len(p) for p in packs] == [2] and len(alone) == 1
    assert alone[0].tasks[0].duration == 0.2
    assert reasons == {}  # it could be packed: only with none of the others


def test_a_second_generation_in_the_same_bucket_compiles_nothing(evaluator, monkeypatch) -> None:
    evaluator.evaluate_batch(generation(3, seed=21))
    fresh = count_warp_module_loads(monkeypatch)
    results = evaluator.evaluate_batch(generation(3, seed=22))  # other bodies, same bucket
    assert all(r.status == "ok" for r in results)
    assert fresh, "no Warp module was asked for: the count would be vacuous"
    assert sum(fresh) == 0, f"{sum(fresh)} Warp modules compiled or loaded for a new generation"


def test_bodies_that_cannot_be_packed_run_alone_and_say_why_once(monkeypatch, capsys) -> None:
    from ariel.evaluation import _warp_packed

    monkeypatch.setattr(_warp_packed, "_body_reason", lambda built: "a reason for the test")
    evaluator = WarpEvaluator("cpu")
    tasks = generation(2, seed=5)
    results = evaluator.evaluate_batch(tasks)
    evaluator.evaluate_batch(tasks)
    assert all(r.status == "ok" for r in results)
    assert not any(getattr(b.built, "robots", None) for b in evaluator._bodies.values())
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "note: gpu: 2 bodies of a generation are not packed into one model (a reason for the "
        "test); each runs alone on the device (docs/gpu.md)"
    ]
