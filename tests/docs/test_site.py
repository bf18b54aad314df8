"""The docs site builds with warnings as errors, lists every public name, and fails on a
broken link. Built here without running notebooks (``make docs`` runs them; CI does both)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from tests.docs._api import public_modules

pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install -e .[docs])")

ROOT = Path(__file__).resolve().parents[2]


def _build(root: Path, site: Path, *, api: bool) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "ARIEL_DOCS_EXECUTE": "0",
        "ARIEL_DOCS_API": "1" if api else "0",
        "NO_MKDOCS_2_WARNING": "1",
    }
    command = [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(site)]
    return subprocess.run(command, cwd=root, env=env, capture_output=True, text=True, check=False)


def _inventory(site: Path) -> set[str]:
    """The object names in mkdocstrings' Sphinx inventory (objects.inv)."""
    header, _, compressed = (
        (site / "objects.inv")
        .read_bytes()
        .partition(b"# The remainder of this file is compressed using zlib.\n")
    )
    assert header.startswith(b"# Sphinx inventory version 2")
    return {line.split(" ", 1)[0] for line in zlib.decompress(compressed).decode().splitlines()}


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    built = _build(ROOT, out, api=True)
    assert built.returncode == 0, built.stdout + built.stderr
    return out


def test_the_api_reference_lists_every_name_in_every_public_all(site: Path) -> None:
    inventory = _inventory(site)
    missing = [
        f"{module.__name__}.{name}"
        for module in public_modules()
        for name in module.__all__
        if f"{module.__name__}.{name}" not in inventory
    ]
    assert not missing, f"public names missing from the API reference: {missing}"
    assert (site / "reference" / "ariel.runs" / "index.html").is_file()


def test_the_cli_reference_and_the_readme_page_are_in_the_site(site: Path) -> None:
    from ariel.cli import build_parser

    cli = (site / "cli" / "index.html").read_text(encoding="utf-8")
    for option in ("--executor", "--set", "--overwrite"):
        assert option in cli
    commands = [a for a in build_parser()._actions if a.dest == "command"]
    assert commands, "the parser has no command list"
    for name in commands[0].choices:
        assert f"ariel {name}" in cli, f"`ariel {name}` is not in the CLI reference"
    index = (site / "index.html").read_text(encoding="utf-8")
    assert "Two commands" in index and 'href="records/' in index


def _copy_sources(into: Path) -> Path:
    into.mkdir()
    for name in ("mkdocs.yml", "README.md"):
        shutil.copy2(ROOT / name, into / name)
    shutil.copytree(ROOT / "docs", into / "docs", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "analysis", into / "analysis", ignore=shutil.ignore_patterns(".*"))
    return into


def test_a_broken_link_fails_the_build(site: Path, tmp_path: Path) -> None:
    # The same sources build (the `site` fixture); a copy with one broken link does not.
    root = _copy_sources(tmp_path / "copy")
    page = root / "docs" / "records.md"
    page.write_text(page.read_text(encoding="utf-8") + "\n[gone](no-such-page.md)\n")
    broken = _build(root, tmp_path / "broken", api=False)
    assert broken.returncode != 0
    assert "'no-such-page.md'" in broken.stdout + broken.stderr
    assert "Aborted with 1 warnings in strict mode" in broken.stdout + broken.stderr
