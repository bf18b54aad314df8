"""The core module: the robot's 0.2 m yellow cube, root of every body tree."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import mujoco

from ariel.body_phenotypes.robogen_lite.config import IDX_OF_CORE, ModuleFaces, ModuleType
from ariel.body_phenotypes.robogen_lite.modules.module import Module, rgba
from ariel.utils import accept_aliases

__all__ = [
    "CORE_CAMERA_POS",
    "CORE_CAMERA_QUAT",
    "CORE_COLOUR",
    "CORE_GEOM_POS",
    "CORE_HALF_EXTENTS",
    "CORE_MASS",
    "CORE_SITES",
    "CoreModule",
]

_S = math.sqrt(0.5)

CORE_MASS = 1.0
CORE_HALF_EXTENTS = (0.1, 0.1, 0.1)  # MuJoCo box sizes are half-extents: a 0.2 m cube
CORE_GEOM_POS = (0.0, 0.1, 0.0)  # the cube spans y in [0, 0.2] of the body frame
CORE_COLOUR = rgba(253, 202, 64)  # yellow
CORE_CAMERA_POS = (0.0, 0.0, 0.08)
CORE_CAMERA_QUAT = (0.0, 0.0, _S, _S)

# face -> (site name, position, quaternion (w, x, y, z)). The site frame's +y is the direction a
# child grows in. The four side sites sit 5 cm below the cube's centre, like upstream.
CORE_SITES: dict[ModuleFaces, tuple[str, tuple[float, ...], tuple[float, ...]]] = {
    ModuleFaces.FRONT: ("core-front", (0.0, 0.2, -0.05), (1.0, 0.0, 0.0, 0.0)),
    ModuleFaces.BACK: ("core-back", (0.0, 0.0, -0.05), (0.0, 0.0, 0.0, 1.0)),
    ModuleFaces.RIGHT: ("core-right", (0.1, 0.1, -0.05), (-_S, 0.0, 0.0, _S)),
    ModuleFaces.LEFT: ("core-left", (-0.1, 0.1, -0.05), (_S, 0.0, 0.0, _S)),
    ModuleFaces.TOP: ("core-top", (0.0, 0.1, 0.1), (_S, _S, 0.0, 0.0)),
    ModuleFaces.BOTTOM: ("core-bottom", (0.0, 0.1, -0.1), (0.0, 0.0, -_S, _S)),
}


class CoreModule(Module):
    """The core: body and geom "core", six sites, a camera "core_mycamera". Index must be 0.

    Args:
        index: The module index (node id in the robot graph); only 0 (``IDX_OF_CORE``) is
            accepted.

    Raises:
        TypeError: If ``index`` is not an int (a bool is refused too).
        ValueError: If ``index`` is not 0.
    """

    module_type = ModuleType.CORE

    def __init__(self, index: int = IDX_OF_CORE) -> None:
        if isinstance(index, bool) or not isinstance(index, numbers.Integral):
            raise TypeError(f"core module index must be an int, got {type(index).__name__}")
        if index != IDX_OF_CORE:
            raise ValueError(f"core module index must be {IDX_OF_CORE}, got {index}")
        super().__init__(index)

    def _build(self, body: mujoco.MjsBody) -> Sequence[tuple[ModuleFaces, mujoco.MjsSite]]:
        body.add_geom(
            name="core",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=CORE_HALF_EXTENTS,
            pos=CORE_GEOM_POS,
            mass=CORE_MASS,
            rgba=CORE_COLOUR,
        )
        body.add_camera(name="core_mycamera", pos=CORE_CAMERA_POS, quat=CORE_CAMERA_QUAT)
        return [
            (face, body.add_site(name=name, pos=pos, quat=quat))
            for face, (name, pos, quat) in CORE_SITES.items()
        ]

    @accept_aliases(angle="degrees")
    def rotate(self, degrees: float) -> None:
        """The core cannot rotate: only 0 degrees is accepted (a no-op)."""
        if isinstance(degrees, bool) or not isinstance(degrees, numbers.Real):
            raise TypeError(f"rotation must be a number of degrees, got {type(degrees).__name__}")
        if degrees != 0:
            raise ValueError(
                f"the core module cannot be rotated: only 0 degrees allowed, got {degrees}"
            )
