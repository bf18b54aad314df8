"""The analysis notebooks run top to bottom on a tiny run (a real Jupyter kernel from this
environment's ipykernel) and show what they promise; the stored notebooks hold no outputs."""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ariel.evolution import run_experiment
from ariel.recording import joint_labels, load_run

EXTRA = "the analysis extra (pip install -e '.[analysis]')"
nbformat = pytest.importorskip("nbformat", reason=EXTRA)
nbclient = pytest.importorskip("nbclient", reason=EXTRA)
pytest.importorskip("ipykernel", reason=EXTRA)
pytest.importorskip("duckdb", reason=EXTRA)

ANALYSIS = Path(__file__).resolve().parents[2] / "analysis"
NOTEBOOKS = ("fitness_and_diversity", "gait_of_best")
# Like TINY in tests/evolution/test_loop.py: 3 generations of 3 + 3 bodies, ~2 s serial.
TINY = {
    "name": "tiny",
    "seed": 5,
    "generations": 3,
    "body": {"options": {"number_of_modules": 6}, "population": 3, "offspring": 3},
    "brain": {"popsize": 4, "iterations": 2},
    "task": {"duration": 1.0},
    "executor": {"kind": "serial"},
    "record": {"rerun": False},
}


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("analysis") / "tiny"
    run_experiment(TINY, out=out, progress=False)
    return out


def _execute(notebook, *, cwd: Path, home: Path, run_dir: Path | None) -> None:
    """Run ``notebook`` in place, in a kernel of this interpreter's ipykernel, in ``cwd``, with
    ``ARIEL_RUN_DIR`` set to ``run_dir`` (unset for None); Jupyter's files go under ``home``."""
    from ipykernel.kernelspec import write_kernel_spec
    from jupyter_client.manager import AsyncKernelManager

    spec = write_kernel_spec(home / "kernels" / "ariel-test")
    assert json.loads((Path(spec) / "kernel.json").read_text())["argv"][0] == sys.executable
    with pytest.MonkeyPatch.context() as env:
        if run_dir is None:
            env.delenv("ARIEL_RUN_DIR", raising=False)
        else:
            env.setenv("ARIEL_RUN_DIR", str(run_dir))
        env.setenv("JUPYTER_PATH", str(home))
        env.setenv("IPYTHONDIR", str(home / "ipython"))
        env.setenv("JUPYTER_RUNTIME_DIR", str(home / "runtime"))
        env.delenv("MPLBACKEND", raising=False)  # the notebooks pick `inline` themselves
        # IPC sockets in the temporary folder: no TCP ports, nothing in the working tree.
        manager = AsyncKernelManager(
            kernel_name="ariel-test", transport="ipc", ip=str(home / "ipc")
        )
        client = nbclient.NotebookClient(
            notebook, km=manager, timeout=120, resources={"metadata": {"path": str(cwd)}}
        )
        client.execute()  # raises CellExecutionError at the first failing cell


@pytest.fixture(scope="module")
def executed(tiny_run: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Both notebooks executed against the tiny run, from analysis/ as Jupyter would."""
    done = {}
    for name in NOTEBOOKS:
        notebook = nbformat.read(ANALYSIS / f"{name}.ipynb", as_version=4)
        _execute(notebook, cwd=ANALYSIS, home=tmp_path_factory.mktemp(name), run_dir=tiny_run)
        done[name] = notebook
    return done


def _outputs(notebook) -> list:
    return [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]


def _text(notebook) -> str:
    return "".join(o.get("text", "") for o in _outputs(notebook) if o.output_type == "stream")


def _figures(notebook) -> int:
    return sum("image/png" in o.get("data", {}) for o in _outputs(notebook))


def _cell_with(notebook, needle: str):
    (cell,) = [c for c in notebook.cells if c.cell_type == "code" and needle in c.source]
    return cell


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_stored_notebooks_have_no_outputs(name: str) -> None:
    notebook = nbformat.read(ANALYSIS / f"{name}.ipynb", as_version=4)
    nbformat.validate(notebook)
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert code
    for cell in code:
        assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]
    # The first code cell names the run: RUN_DIR, overridable by ARIEL_RUN_DIR.
    assert "RUN_DIR = None" in code[0].source and "ARIEL_RUN_DIR" in code[0].source


def test_fitness_and_diversity_draws_curves_descriptors_and_the_lineage_of_the_best(
    executed: dict, tiny_run: Path
) -> None:
    notebook = executed["fitness_and_diversity"]
    assert str(tiny_run) in _text(notebook)  # it read the run named by ARIEL_RUN_DIR
    assert _figures(notebook) == 3  # fitness curves, descriptor boxplots, lineage graph
    for needle in ("ax.scatter(ok", "ax.boxplot(", "nx.draw_networkx_nodes("):
        assert any("image/png" in o.get("data", {}) for o in _cell_with(notebook, needle).outputs)

    # The lineage ends at the best body, and each step is a parent -> child link in the table.
    run = load_run(tiny_run)
    bodies = run.bodies.drop_duplicates("body_id").set_index("body_id")
    ok = bodies[(bodies["status"] == "ok") & bodies["fitness"].map(math.isfinite)]
    best = ok.sort_values("fitness", ascending=False, kind="stable").index[0]
    assert re.search(rf"^best body: {best} ", _text(notebook), re.MULTILINE)
    line = re.search(r"^lineage: (.*)$", _text(notebook), re.MULTILINE).group(1).split(" -> ")
    assert line[-1] == best and len(line) >= 2  # generation 2's best has ancestors
    first = bodies.loc[line[0]]
    assert first["born_generation"] == 0 and not len(first["parent_ids"])  # a random body
    for parent, child in itertools.pairwise(line):
        assert bodies.loc[child, "parent_ids"][0] == parent
    ancestors, todo = set(), [best]
    while todo:
        for parent in bodies.loc[todo.pop(), "parent_ids"]:
            if parent not in ancestors:
                ancestors.add(parent)
                todo.append(parent)
    assert f"ancestors: {len(ancestors)}\n" in _text(notebook)


def test_the_morphology_is_that_of_the_population_the_report_draws(
    executed: dict, tiny_run: Path
) -> None:
    """The notebook's morphology figure and ``ariel report``'s morphology.png: the same bodies
    (the population after selection, `Run.population`) under the same title."""
    from ariel.recording._report import MORPHOLOGY_TITLE

    cell = _cell_with(executed["fitness_and_diversity"], "ax.boxplot(")
    assert "\npopulation = run.population\n" in cell.source
    assert f'fig.suptitle("{MORPHOLOGY_TITLE}")' in cell.source
    run = load_run(tiny_run)
    sizes = run.population.groupby("generation").size()
    assert (sizes < run.bodies.groupby("generation").size()).any()  # not every body of it
    shown = "".join(o.get("data", {}).get("text/plain", "") for o in cell.outputs)
    assert "distinct graphs" in shown
    for generation, size in sizes.items():
        assert re.search(rf"^{generation}\s+{size}\s", shown, re.MULTILINE), shown


def test_duckdb_reads_the_parquet_tables_in_place(executed: dict, tiny_run: Path) -> None:
    cell = _cell_with(executed["fitness_and_diversity"], "duckdb.sql(")
    (table,) = [o for o in cell.outputs if "text/plain" in o.get("data", {})]
    shown = table["data"]["text/plain"]
    assert "best_fitness" in shown and "evaluations" in shown
    run = load_run(tiny_run)
    ok = run.evaluations[run.evaluations["status"] == "ok"]
    for generation, count in ok.groupby("generation").size().items():
        assert re.search(rf"^\d+\s+{generation}\s+{count}\s", shown, re.MULTILINE), shown


def test_gait_of_best_plots_the_core_path_and_joint_signals_of_the_best(
    executed: dict, tiny_run: Path
) -> None:
    notebook = executed["gait_of_best"]
    evaluations = load_run(tiny_run).evaluations
    ok = evaluations[evaluations["status"] == "ok"]
    best = ok.sort_values("fitness", ascending=False, kind="stable").iloc[0]
    assert f"best evaluation: {best['eval_id']} " in _text(notebook)
    assert "11 frames over 1.00 simulated seconds" in _text(notebook)  # 10 Hz over 1 s
    assert _figures(notebook) == 2  # the core's path, the joints
    joints = _cell_with(notebook, "joint_target")
    tracking = [o for o in joints.outputs if "text/html" in o.get("data", {})]
    html = tracking[0]["data"]["text/html"]
    for name in best["joint_names"]:
        assert name in html
    run = load_run(tiny_run)
    graph = run.bodies.loc[run.bodies["body_id"] == best["body_id"], "graph"].iloc[0]
    for label in joint_labels(best["joint_names"], graph):  # "right branch, hinge 1"
        assert f"<td>{label}</td>" in html


def test_without_run_dir_the_newest_finished_run_under_data_runs_is_read(
    tiny_run: Path, tmp_path
) -> None:
    """The first cell, run from a checkout whose data/runs holds two finished runs and, newer,
    one interrupted after its first generation and one before (no tables): both are passed
    over, and the cell says so."""
    checkout = tmp_path / "checkout"
    (checkout / "analysis").mkdir(parents=True)
    (checkout / "pyproject.toml").write_text("")
    shutil.copy(ANALYSIS / "run_choice.py", checkout / "analysis")
    for name, created, done in (
        ("older", "2026-01-02T00:00:00+00:00", None),
        ("newer", "2026-03-04T00:00:00+00:00", None),
        ("abandoned", "2026-04-05T00:00:00+00:00", 1),
        ("interrupted", "2026-05-06T00:00:00+00:00", 0),
    ):
        folder = checkout / "data" / "runs" / name
        shutil.copytree(tiny_run, folder)
        info = json.loads((folder / "run.json").read_text())
        info = {**info, "created": created, "run_id": name}
        if done is not None:
            info = {**info, "generations_done": done, "status": "interrupted"}
        (folder / "run.json").write_text(json.dumps(info))
    for name in ("fitness_and_diversity", "gait_of_best"):
        notebook = nbformat.read(ANALYSIS / f"{name}.ipynb", as_version=4)
        notebook.cells = [next(c for c in notebook.cells if c.cell_type == "code")]
        home = tmp_path / f"jupyter-{name}"
        _execute(notebook, cwd=checkout / "analysis", home=home, run_dir=None)
        text = _text(notebook)
        assert text.startswith("run newer (finished)")
        runs = checkout / "data" / "runs"
        assert f"\nchosen: the newest finished run under {runs}; passed over, newer: " in text
        assert "interrupted (interrupted, 0 generations), abandoned (interrupted, 1 " in text


# --- compare_conditions.ipynb: a campaign's conditions from pandas ------------------------------


@pytest.fixture(scope="module")
def tiny_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from ariel.runs import run_campaign

    out = tmp_path_factory.mktemp("campaign") / "tiny"
    tiny = Path(__file__).resolve().parents[1] / "data" / "campaign_tiny.toml"
    assert run_campaign(tiny, out=out).status == "finished"
    return out


def test_compare_conditions_is_stored_without_outputs() -> None:
    notebook = nbformat.read(ANALYSIS / "compare_conditions.ipynb", as_version=4)
    nbformat.validate(notebook)
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert all(c.outputs == [] and c.execution_count is None for c in code)
    assert "CAMPAIGN_DIR = None" in code[0].source and "ARIEL_CAMPAIGN_DIR" in code[0].source


def test_compare_conditions_shows_the_comparison_of_compare_from_pandas(
    tiny_campaign: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ariel.recording import compare, load_campaign

    notebook = nbformat.read(ANALYSIS / "compare_conditions.ipynb", as_version=4)
    monkeypatch.setenv("ARIEL_CAMPAIGN_DIR", str(tiny_campaign))
    _execute(notebook, cwd=ANALYSIS, home=tmp_path / "jupyter", run_dir=None)
    text = _text(notebook)
    assert "conditions fresh, inherit; seeds [1, 2]" in text
    assert _figures(notebook) == 3  # best so far, final best, morphology
    # The notebook's final bests and A12 are those of `ariel compare`.
    comparison = compare([tiny_campaign], out=tmp_path / "compare")
    for run in comparison.runs.to_dict("records"):
        assert f"{run['final_best']:.4f}" in text
    (table,) = [
        o
        for o in _cell_with(notebook, "comparison.table()").outputs
        if o.output_type == "execute_result"
    ]
    # The table the command prints (one function makes both): every cell, A12 with its n.
    shown = table["data"]["text/plain"]
    for row in comparison.table().itertuples(index=False):
        assert all(str(cell) in shown for cell in row), (row, shown)
    a12 = comparison.stats.loc[0, "a12"]
    assert f"{a12:.2f} (n=2 vs 2)" in shown and "warning: fewer than 5 runs" in text
    assert load_campaign(tiny_campaign).maximise


def test_a_brain_only_run_s_best_body_shows_its_best_fitness(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """The one body of a brain-only run improves every generation: the lineage cell prints
    its fitness after the last generation, the run's best, not generation 0's."""
    out = tmp_path_factory.mktemp("analysis") / "gecko"
    gecko = {
        **TINY,
        "name": "gecko",
        "body": {"encoder": "prebuilt", "genotype": "gecko"},
        "task": {"duration": 0.6},
    }
    run_experiment(gecko, out=out, progress=False)
    bodies = load_run(out).bodies
    assert bodies["fitness"].nunique() > 1  # it did improve
    notebook = nbformat.read(ANALYSIS / "fitness_and_diversity.ipynb", as_version=4)
    _execute(notebook, cwd=ANALYSIS, home=tmp_path_factory.mktemp("gecko-nb"), run_dir=out)
    shown = re.search(r"^best body: (\S+) \(fitness (\S+),", _text(notebook), re.MULTILINE)
    assert shown.group(2) == f"{bodies['fitness'].max():.6g}"


# --- the README's headless command, as typed at the repository root ------------------------------


def _readme_command(run_id: str, out: Path) -> str:
    """analysis/README.md's `jupyter nbconvert --execute` command, its `<run-id>` and output
    folder filled in."""
    readme = (ANALYSIS / "README.md").read_text()
    start = readme.index("ARIEL_RUN_DIR=data/runs/<run-id> .venv/bin/jupyter nbconvert")
    lines = []
    for line in readme[start:].splitlines():
        lines.append(line.split("#", 1)[0].rstrip().removesuffix("\\"))
        if not line.split("#", 1)[0].rstrip().endswith("\\"):
            break
    command = " ".join(part.strip() for part in lines)
    assert command.endswith("--output-dir /tmp"), command
    return command.replace("<run-id>", run_id).removesuffix("/tmp") + str(out)


def test_the_readme_command_renders_a_run_named_relative_to_the_root(
    tiny_run: Path, tmp_path: Path
) -> None:
    """`ARIEL_RUN_DIR=data/runs/<id> .venv/bin/jupyter nbconvert ...` typed at the root of a
    checkout: the kernel runs in analysis/, and still reads <root>/data/runs/<id>; a run that
    is not there ends the output in one line naming where it looked."""
    pytest.importorskip("nbconvert", reason="nbconvert: the analysis extra, which make installs")
    checkout = tmp_path / "checkout"
    (checkout / "analysis").mkdir(parents=True)
    for name in ("gait_of_best.ipynb", "run_choice.py"):
        shutil.copy(ANALYSIS / name, checkout / "analysis")
    shutil.copytree(tiny_run, checkout / "data" / "runs" / "tiny")
    (checkout / ".venv").symlink_to(sys.prefix)  # this environment, as `make` makes it
    home = tmp_path / "home"
    env = {
        **os.environ,
        "JUPYTER_DATA_DIR": str(home / "data"),  # no user kernel "python3" in the way
        "JUPYTER_CONFIG_DIR": str(home / "config"),
        "JUPYTER_RUNTIME_DIR": str(home / "runtime"),
        "IPYTHONDIR": str(home / "ipython"),
        "PWD": str(checkout),  # as a shell in the checkout would have it
    }
    env.pop("MPLBACKEND", None)
    env.pop("ARIEL_RUN_DIR", None)
    out = tmp_path / "html"
    command = _readme_command("tiny", out)

    done = subprocess.run(
        command, shell=True, cwd=checkout, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    html = (out / "gait_of_best.html").read_text()
    assert "chosen: ARIEL_RUN_DIR=data/runs/tiny" in html
    assert str(checkout / "data" / "runs" / "tiny") in html and "<img" in html

    typo = command.replace("data/runs/tiny", "data/runs/tinny")
    failed = subprocess.run(
        typo, shell=True, cwd=checkout, env=env, capture_output=True, text=True, timeout=300
    )
    assert failed.returncode != 0
    last = failed.stderr.strip().splitlines()[-1]
    assert last.startswith("error: ARIEL_RUN_DIR=data/runs/tinny: no such folder (looked in ")
    assert str(checkout / "data" / "runs" / "tinny") in last
    assert "Traceback" not in failed.stderr.split("------------------")[-1]  # the kernel's part
