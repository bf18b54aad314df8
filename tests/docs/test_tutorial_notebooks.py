"""The two ARIEL tutorials as notebooks of the docs site (docs/tutorials/).

Their code cells must be the tutorials' code cells exactly, as tests/test_tutorials.py
extracts them from the tutorial texts (which live outside the repository; that check is
skipped without them). The stored notebooks hold no outputs: the docs build executes them
(mkdocs-jupyter), so they are not executed here.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.test_tutorials import BASIC, QUICKSTART, extract_code_cells

nbformat = pytest.importorskip(
    "nbformat", reason="nbformat comes with the docs or analysis extra (pip install -e '.[docs]')"
)

TUTORIALS = Path(__file__).resolve().parents[2] / "docs" / "tutorials"
# notebook name -> the tutorial text its code cells come from
NOTEBOOKS = {
    "quickstart-modular-robots": QUICKSTART,
    "basic-api-nde-cpg": BASIC,
}


def _read(name: str):
    path = TUTORIALS / f"{name}.ipynb"
    assert path.is_file(), f"missing notebook {path}"
    return nbformat.read(path, as_version=nbformat.NO_CONVERT)


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_is_valid_and_stored_without_outputs(name: str) -> None:
    nb = _read(name)
    assert nb.nbformat == 4
    nbformat.validate(nb)
    assert nb.metadata.kernelspec.name == "python3"
    for index, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [], f"{name}: cell {index} has stored outputs"
            assert cell.execution_count is None, f"{name}: cell {index} has an execution count"


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_code_cells_are_the_tutorials(name: str) -> None:
    text_path = NOTEBOOKS[name]
    if not text_path.is_file():
        pytest.skip(f"tutorial text not found at {text_path} (it lives outside the repository)")
    expected = extract_code_cells(text_path.read_text(encoding="utf-8"))
    actual = [cell.source for cell in _read(name).cells if cell.cell_type == "code"]
    for index, (got, want) in enumerate(zip(actual, expected, strict=False)):
        assert got == want, f"{name}: code cell {index} differs from the tutorial's"
    assert len(actual) == len(expected), (
        f"{name}: {len(actual)} code cells, the tutorial has {len(expected)}"
    )


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_first_cell_is_an_h1_title(name: str) -> None:
    first = _read(name).cells[0]
    assert first.cell_type == "markdown", f"{name}: the first cell is not Markdown"
    lines = [line for line in first.source.splitlines() if line.strip()]
    assert lines and lines[0].startswith("# "), f"{name}: the first cell has no H1 title"


def test_the_docs_build_s_kernels_draw_the_tutorials_figures_inline() -> None:
    """`make docs` ran the notebooks with MPLBACKEND=Agg, under which a kernel's
    ``plt.show()`` draws nothing: the quick-start tutorial's trajectory plot was missing from
    the site. A cell like the tutorial's, run with the build's environment, shows a PNG."""
    import os
    import re

    nbclient = pytest.importorskip("nbclient", reason="nbclient comes with the docs extra")
    makefile = (Path(__file__).resolve().parents[2] / "Makefile").read_text()
    line = re.search(r"^DOCS_ENV := (.*)$", makefile, re.MULTILINE)
    assert line is not None
    given = dict(word.split("=", 1) for word in line.group(1).split() if "=" in word)
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"} | given
    cell = "import matplotlib.pyplot as plt\nplt.plot([0, 1], [0, 1])\nplt.show()"
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(cell)])
    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)  # the kernel is started with this process's environment
    try:
        nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3").execute()
    finally:
        os.environ.clear()
        os.environ.update(saved)
    outputs = notebook.cells[0].outputs
    assert any("image/png" in output.get("data", {}) for output in outputs), outputs
