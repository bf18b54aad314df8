"""Upstream ARIEL's earlier home of `Population` (``from ariel.ec.a003 import Population``)."""

from ariel.ec.individual import Individual
from ariel.ec.population import Population

__all__ = ["Individual", "Population"]
