"""The brick module: a passive 0.1 m blue cube with five attachment sites (no BACK)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleType
from ariel.body_phenotypes.robogen_lite.modules.module import Module, rgba

__all__ = [
    "BRICK_COLOUR",
    "BRICK_GEOM_POS",
    "BRICK_HALF_EXTENTS",
    "BRICK_MASS",
    "BRICK_SITES",
    "BrickModule",
]

_S = math.sqrt(0.5)

BRICK_MASS = 0.055
BRICK_HALF_EXTENTS = (0.05, 0.05, 0.05)  # half-extents: a 0.1 m cube
BRICK_GEOM_POS = (0.0, 0.05, 0.0)
BRICK_COLOUR = rgba(28, 119, 195)  # blue

# face -> (site name, position, quaternion (w, x, y, z)); BACK is where the brick is attached.
BRICK_SITES: dict[ModuleFaces, tuple[str, tuple[float, ...], tuple[float, ...]]] = {
    ModuleFaces.FRONT: ("brick-front", (0.0, 0.1, 0.0), (1.0, 0.0, 0.0, 0.0)),
    ModuleFaces.RIGHT: ("brick-right", (0.05, 0.05, 0.0), (-_S, 0.0, 0.0, _S)),
    ModuleFaces.LEFT: ("brick-left", (-0.05, 0.05, 0.0), (_S, 0.0, 0.0, _S)),
    ModuleFaces.TOP: ("brick-top", (0.0, 0.05, 0.05), (_S, _S, 0.0, 0.0)),
    ModuleFaces.BOTTOM: ("brick-bottom", (0.0, 0.05, -0.05), (0.0, 0.0, -_S, _S)),
}


class BrickModule(Module):
    """A brick: body and geom "brick", sites FRONT, RIGHT, LEFT, TOP, BOTTOM."""

    module_type = ModuleType.BRICK

    def _build(self, body: mujoco.MjsBody) -> Sequence[tuple[ModuleFaces, mujoco.MjsSite]]:
        body.add_geom(
            name="brick",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=BRICK_HALF_EXTENTS,
            pos=BRICK_GEOM_POS,
            mass=BRICK_MASS,
            rgba=BRICK_COLOUR,
        )
        sites = [
            (face, body.add_site(name=name, pos=pos, quat=quat))
            for face, (name, pos, quat) in BRICK_SITES.items()
        ]
        self.rotate(0)
        return sites
