"""The two ARIEL tutorials are the API contract: every code cell must run as written.

The tutorial texts live outside the repository (``<repo>/../shared/reference``). Their code
cells are extracted here, run in order in one namespace per tutorial (in a fresh Python
process, with the Agg matplotlib backend so ``plt.show()`` is a no-op), and what they print
is checked against the numbers the tutorials promise.
"""

from __future__ import annotations

import ast
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REFERENCE_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "reference"
BASIC = REFERENCE_DIR / "tutorial-basic-api-nde-cpg.txt"
QUICKSTART = REFERENCE_DIR / "tutorial-quickstart-modular-robots.txt"

# A cell starts after a prompt line such as "[1]:" or "[ ]:"; a heading ends with a pilcrow.
_PROMPT = re.compile(r"^\[\s*\d*\s*\]:\s*$")
_HEADING_MARK = "¶"


def _parses(code: str) -> bool:
    try:
        ast.parse(code)
    except SyntaxError:
        return False
    return True


def extract_code_cells(text: str) -> list[str]:
    """Return the code cells of a tutorial text, in order.

    A cell runs from a prompt line (``[1]:`` / ``[ ]:``) to the next prompt or heading line
    (one ending in ``¶``). Prose can follow the code before the next heading, so the cell is
    the longest prefix of that block that parses as Python; trailing prose is dropped. Some
    exports indent the code: then the cell also ends at the first less-indented line, and the
    first line's indentation is removed from every line.
    """
    lines = text.splitlines()
    cells: list[str] = []
    i = 0
    while i < len(lines):
        if not _PROMPT.match(lines[i].strip()):
            i += 1
            continue
        i += 1
        block: list[str] = []
        indent: int | None = None  # indentation of the cell's first code line
        while (
            i < len(lines)
            and not _PROMPT.match(lines[i].strip())
            and not lines[i].rstrip().endswith(_HEADING_MARK)
        ):
            line = lines[i]
            if line.strip():
                width = len(line) - len(line.lstrip(" "))
                if indent is None:
                    indent = width
                elif width < indent:
                    break  # an indented cell ends at the first less-indented (prose) line
            block.append(line)
            i += 1
        code = _longest_parsing_prefix([line[indent or 0 :] for line in block])
        if code is None:
            raise ValueError(f"no parsable code after prompt near line {i}: {block[:3]!r}")
        cells.append(code)
    return cells


def _longest_parsing_prefix(block: list[str]) -> str | None:
    for end in range(len(block), 0, -1):
        if not block[end - 1].strip():
            continue
        code = "\n".join(block[:end]).strip("\n") + "\n"
        if _parses(code):
            return code
    return None


# --- the extractor itself ---------------------------------------------------------------------


def test_extractor_on_synthetic_text() -> None:
    text = "\n".join(
        [
            "Title¶",
            "Some prose.",
            "[1]:",
            "x = (",
            "1,",
            ")",
            "2. Next heading¶",
            "[ ]:",
            "    def f():",
            '        """Doc.',
            "",
            "        More doc.",
            '        """',
            "        return 2",
            "",
            "",
            "    y = f()",
            "",
            "The resulting y is two, as you can see.",
            "",
            "[ ]:",
            "# only a comment",
            "Summary¶",
        ]
    )
    cells = extract_code_cells(text)
    assert len(cells) == 3
    assert cells[0] == "x = (\n1,\n)\n"
    assert cells[1].startswith("def f():") and cells[1].rstrip().endswith("y = f()")
    assert "resulting" not in cells[1]
    assert cells[2] == "# only a comment\n"
    namespace: dict = {}
    exec(cells[0] + cells[1], namespace)
    assert namespace["x"] == (1,) and namespace["y"] == 2


def test_extractor_on_indented_cells() -> None:
    text = "\n".join(
        [
            "[ ]:",
            "    import math",
            "",
            "    def g(x):",
            "        return math.sqrt(x)",
            "",
            "",
            "    z = g(4.0)",
            "The result is printed below",
            "[ ]:",
            "    print(z)",
        ]
    )
    cells = extract_code_cells(text)
    assert cells == [
        "import math\n\ndef g(x):\n    return math.sqrt(x)\n\n\nz = g(4.0)\n",
        "print(z)\n",
    ]


def _read(path: Path) -> str:
    if not path.is_file():
        pytest.skip(f"tutorial text not found at {path} (it lives outside the repository)")
    return path.read_text(encoding="utf-8")


def test_extractor_finds_every_tutorial_cell() -> None:
    basic = extract_code_cells(_read(BASIC))
    quick = extract_code_cells(_read(QUICKSTART))
    # Counted by hand: basic [1]..[6]; quick-start: imports, 2a, 2b, 2c, 3, 4a, 4b, 5a, 5b,
    # 5c (viewer, commented out), 6 (plot), 7 (fitness), 8 (evaluate).
    assert len(basic) == 6
    assert len(quick) == 13
    assert basic[0].startswith("import mujoco") and "Tracker" in basic[0]
    assert basic[-1].startswith("simple_runner(model, data, duration=15)")
    assert "displacement = np.linalg.norm" in basic[-1]
    assert quick[0].startswith("# Standard library")
    assert quick[3].rstrip().endswith('print(f"Robot body type: {type(random_robot)}")')
    assert all(line.startswith("#") for line in quick[9].splitlines() if line.strip())
    assert quick[10].rstrip().endswith('plot_trajectory(tracker.history["xpos"][0])')
    assert quick[12].rstrip().endswith('print(f"Displacement: {score:.4f} m")')


# --- running the tutorials ----------------------------------------------------------------------

_DRIVER = r"""
import json, math, sys
import matplotlib
matplotlib.use("Agg")  # plt.show() becomes a no-op
import matplotlib.pyplot as plt

cells = json.load(sys.stdin)
namespace = {"__name__": "__tutorial__"}
for index, code in enumerate(cells):
    print(f"@@cell {index}", flush=True)
    exec(compile(code, f"<tutorial cell {index}>", "exec"), namespace)

summary = {"figures": len(plt.get_fignums())}
for name in ("displacement", "fitness", "score"):
    if name in namespace:
        summary[name] = float(namespace[name])
if "p_matrices" in namespace:
    summary["p_shapes"] = [list(m.shape) for m in namespace["p_matrices"]]
if "robot_graph" in namespace:
    graph = namespace["robot_graph"]
    summary["graph"] = [graph.number_of_nodes(), graph.number_of_edges()]
if "model" in namespace:
    summary["nu"], summary["nv"] = int(namespace["model"].nu), int(namespace["model"].nv)
if "tracker" in namespace:
    summary["snapshots"] = len(namespace["tracker"].history["xpos"][0])
if "cpg" in namespace:
    summary["cpg"] = [int(namespace["cpg"].n), int(namespace["cpg"].num_of_parameters)]
if "data" in namespace:
    summary["time"] = float(namespace["data"].time)
print("@@summary " + json.dumps(summary), flush=True)
"""


def _run_tutorial(path: Path, tmp_path: Path) -> tuple[list[str], dict]:
    cells = extract_code_cells(_read(path))
    env = dict(os.environ, MPLBACKEND="Agg")
    if sys.platform == "linux":
        env.setdefault("MUJOCO_GL", "egl")
    result = subprocess.run(
        [sys.executable, "-c", _DRIVER],
        input=json.dumps(cells),
        capture_output=True,
        text=True,
        cwd=tmp_path,  # anything a cell writes lands in a temporary folder
        env=env,
        timeout=300,
    )
    outputs = result.stdout.split("@@cell ")[1:]
    if result.returncode != 0:
        failed = len(outputs) - 1
        pytest.fail(
            f"{path.name}: cell {failed} failed:\n{cells[failed] if failed >= 0 else ''}\n"
            f"--- stderr ---\n{result.stderr[-4000:]}"
        )
    *cell_outputs, last = outputs
    last_output, summary_line = last.split("@@summary ")
    per_cell = [
        out.split("\n", 1)[1] if "\n" in out else "" for out in [*cell_outputs, last_output]
    ]
    assert len(per_cell) == len(cells)
    return per_cell, json.loads(summary_line)


def _number(pattern: str, text: str) -> float:
    match = re.search(pattern, text)
    assert match, f"{pattern!r} not found in {text!r}"
    value = float(match.group(1))
    assert math.isfinite(value)
    return value


@pytest.mark.slow
def test_basic_tutorial_runs(tmp_path: Path) -> None:
    outputs, summary = _run_tutorial(BASIC, tmp_path)
    assert not "".join(outputs).strip()  # the basic tutorial prints nothing
    assert summary["p_shapes"] == [[20, 4], [20, 20, 6], [20, 3]]
    nodes, edges = summary["graph"]
    assert nodes >= 1 and edges == nodes - 1  # a tree rooted at the core
    assert summary["nv"] >= 6  # a free joint plus one per hinge
    assert summary["cpg"] == [summary["nu"], 5 * summary["nu"]]
    assert summary["time"] == pytest.approx(15.0, abs=1e-6)
    assert summary["snapshots"] == 15
    assert math.isfinite(summary["displacement"]) and summary["displacement"] >= 0


@pytest.mark.slow
def test_quickstart_tutorial_runs(tmp_path: Path) -> None:
    outputs, summary = _run_tutorial(QUICKSTART, tmp_path)
    out = dict(enumerate(outputs))
    assert out[0] == ""  # imports
    assert "CoreModule" in out[1]  # print(type(gecko_body))
    assert out[2].strip() == "Custom robot assembled."
    assert "Probability matrix shapes: [(20, 4), (20, 20, 6), (20, 3)]" in out[3]
    nodes = _number(r"Robot graph: (\d+) nodes", out[3])
    assert _number(r"nodes, (\d+) edges", out[3]) == nodes - 1
    assert re.search(r"Robot body type: <class '[\w.]*CoreModule'>", out[3])
    assert "Number of actuators (joints): 8\n" in out[4]
    assert "Number of degrees of freedom: 14\n" in out[4]
    assert "CPG nodes (= actuators): 8\n" in out[5]
    assert "Total learnable parameters: 40\n" in out[5]
    assert out[6].strip() == "Controller registered."
    assert "Simulation finished at t = 15.00 s" in out[7]
    assert re.search(r"Final core position: \[\s*[-\d.e+]+\s+[-\d.e+]+\s+[-\d.e+]+\s*\]", out[7])
    assert "Recorded 15 position snapshots." in out[7]
    assert out[8].strip() == "Recorded 15 position snapshots."
    assert out[9] == "" and out[10] == ""  # viewer (commented out) and the plot
    assert summary["figures"] == 1  # the trajectory plot was drawn
    fitness = _number(r"Fitness \(displacement\): ([-\d.]+) m", out[11])
    assert fitness >= 0 and fitness == pytest.approx(summary["fitness"], abs=1e-4)
    score = _number(r"Displacement: ([-\d.]+) m", out[12])
    assert score >= 0 and score == pytest.approx(summary["score"], abs=1e-4)
