"""An upstream-style script (evolve_gecko_cpg.py) run end to end, read back like upstream's
``simulate_from_db`` readers do, and its best gait replayed through the tutorial API."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from sqlmodel import Session, col, create_engine, select

from ariel.ec import Individual

SCRIPT = Path(__file__).with_name("evolve_gecko_cpg.py")
ARGS = ("--generations", "3", "--pop", "6", "--duration", "2", "--seed", "5")


def _run(out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *ARGS, "--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
        cwd=out.parent,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads((out / "summary.json").read_text())


def _read_db(db: Path) -> list[Individual]:
    """What a ``simulate_from_db`` script does: its own engine, a sqlmodel select."""
    with Session(create_engine(f"sqlite:///{db}")) as session:
        return list(session.exec(select(Individual).order_by(col(Individual.id))).all())


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict, Path]:
    first, second = tmp_path_factory.mktemp("a") / "run", tmp_path_factory.mktemp("b") / "run"
    return first, _run(first), second


def test_the_script_writes_one_individual_per_row_with_lifetimes(runs: tuple) -> None:
    out, summary, _ = runs
    rows = _read_db(out / "database.db")
    assert all(not r.requires_eval and r.tags.get("status") == "ok" for r in rows)
    assert all(len(r.genotype) == 40 for r in rows)  # 8 joints x 5 CPG parameters
    assert {r.time_of_birth for r in rows} == {0, 1, 2, 3}
    for gen in range(4):  # the population at the end of every generation has --pop members
        at_end = [
            r
            for r in rows
            if r.time_of_birth <= gen
            and (r.time_of_death > gen or (r.time_of_death == gen and r.alive))
        ]
        assert len(at_end) == 6
    best = max(rows, key=lambda r: r.fitness)
    assert (summary["best_id"], summary["best_fitness"]) == (best.id, best.fitness)
    children = [r for r in rows if r.time_of_birth > 0]
    assert children and all(len(r.tags["parents"]) == 2 for r in children)


def test_elitist_survival_never_loses_the_best(runs: tuple) -> None:
    rows = _read_db(runs[0] / "database.db")
    best_alive = [
        max(r.fitness for r in rows if r.time_of_birth <= g <= r.time_of_death) for g in range(4)
    ]
    assert best_alive == sorted(best_alive) and best_alive[-1] > 0


def test_same_seed_same_database(runs: tuple) -> None:
    first, _, second = runs
    _run(second)
    dump = [r.model_dump() for r in _read_db(first / "database.db")]
    assert dump == [r.model_dump() for r in _read_db(second / "database.db")]


def test_best_gait_replays_through_the_tutorial_api(runs: tuple) -> None:
    """The fitness stored by the batched engine is what the tutorial's Controller path gives."""
    from ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko import gecko
    from ariel.evaluation.builtin_plugins import NaCPGController
    from ariel.simulation.controllers.controller import Controller
    from ariel.simulation.controllers.na_cpg import NaCPG, create_fully_connected_adjacency
    from ariel.simulation.environments import SimpleFlatWorld
    from ariel.utils.runners import simple_runner

    best = max(_read_db(runs[0] / "database.db"), key=lambda r: r.fitness)
    mujoco.set_mjcb_control(None)
    world = SimpleFlatWorld()
    world.spawn(gecko().spec, position=[0, 0, 0])
    model = world.spec.compile()
    data = mujoco.MjData(model)
    cpg = NaCPG(create_fully_connected_adjacency(model.nu), hard_bounds=(-np.pi / 2, np.pi / 2))
    cpg.set_flat_params(best.genotype)
    cpg.set_initial_state(*NaCPGController().initial_state(model, 5))  # the script's --seed
    controller = Controller(lambda m, d: cpg.forward(time=d.time), alpha=0.5)
    core = model.geom("robot1_core").id
    mujoco.mj_forward(model, data)
    start = data.geom_xpos[core, :2].copy()
    mujoco.set_mjcb_control(controller.set_control)
    try:
        simple_runner(model, data, duration=2.0)
    finally:
        mujoco.set_mjcb_control(None)
    mujoco.mj_forward(model, data)
    walked = float(np.linalg.norm(data.geom_xpos[core, :2] - start))
    assert walked == pytest.approx(best.fitness, rel=1e-9, abs=1e-12)
