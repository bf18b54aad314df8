"""Upstream ARIEL's earlier home of the generators and mutators (``from ariel.ec.a000 import``)."""

from ariel.ec._mutators import FloatMutator, IntegerMutator
from ariel.ec.generators import FloatsGenerator, IntegersGenerator

__all__ = ["FloatMutator", "FloatsGenerator", "IntegerMutator", "IntegersGenerator"]
