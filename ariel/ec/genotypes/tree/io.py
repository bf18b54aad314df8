"""Load and save tree genomes as JSON (upstream's ``tree.io`` helpers)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ariel.ec.genotypes.tree.tree_genome import TreeGenome

__all__ = ["genome_to_networkx_dict", "load_genome", "save_genome"]


def load_genome(path: str | Path) -> TreeGenome:
    """The genome in a JSON file written by `save_genome` (or ``TreeGenome.save_json``).

    Args:
        path: the JSON file (UTF-8).

    Returns:
        A new `TreeGenome`.

    Raises:
        ValueError: the file is not valid JSON, or not a genome dict with ``"nodes"``.
    """
    return TreeGenome.load_json(path)


def save_genome(genome: TreeGenome, path: str | Path) -> None:
    """Write ``genome`` as JSON (``genome.to_dict()``).

    Args:
        genome: the genome to save.
        path: the file to write (UTF-8, indented JSON); an existing file is overwritten.
    """
    genome.save_json(path)


def genome_to_networkx_dict(genome: TreeGenome) -> dict[str, Any]:
    """The genome's plain dict form (``genome.to_dict()``), as upstream.

    Args:
        genome: the genome to convert.

    Returns:
        ``{"nodes": {"0": {...}, ...}, "edges": [...]}``, with node ids as string keys.
    """
    return genome.to_dict()
