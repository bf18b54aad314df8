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
