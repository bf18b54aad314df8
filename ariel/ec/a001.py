"""Upstream ARIEL's earlier home of `Individual` (``from ariel.ec.a001 import Individual``).

Upstream's module also created ``./__data__`` on import; this one creates nothing.
"""

from ariel.ec.individual import Individual, JSONIterable, JSONPrimitive, JSONType

__all__ = ["Individual", "JSONIterable", "JSONPrimitive", "JSONType"]
