"""Upstream ARIEL's earlier home of `Crossover` (``from ariel.ec.a005 import Crossover``)."""

from ariel.ec.crossover import Crossover

__all__ = ["Crossover"]
