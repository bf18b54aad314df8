"""The loop stays in small parts: no module of the evolution layer (the optimizers, the
scheduler, the driver, bodies, state), of `ariel.runs` (its entry points), the records writer
or its row declarations over 400 lines, and no function in them over 60."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ARIEL = Path(__file__).resolve().parents[2] / "ariel"
MODULES = sorted(
    [
        *ARIEL.glob("evolution/*.py"),
        *ARIEL.glob("runs/*.py"),
        ARIEL / "recording" / "_rows.py",
        ARIEL / "recording" / "_row_types.py",
    ]
)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ARIEL)))
def test_small_modules_and_functions(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 400, f"{path.name}: {len(text.splitlines())} lines"
    long = [
        f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(ast.parse(text))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno - node.lineno + 1 > 60
    ]
    assert not long, f"{path.name}: functions over 60 lines: {long}"
