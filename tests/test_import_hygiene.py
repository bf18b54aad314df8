"""Nothing happens on import: no heavy libraries where they are not needed, no files, no RNG."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = ("torch", "matplotlib", "rerun", "warp", "mujoco_warp")

PROBE = """
import json, sys, os
before = set(os.listdir("."))
import {module}
print(json.dumps({{"loaded": sorted(m for m in {heavy} if m in sys.modules),
                   "new_files": sorted(set(os.listdir(".")) - before)}}))
"""


def _probe(module: str, cwd: Path) -> dict:
    code = PROBE.format(module=module, heavy=repr(HEAVY))
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "module",
    [
        "ariel",
        "ariel.evaluation",
        "ariel.plugins",
        "ariel.body_phenotypes.robogen_lite.config",
        "ariel.body_phenotypes.robogen_lite.modules.core",
        "ariel.body_phenotypes.robogen_lite.modules.hinge",
        "ariel.body_phenotypes.robogen_lite.prebuilt_robots.gecko",
        "ariel.body_phenotypes.robogen_lite.constructor",
        "ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding",
        "ariel.body_phenotypes.robogen_lite.decoders.cppn_best_first",
        "ariel.body_phenotypes.robogen_lite.cppn_encoder",
        "ariel.ec.genotypes.tree.encoder",
        "ariel.utils.morphological_descriptor",
        "ariel.simulation.environments",
        "ariel.simulation.controllers.controller",
        "ariel.simulation.controllers.cpg_kernel",
        "ariel.evaluation._engine",
        "ariel.evaluation._warp",
        "ariel.evaluation.executors",
        "ariel.evaluation.builtin_plugins",
        "ariel.ec.genotypes.nde.encoder",
        "ariel.body_phenotypes.robogen_lite.prebuilt_robots.encoder",
        "ariel.body_phenotypes.robogen_lite.graph_encoder",
        "ariel.evaluation._warp_cpg",
        "ariel.evaluation._checks",
        "ariel.errors",
        "ariel.simulation.controllers.observations",
        "ariel.evolution",
        "ariel.evolution._driver",
        "ariel.evolution._scheduler",
        "ariel.evolution._ga",
        "ariel.runs",
        "ariel.runs._experiment",
        "ariel.runs._prepare",
        "ariel.runs._campaign",
        "ariel.runs._campaign_file",
        "ariel.recording.store._campaign",
        "ariel.recording.rerun._campaign_rerun",
        "ariel.recording.store._curves",
        "ariel.recording.analysis._compare",
        "ariel.recording.analysis._compare_stats",
        "ariel.recording.analysis._compare_plots",
        "ariel.recording.analysis._compare_html",
        "ariel.cli._campaign",
        "ariel.recording.store._rows",
        "ariel.recording",
        "ariel.recording.store._load",
        "ariel.recording.resim._replay",
        "ariel.recording.analysis._report",
        "ariel.evolution._tasks",
        "ariel.recording.rerun._recorder",
        "ariel.recording.rerun._rerun",
        "ariel.cli",
        "ariel.cli._config",
        "ariel.cli._prune",
        "ariel.ec",
        "ariel.ec.ea",
        "ariel.ec.archive",
        "ariel.ec.crossover",
        "ariel.ec.generators",
        "ariel.ec.a004",
    ],
)
def test_import_loads_no_heavy_library_and_writes_no_file(module: str, tmp_path: Path) -> None:
    report = _probe(module, tmp_path)
    assert report["loaded"] == [], f"{module} imported {report['loaded']}"
    assert report["new_files"] == []


def test_importing_the_tutorial_modules_writes_no_file(tmp_path: Path) -> None:
    # The NDE and NaCPG need torch (the tutorial API); they still create nothing.
    for module in ("ariel.ec.genotypes.nde.nde", "ariel.simulation.controllers.na_cpg"):
        assert _probe(module, tmp_path)["new_files"] == []


def test_ec_loads_the_database_layer_only_when_the_engine_is_used(tmp_path: Path) -> None:
    # Population, EAOperation and the operators are plain Python; Individual (an SQLModel table)
    # and EA bring in sqlmodel/sqlalchemy, and only when a script asks for them.
    code = (
        "import sys, json, ariel, ariel.ec\n"
        "from ariel.ec import Population, EAOperation, Crossover, set_seed\n"
        "c = ariel.console\n"
        "print(json.dumps(sorted(m for m in ('sqlmodel', 'sqlalchemy', 'pydantic_settings',"
        " 'torch', 'matplotlib', 'rerun') if m in sys.modules)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
    assert os.listdir(tmp_path) == []  # config's ./__data__ is not created either


def test_using_the_api_leaves_python_s_random_state_alone() -> None:
    """rich draws from `random` as it loads: a script's ``random.seed(0)`` before its first
    use of ariel gave other draws after it."""
    script = (
        "import random\n"
        "random.seed(0); expected = random.random(); random.seed(0)\n"
        "import ariel, ariel.runs, ariel.recording\n"
        "ariel.runs.run_experiment, ariel.recording.make_report, ariel.console\n"
        "print(random.random() == expected)\n"
    )
    _prints_true(script)


def _prints_true(script: str) -> None:
    """``script``, run in a fresh interpreter, prints True."""
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.stdout.strip() == "True", done.stderr[-2000:]


def test_loading_a_plugin_leaves_the_global_generators_alone() -> None:
    """nevergrad's import draws from `random` and NumPy's global generator: a script that
    seeded both and then looked up the nevergrad learner got other draws after."""
    script = (
        "import random, numpy as np, ariel.plugins\n"
        "random.seed(0); np.random.seed(0); expected = (random.random(), np.random.random())\n"
        "random.seed(0); np.random.seed(0)\n"
        "ariel.plugins.brain_optimizers.get('nevergrad')\n"
        "print((random.random(), np.random.random()) == expected)\n"
    )
    _prints_true(script)
