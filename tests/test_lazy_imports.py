"""Imports inside functions are the exception, and each says why.

An import belongs at the top of its module. One stays inside a function only for a reason
written beside it: a comment containing ``lazy:`` on the import's first line or in the comment
lines directly above it (a heavy optional library such as rerun, matplotlib, torch, warp or
dask; mujoco where a GL backend must be chosen first; a slow import a light path must not pay).
Their number may not grow: `CEILING` is the count when this guard came, and it only comes down.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ARIEL = Path(__file__).resolve().parents[1] / "ariel"
#: Function-level imports in `ariel/` now (516 before the house was split up); lower it as they go.
CEILING = 53


def _function_imports(text: str) -> list[ast.Import | ast.ImportFrom]:
    tree = ast.parse(text)
    found: dict[int, ast.Import | ast.ImportFrom] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for inner in ast.walk(node):
                if isinstance(inner, ast.Import | ast.ImportFrom):
                    found[id(inner)] = inner  # nested functions are walked more than once
    return list(found.values())


def _has_reason(lines: list[str], node: ast.stmt) -> bool:
    if "lazy:" in lines[node.lineno - 1]:
        return True
    above = node.lineno - 2
    while above >= 0 and lines[above].strip().startswith("#"):
        if "lazy:" in lines[above]:
            return True
        above -= 1
    return False


def _unexplained(text: str) -> list[int]:
    lines = text.splitlines()
    return [n.lineno for n in _function_imports(text) if not _has_reason(lines, n)]


def test_every_function_level_import_says_why_and_their_number_does_not_grow() -> None:
    total, missing = 0, []
    for path in sorted(ARIEL.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        total += len(_function_imports(text))
        missing += [f"{path.relative_to(ARIEL)}:{line}" for line in _unexplained(text)]
    assert not missing, f"imports inside functions without a `lazy:` reason: {missing}"
    assert total <= CEILING, f"{total} function-level imports, at most {CEILING}: hoist them"


@pytest.mark.parametrize(
    ("source", "unexplained"),
    [
        ("def f():\n    import json\n", [2]),
        ("def f():\n    import rerun  # lazy: heavy optional library\n", []),
        ("def f():\n    # lazy: loads mujoco\n    # (GL first)\n    import mujoco\n", []),
        ("def f():\n    x = 1  # lazy: not a comment line\n    import mujoco\n", [3]),
        ("import json\n\ndef f():\n    return json\n", []),
        ("def f():\n    def g():\n        import json\n", [3]),
    ],
)
def test_the_rule_finds_an_unexplained_import(source: str, unexplained: list[int]) -> None:
    assert _unexplained(source) == unexplained
