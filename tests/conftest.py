"""Shared pytest set-up.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so the headless backend is
chosen here, before any test module imports it. A value set by the user (or ``make test``) wins.
"""

import os
import sys

if sys.platform == "linux":
    os.environ.setdefault("MUJOCO_GL", "egl")


# --- fake installed distributions (plugin entry points) ----------------------------------------

import importlib
import textwrap
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import pytest


@pytest.fixture
def fake_distribution(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[Callable[..., Path]]:
    """Factory that "installs" a throwaway distribution for the length of one test.

    ``fake_distribution(name, version, source=..., entry_points={group: {ep_name: "mod:attr"}})``
    writes ``<root>/<name>/__init__.py`` (from ``source``) and ``<root>/<name>-<version>.dist-info``
    (METADATA and entry_points.txt), puts ``<root>`` first on ``sys.path`` and refreshes the
    plugin registries, so ``importlib.metadata`` and the registries see it like an installed
    package. Afterwards its modules are forgotten and the registries refreshed again.
    """
    from ariel.plugins import refresh_all

    packages: list[str] = []

    def make(
        name: str = "ariel_test_plugin_pkg",
        version: str = "0.1",
        *,
        source: str = "",
        entry_points: Mapping[str, Mapping[str, str]] | None = None,
    ) -> Path:
        root = tmp_path / f"site-{len(packages)}-{name}"
        package = root / name
        package.mkdir(parents=True)
        (package / "__init__.py").write_text(textwrap.dedent(source))
        info = root / f"{name}-{version}.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
        lines = []
        for group, declared in (entry_points or {}).items():
            lines.append(f"[{group}]")
            lines.extend(f"{ep_name} = {value}" for ep_name, value in declared.items())
            lines.append("")
        (info / "entry_points.txt").write_text("\n".join(lines))
        monkeypatch.syspath_prepend(str(root))
        packages.append(name)
        refresh_all()
        return root

    yield make

    for name in packages:
        for module in [m for m in sys.modules if m == name or m.startswith(f"{name}.")]:
            del sys.modules[module]
    # Only caches are dropped here; the next lookup (after sys.path is restored) rediscovers.
    refresh_all()
    importlib.invalidate_caches()


@pytest.fixture(autouse=True)
def _no_global_control_callback() -> Iterator[None]:
    """Every test starts and ends without a global ``mjcb_control`` (it is process-wide)."""
    import mujoco

    mujoco.set_mjcb_control(None)
    yield
    mujoco.set_mjcb_control(None)
