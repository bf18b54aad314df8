"""Packages meet at their faces: no module of `ariel` imports another package's private module
(``ariel.evaluation._engine``) or private name (``_helper``).

A package's ``__init__`` names what the others may use (`ariel.utils.lazy.lazy_face` loads it on
first use), so a package can rearrange its private modules without breaking another. Inside one
package (the folder a module sits in) private modules import each other freely. `make lint`
runs this test beside import-linter, which cannot express the rule.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ARIEL = ROOT / "ariel"


def _private(part: str) -> bool:
    return part.startswith("_") and not part.startswith("__")


def _package_of(module: str) -> str:
    """The package a dotted module path belongs to: the part before its first private name,
    or, for a public path, the package itself or the folder holding the module."""
    parts = module.split(".")
    for i, part in enumerate(parts):
        if _private(part):
            return ".".join(parts[:i])
    if (ROOT.joinpath(*parts) / "__init__.py").is_file():
        return module
    return ".".join(parts[:-1])


def private_imports(path: Path, source: str | None = None) -> list[str]:
    """``line: import`` for each import in ``path`` (or in ``source``, as if it were the text of
    ``path``) that reaches into another package."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    own = ".".join(parts[:-1])  # a package's __init__ belongs to the package itself
    found = []
    text = path.read_text(encoding="utf-8") if source is None else source
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            targets = [(node.module, [alias.name for alias in node.names])]
        elif isinstance(node, ast.Import):
            targets = [(alias.name, []) for alias in node.names]
        else:
            continue
        for module, names in targets:
            if module.split(".")[0] != "ariel" or _package_of(module) == own:
                continue
            where = f"{path.relative_to(ROOT)}:{node.lineno}"
            if any(_private(part) for part in module.split(".")):
                found.append(f"{where}: {module}")
            found += [f"{where}: {module}.{name}" for name in names if _private(name)]
    return found


def test_no_package_imports_another_packages_private_modules_or_names() -> None:
    found = [hit for path in sorted(ARIEL.rglob("*.py")) for hit in private_imports(path)]
    assert not found, "import from the package's face instead:\n" + "\n".join(found)


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("from ariel.evaluation._engine import build\n", ["ariel.evaluation._engine"]),
        ("from ariel.evaluation import _plugin\n", ["ariel.evaluation._plugin"]),
        ("import ariel.recording.store._files\n", ["ariel.recording.store._files"]),
        ("from ariel.evaluation import build\n", []),
        ("from ariel.runs._prepare import x\n", []),  # its own package
        ("from ariel.__init__ import __version__\n", []),
    ],
)
def test_the_rule_finds_what_it_should(source: str, expected: list[str]) -> None:
    """The check itself, on a module of `ariel.runs` importing other packages' parts."""
    hits = private_imports(ARIEL / "runs" / "_probe.py", source)
    assert [hit.split(": ", 1)[1] for hit in hits] == expected


def test_dir_of_ariel_lists_its_lazy_names() -> None:
    """Tab completion in a notebook (``ariel.<Tab>``) missed run_experiment and console."""
    import ariel

    assert {"run_experiment", "console", "__version__"} <= set(dir(ariel))
