"""Prebuilt robot bodies, and registries of them by name.

``PREBUILT_ROBOTS`` maps a name to a factory returning a fresh ``CoreModule``;
``PREBUILT_GRAPHS`` maps a name to a factory returning the same body as a robot graph (only
for bodies that have one). Both import the body's module on first call, so importing this
package stays cheap.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import networkx as nx

    from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule

__all__ = ["PREBUILT_GRAPHS", "PREBUILT_ROBOTS"]


def _lazy(module: str, attr: str, name: str) -> Callable[[], Any]:
    def factory() -> Any:
        return getattr(importlib.import_module(f"{__name__}.{module}"), attr)()

    factory.__name__ = attr
    factory.__qualname__ = attr
    factory.__doc__ = f"Build the prebuilt body {name!r} ({module}.{attr}())."
    return factory


PREBUILT_ROBOTS: dict[str, Callable[[], CoreModule]] = {
    "gecko": _lazy("gecko", "gecko", "gecko"),
    "spider": _lazy("spider", "spider", "spider"),
    "spider_with_blocks": _lazy("spider_with_blocks", "body_spider", "spider_with_blocks"),
    "spider45": _lazy("spider_with_blocks", "body_spider45", "spider45"),
    "random_spider20": _lazy("random_20", "random_spider20", "random_spider20"),
    "baby_a": _lazy("john_set", "baby_a", "baby_a"),
    "baby_b": _lazy("john_set", "baby_b", "baby_b"),
}

PREBUILT_GRAPHS: dict[str, Callable[[], nx.DiGraph]] = {
    "gecko": _lazy("gecko", "gecko_graph", "gecko"),
    "spider": _lazy("spider", "spider_graph", "spider"),
}
