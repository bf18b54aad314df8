"""The analysis notebooks run top to bottom on a tiny run (a real Jupyter kernel from this
environment's ipykernel) and show what they promise; the stored notebooks hold no outputs."""

from __future__ import annotations

import inspect
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
from _helpers import with_run_id

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
    # A folder name DuckDB would read as a glob pattern ([1] is "1", ? any one character):
    # the notebooks read the run's files by name (the DuckDB cell found no file).
    out = tmp_path_factory.mktemp("analysis") / "exp?[1]" / "tiny"
    run_experiment(TINY, out=out, progress=False)
    return out


def describe_figure(figure) -> dict:
    """What a reader sees of a matplotlib figure: its title, and per visible axes the title,
    axis labels, whether the ticks shown are whole numbers, and the colour of each labelled
    line or single-coloured collection (label -> hex). The notebooks' figures are described
    by this same function in their kernel (`PROBE`), the report's here."""
    from matplotlib.colors import to_hex

    def whole(axis, limits) -> bool:
        low, high = sorted(limits)
        shown = [t for t in axis.get_majorticklocs() if low - 1e-9 <= t <= high + 1e-9]
        return bool(shown) and all(float(t).is_integer() for t in shown)

    axes = []
    for ax in figure.axes:
        if not ax.get_visible():
            continue
        colours = {}
        for line in ax.get_lines():
            colours[line.get_label()] = to_hex(line.get_color())
        for collection in ax.collections:
            faces = collection.get_facecolor()
            if collection.get_array() is None and len(faces):  # not colour-mapped
                colours[collection.get_label()] = to_hex(faces[0])
        axes.append(
            {
                "title": " ".join(ax.get_title().split() or ax.get_title(loc="left").split()),
                "xlabel": ax.get_xlabel(),
                "ylabel": ax.get_ylabel(),
                "whole_x": whole(ax.xaxis, ax.get_xlim()),
                "whole_y": whole(ax.yaxis, ax.get_ylim()),
                "colours": {k: v for k, v in colours.items() if not k.startswith("_")},
            }
        )
    return {"title": figure.get_suptitle(), "axes": axes}


#: A first cell for a notebook under test: every figure it shows carries, as its text/plain,
#: ``figure `` and `describe_figure`'s JSON (read back by `_drawn`). Registered again before
#: every cell: ``%matplotlib inline`` drops every formatter of figures.
PROBE = (
    "import json as _json\n\n"
    + inspect.getsource(describe_figure)
    + "\n\ndef _describe(figure, printer, cycle):\n"
    "    printer.text('figure ' + _json.dumps(describe_figure(figure)))\n\n\n"
    "def _register(*_):\n"
    "    plain = get_ipython().display_formatter.formatters['text/plain']\n"
    "    plain.for_type_by_name('matplotlib.figure', 'Figure', _describe)\n\n\n"
    "_register()\n"
    "get_ipython().events.register('pre_run_cell', _register)\n"
)


def _drawn(cell) -> list[dict]:
    """`describe_figure` of every figure ``cell`` showed, in order (a notebook run with
    `PROBE`)."""
    shown = [o["data"]["text/plain"] for o in cell.outputs if "image/png" in o.get("data", {})]
    assert all(text.startswith("figure {") for text in shown), shown
    return [json.loads(text.removeprefix("figure ")) for text in shown]


def _execute(notebook, *, cwd: Path, home: Path, run_dir: Path | None) -> None:
    """Run ``notebook`` in place, in a kernel of this interpreter's ipykernel, in ``cwd``, with
    ``ARIEL_RUN_DIR`` set to ``run_dir`` (unset for None); Jupyter's files go under ``home``.
    A first cell (`PROBE`) is added: each figure shown carries its description (`_drawn`)."""
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
        notebook.cells.insert(0, nbformat.v4.new_code_cell(PROBE))
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


@pytest.mark.parametrize("name", [*NOTEBOOKS, "compare_conditions"])
def test_notebooks_read_only_config_keys_every_run_has(name: str) -> None:
    """Older runs' configs lack later keys: ``run.config["body"]["optimizer"]`` was a KeyError
    on a run made before body optimizers had names (`Run.body_optimizer` answers for it)."""
    notebook = nbformat.read(ANALYSIS / f"{name}.ipynb", as_version=4)
    code = "\n".join(c.source for c in notebook.cells if c.cell_type == "code")
    read = set(re.findall(r"config((?:\[[^\]]+\])+)", code))
    assert read <= {'["task"]["fitness"]'}, read


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
    line = re.search(r"^first parents only: (.*)$", _text(notebook), re.MULTILINE)
    line = line.group(1).split(" -> ")
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
    assert (
        f"ancestors: {len(ancestors)} (every parent of every parent, back to generation 0)\n"
        in (_text(notebook))
    )


def test_the_morphology_is_that_of_the_population_the_report_draws(
    executed: dict, tiny_run: Path
) -> None:
    """The notebook's morphology figure and ``ariel report``'s morphology.png: the same bodies
    (the population after selection, `Run.population`) under the same title."""
    from ariel.recording.analysis._report import MORPHOLOGY_TITLE

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


@pytest.fixture(scope="module")
def report(tiny_run: Path, tmp_path_factory: pytest.TempPathFactory):
    """`ariel report` of a copy of the tiny run (its figures, to hold the notebooks' to)."""
    from ariel.recording import make_report

    copy = tmp_path_factory.mktemp("report") / "tiny"
    shutil.copytree(tiny_run, copy)
    return make_report(copy, render=False)


def test_fitness_and_diversity_draws_as_the_report_does(executed: dict, report) -> None:
    """The notebook's figures follow `ariel report`'s: the same labels with units, whole
    generations on the x axis, the same colour for each line."""
    from ariel.recording.analysis._report import MORPHOLOGY_TITLE
    from ariel.recording.store._axes import DESCRIPTORS, fitness_label

    notebook = executed["fitness_and_diversity"]
    (fitness,) = _drawn(_cell_with(notebook, "ax.scatter(ok"))
    (drawn,) = fitness["axes"]
    (theirs,) = describe_figure(report.figures["fitness.png"])["axes"]
    label = fitness_label("xy_displacement", True)
    assert drawn["ylabel"] == theirs["ylabel"] == label  # the fitness function's unit
    assert label == "fitness: xy_displacement (m), higher is better"
    assert drawn["xlabel"] == theirs["xlabel"] == "generation"
    assert drawn["whole_x"] and theirs["whole_x"]  # 0, 1, 2: no 0.25 generations
    assert set(drawn["colours"]) == {"evaluations", "mean", "median", "best"}
    assert drawn["colours"] == theirs["colours"]  # best green, mean blue, median orange, grey
    assert theirs["title"].endswith(f": {drawn['title']}")

    (morphology,) = _drawn(_cell_with(notebook, "ax.boxplot("))
    theirs = {a["title"]: a for a in describe_figure(report.figures["morphology.png"])["axes"]}
    assert len(morphology["axes"]) == 6 and morphology["title"] == MORPHOLOGY_TITLE
    for axes in morphology["axes"]:
        name = axes["title"]
        unit, whole = DESCRIPTORS[name]
        assert axes["ylabel"] == theirs[name]["ylabel"] == unit, name  # "extent_x": m
        assert axes["whole_x"], name
        assert axes["colours"] == theirs[name]["colours"], name
        if whole:  # a count: 2, 3, 4 leaf modules, never 2.5
            assert axes["whole_y"] and theirs[name]["whole_y"], name
    assert [a["xlabel"] for a in morphology["axes"][3:]] == ["generation"] * 3

    (lineage,) = _drawn(_cell_with(notebook, "nx.draw_networkx_nodes("))
    assert label in [a["ylabel"] for a in lineage["axes"]]  # the colour bar: fitness (m)


def test_gait_of_best_draws_as_the_report_does(executed: dict, report) -> None:
    notebook = executed["gait_of_best"]
    (path,) = _drawn(_cell_with(notebook, "core_x"))
    theirs = describe_figure(report.figures["trajectory.png"])["axes"]
    top, height, away = (a for a in path["axes"] if a["ylabel"] != "time (s)")
    assert (top["xlabel"], top["ylabel"]) == (theirs[0]["xlabel"], theirs[0]["ylabel"])
    assert (top["xlabel"], top["ylabel"]) == ("core x (m)", "core y (m)")
    assert {"start", "end"} <= set(top["colours"]) and {"start", "end"} <= set(theirs[0]["colours"])
    assert [a["ylabel"] for a in path["axes"]].count("time (s)") == 1  # the colour bar, as theirs
    assert [a["ylabel"] for a in theirs].count("time (s)") == 1
    assert (height["xlabel"], height["ylabel"]) == ("time (s)", "core z (m)")
    assert (away["xlabel"], away["ylabel"]) == ("time (s)", "distance from the start (m)")

    (joints,) = _drawn(_cell_with(notebook, "joint_target"))
    theirs = describe_figure(report.figures["joints.png"])["axes"]
    assert [a["title"] for a in joints["axes"]] == [a["title"] for a in theirs]  # joint_labels
    for axes, their in zip(joints["axes"], theirs):
        assert axes["ylabel"] == their["ylabel"] == "angle (rad)"
        assert axes["colours"] == their["colours"]  # target blue dashed, angle orange
        assert set(axes["colours"]) == {"target", "angle"}
    assert joints["axes"][-1]["xlabel"] == "time (s)"


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
        info = json.loads((with_run_id(folder, name) / "run.json").read_text())
        info = {**info, "created": created}
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


@pytest.fixture(scope="module")
def compared(tiny_campaign: Path, tmp_path_factory: pytest.TempPathFactory):
    """compare_conditions.ipynb executed against the tiny campaign, from analysis/."""
    notebook = nbformat.read(ANALYSIS / "compare_conditions.ipynb", as_version=4)
    with pytest.MonkeyPatch.context() as env:
        env.setenv("ARIEL_CAMPAIGN_DIR", str(tiny_campaign))
        home = tmp_path_factory.mktemp("jupyter-compare")
        _execute(notebook, cwd=ANALYSIS, home=home, run_dir=None)
    return notebook


def test_compare_conditions_is_stored_without_outputs() -> None:
    notebook = nbformat.read(ANALYSIS / "compare_conditions.ipynb", as_version=4)
    nbformat.validate(notebook)
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert all(c.outputs == [] and c.execution_count is None for c in code)
    assert "CAMPAIGN_DIR = None" in code[0].source and "ARIEL_CAMPAIGN_DIR" in code[0].source


def test_compare_conditions_shows_the_comparison_of_compare_from_pandas(
    compared, tiny_campaign: Path, tmp_path: Path
) -> None:
    from ariel.recording import compare, load_campaign

    notebook = compared
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
    # Its headings: the Holm-corrected p, the test the design calls for (shared seeds: paired).
    heading = [line for line in shown.splitlines() if "p (Holm)" in line]
    assert heading and "A12 (n)" in shown and "median A (mean ± sd)" in shown
    assert table["data"]["text/html"].count("<th>p (Holm)</th>") == 1
    assert "Wilcoxon signed-rank, 2 pairs" in shown and "Mann" not in shown
    about = f"{comparison.title}: xy_displacement, higher is better"  # the command's titles
    for part in ("per condition", "pairs of conditions"):
        assert f"{about}: {part}\n" in text
    summary = "".join(
        o["data"].get("text/plain", "")
        for o in _cell_with(notebook, "comparison.summary_table()").outputs
        if o.output_type == "display_data"
    )
    for row in comparison.summary_table().itertuples(index=False):
        assert all(str(cell) in summary for cell in row), (row, summary)
    assert "final best: mean ± sd" in summary


def test_compare_conditions_draws_as_compare_does(compared, tiny_campaign: Path) -> None:
    """The notebook's figures: `ariel compare`'s colour for each condition, its axis labels
    (the fitness's unit, a descriptor's unit) and whole numbers of evaluations."""
    from matplotlib.colors import to_hex

    from ariel.recording import compare, condition_colours
    from ariel.recording.store._axes import DESCRIPTORS, fitness_label

    notebook = compared
    comparison = compare([tiny_campaign], write=False)
    colours = {name: to_hex(c) for name, c in condition_colours(comparison.conditions).items()}
    assert len(set(colours.values())) == 2
    ylabel = fitness_label("xy_displacement", True, what="best fitness")
    assert ylabel == "best fitness: xy_displacement (m), higher is better"

    (best,) = _drawn(_cell_with(notebook, "pivot_table("))
    (axes,) = best["axes"]
    assert (axes["xlabel"], axes["ylabel"]) == ("evaluations", ylabel) and axes["whole_x"]
    for name, colour in colours.items():
        assert axes["colours"][name] == colour  # the median line
        assert next(v for k, v in axes["colours"].items() if k.startswith(f"{name}: ")) == colour

    (final,) = _drawn(_cell_with(notebook, "ax.boxplot("))
    (axes,) = final["axes"]
    assert axes["ylabel"] == ylabel
    assert {k: v for k, v in axes["colours"].items() if k in colours} == colours  # the dots

    (morphology,) = _drawn(_cell_with(notebook, "DESCRIPTORS[descriptor]"))
    titles = [a["title"] for a in morphology["axes"]]
    assert titles == ["num_modules", "num_limbs", "joints_ratio", "symmetry"]
    for axes in morphology["axes"]:
        assert axes["ylabel"] == DESCRIPTORS[axes["title"]][0]  # modules, hinges / modules
        assert axes["xlabel"] == "evaluations" and axes["whole_x"]
        assert {k: v for k, v in axes["colours"].items() if k in colours} == colours


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


def test_the_run_notebook_needs_no_fitness_plugin_and_reads_finished_generations_only(
    tiny_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its first cell asked the fitness plugin for the direction (a traceback for a run whose
    plugin is not installed here; run.json records it), and its DuckDB cell read every
    ``gen-*.parquet`` on disk: a generation being written, or a stray copy, counted twice
    (probe G2). The cells' own code, run in this process."""
    import numpy as np

    copy = tmp_path / "copy"
    shutil.copytree(tiny_run, copy)
    evaluations = copy / "evaluations"
    shutil.copy(evaluations / "gen-000002.parquet", evaluations / "gen-000003.parquet")
    info = json.loads((copy / "run.json").read_text())
    info["config"]["task"]["fitness"] = "not_installed_here"
    (copy / "run.json").write_text(json.dumps(info))
    notebook = nbformat.read(ANALYSIS / "fitness_and_diversity.ipynb", as_version=4)
    first = next(c for c in notebook.cells if c.cell_type == "code")
    monkeypatch.setenv("ARIEL_RUN_DIR", str(copy))
    monkeypatch.syspath_prepend(str(ANALYSIS))
    cells: dict = {"display": lambda shown: None, "np": np}
    exec(first.source, cells)
    assert cells["MAXIMISE"] is True and cells["FITNESS"] == "not_installed_here"
    run = load_run(copy)
    ok = run.evaluations[
        (run.evaluations["status"] == "ok") & np.isfinite(run.evaluations["fitness"])
    ]
    cells["ok"] = ok
    exec(_cell_with(notebook, "duckdb.sql(").source, cells)
    counts = cells["per_generation"].set_index("generation")["evaluations"]
    assert counts.to_dict() == ok.groupby("generation").size().to_dict()
