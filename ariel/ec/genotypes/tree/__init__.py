"""Tree genomes: a body as a tree of modules (`TreeGenome`), GP operators on it
(`ariel.ec.genotypes.tree.operators`), checks (`...tree.validation`) and the ``tree`` body
encoder (`...tree.encoder`)."""

from ariel.ec.genotypes.tree.tree_genome import TreeGenome

__all__ = ["TreeGenome"]
