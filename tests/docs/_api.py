"""The public API as the docs site documents it: the rule lives with the site's generator
(docs/_hooks/api_pages.py), loaded here by path so the tests and the site cannot disagree."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

_SOURCE = Path(__file__).resolve().parents[2] / "docs" / "_hooks" / "api_pages.py"


def _api_pages() -> ModuleType:
    spec = importlib.util.spec_from_file_location("_ariel_docs_api_pages", _SOURCE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def public_modules() -> list[ModuleType]:
    """`ariel` and its public submodules that define ``__all__``, in dotted-name order."""
    return _api_pages().public_modules()
