"""The API reference: one page per public module, listing exactly the names in its ``__all__``.

A public module is `ariel` or one whose dotted path has no part starting with an underscore;
`ariel.cli` is left to the CLI reference (cli.md). The tests use this same rule
(tests/docs/_api.py) to check that the built site lists every public name.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

EXCLUDED = ("ariel.cli",)


def public_modules() -> list[ModuleType]:
    """`ariel` and its public submodules that define ``__all__``, in dotted-name order."""
    import ariel

    names = ["ariel"]
    for info in pkgutil.walk_packages(ariel.__path__, "ariel."):
        parts = info.name.split(".")
        if any(part.startswith("_") for part in parts[1:]):
            continue
        if any(info.name == e or info.name.startswith(e + ".") for e in EXCLUDED):
            continue
        names.append(info.name)
    modules = [importlib.import_module(name) for name in sorted(names)]
    return [module for module in modules if hasattr(module, "__all__")]


def page_path(module: str) -> str:
    """Where a module's page lives in the site's sources, e.g. ``reference/ariel.runs.md``."""
    return f"reference/{module}.md"


def page(module: ModuleType) -> str:
    """The Markdown of one module's page: its docstring, then each ``__all__`` name in order."""
    members = "\n".join(f"        - {name}" for name in module.__all__)
    return (
        f"::: {module.__name__}\n"
        "    options:\n"
        "      show_root_heading: true\n"  # the page's title, and the module in objects.inv
        "      heading_level: 1\n"
        "      members:\n"
        f"{members}\n"
    )


def index(modules: list[ModuleType]) -> str:
    """The reference's entry page: every public module, its first docstring line, a link."""
    lines = [
        "# API reference",
        "",
        "Every public module of the `ariel` package and every name in its `__all__`, built from",
        "the docstrings (Google style: arguments, returns, raised errors and examples). Names",
        "that start with an underscore are internal and may change without notice.",
        "",
        "| Module | What it holds |",
        "| --- | --- |",
    ]
    for module in modules:
        summary = (module.__doc__ or "").strip().splitlines()
        first = summary[0].replace("|", "\\|") if summary else ""
        lines.append(f"| [`{module.__name__}`]({module.__name__}.md) | {first} |")
    return "\n".join(lines) + "\n"


def nav(modules: list[ModuleType]) -> list:
    """The reference's part of the site's navigation, grouped by top-level package."""
    groups: dict[str, list] = {}
    for module in modules:
        parts = module.__name__.split(".")
        group = "ariel" if len(parts) == 1 else f"ariel.{parts[1]}"
        groups.setdefault(group, []).append({module.__name__: page_path(module.__name__)})
    entries: list = [{"Overview": "reference/index.md"}]
    for group, pages in groups.items():
        entries.append(pages[0] if len(pages) == 1 else {group: pages})
    return entries
