"""The layering of the package holds (import-linter, [tool.importlinter] in pyproject.toml):
each package imports only the packages below it, and no modules import each other in a circle.
`make lint` runs the same check; this test makes `make test` see a broken layer too."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = (
    "import sys\n"
    "from importlinter.cli import lint_imports\n"
    "sys.exit(lint_imports(no_cache=True, no_logo=True))\n"
)


def test_every_import_linter_contract_is_kept() -> None:
    pytest.importorskip("importlinter", reason="import-linter is in the dev extra")
    # lint-imports analyses the `ariel` found from the current directory: this checkout's.
    result = subprocess.run(
        [sys.executable, "-c", LINT], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    for contract in ("Layers: each package", "No import cycles between sibling"):
        assert re.search(rf"^{contract}.* KEPT\b", result.stdout, re.MULTILINE), contract
