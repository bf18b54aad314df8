"""`ModuleInstance`, apart from `config` because pydantic is slow to import: `config` loads
this module on first access to the name."""

from __future__ import annotations

from pydantic import BaseModel

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleRotationsIdx, ModuleType

__all__ = ["ModuleInstance"]


class ModuleInstance(BaseModel):
    """One module of a genotype: its type, rotation and children.

    Attributes:
        type: The module's type (core, brick, hinge or none).
        rotation: Its rotation about the face it is attached by.
        links: Its children: ``{face: child id}``.
    """

    type: ModuleType
    rotation: ModuleRotationsIdx
    links: dict[ModuleFaces, int]


ModuleInstance.__module__ = "ariel.body_phenotypes.robogen_lite.config"  # where users import it
