"""Load and save tree genomes as JSON (upstream's ``tree.io`` helpers)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ariel.ec.genotypes.tree.tree_genome import TreeGenome

__all__ = ["genome_to_networkx_dict", "load_genome", "save_genome"]


def load_genome(path: str | Path) -> TreeGenome:
    """The genome in a JSON file written by `save_genome` (or ``TreeGenome.save_json``)."""
    return TreeGenome.load_json(path)


def save_genome(genome: TreeGenome, path: str | Path) -> None:
    """Write ``genome`` as JSON (``genome.to_dict()``)."""
    genome.save_json(path)


def genome_to_networkx_dict(genome: TreeGenome) -> dict[str, Any]:
    """The genome's plain dict form (``genome.to_dict()``), as upstream."""
    return genome.to_dict()
