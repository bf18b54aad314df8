"""CompoundWorld: a heightfield floor, the base of the terrain worlds."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from ariel.simulation.environments._base import (
    BaseWorld,
    as_bool,
    as_dims,
    as_rotation_sequence,
    as_vector,
    euler_to_quat,
)
from ariel.simulation.environments._terrain import HeightfieldSurface

__all__ = ["TERRAIN_COLOR", "CompoundWorld"]

#: Colour of terrain floors drawn without the checker pattern (upstream's brown).
TERRAIN_COLOR = (0.460, 0.362, 0.216, 1.0)


class CompoundWorld(BaseWorld):
    """A heightfield floor: hfield "floor" and an HFIELD geom "floor" on the world body.

    MuJoCo rescales the heightmap to [0, 1], so only its shape matters; ``floor_size`` sets
    the real height.

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"compound-world"``.
        floor_size: ``(width, length, depth)`` in metres, all > 0: the heightfield covers
            width x length, its surface spans z in [0, depth / 2] above the geom origin and its
            base is depth / 10 thick.
        floor_tilt: Euler angles in DEGREES (in ``floor_rot_sequence``) that tilt the whole
            heightfield about the origin; the floor must stay below 90 degrees from level.
        floor_rot_sequence: the Euler sequence: 3 letters from ``xyzXYZ`` (MuJoCo's
            convention: lower case rotates about the tilted axes, upper case about fixed ones).
        dims: ``(rows, cols)``, each >= 2, of the flat map made when ``floor_heightmap`` is
            ``None`` (default (100, 100)); with a heightmap it must match its shape.
        floor_heightmap: a finite 2-D array of shape ``(rows, cols)``, at least 2 x 2 (rows run
            along y, columns along x); ``None`` gives a flat floor.
        terrain_color: the floor's RGBA colour (4 numbers in [0, 1]) when ``checker_floor`` is
            ``False``.
        checker_floor: a checkered floor (``True``) or one in ``terrain_color``.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.

    Raises:
        ValueError: an option's value is not allowed, e.g. a heightmap that is not 2-D and
            finite, ``dims`` that disagree with it, or a tilt of 90 degrees or more (and see
            `BaseWorld`).
    """

    name = "compound-world"
    ground_geoms = ("floor",)

    def __init__(
        self,
        *,
        name: str | None = None,
        floor_size: Sequence[float] = (10.0, 10.0, 1.0),
        floor_tilt: Sequence[float] = (0.0, 0.0, 0.0),
        floor_rot_sequence: str = "XYZ",
        dims: Sequence[int] | None = None,
        floor_heightmap: Any = None,
        terrain_color: Sequence[float] = TERRAIN_COLOR,
        checker_floor: bool = True,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = False,
    ) -> None:
        self.floor_size = as_vector(floor_size, 3, "floor_size", positive=True)
        self.floor_tilt = as_vector(floor_tilt, 3, "floor_tilt")
        self.floor_rot_sequence = as_rotation_sequence(floor_rot_sequence)
        self.checker_floor = as_bool(checker_floor, "checker_floor")
        self.terrain_color = as_vector(terrain_color, 4, "terrain_color")
        if not all(0.0 <= c <= 1.0 for c in self.terrain_color):
            raise ValueError(f"terrain_color must be 4 numbers in [0, 1], got {terrain_color!r}")
        if floor_heightmap is None:
            self.dims = (100, 100) if dims is None else as_dims(dims)
            heightmap = np.zeros(self.dims)
        else:
            heightmap = np.array(floor_heightmap, dtype=np.float64)
            if heightmap.ndim != 2 or min(heightmap.shape) < 2:
                raise ValueError(
                    f"floor_heightmap must be a 2-D array of at least 2x2, "
                    f"got shape {heightmap.shape}",
                )
            if not np.all(np.isfinite(heightmap)):
                raise ValueError("floor_heightmap must be finite (no NaN/inf)")
            if dims is not None and as_dims(dims) != heightmap.shape:
                raise ValueError(
                    f"dims {tuple(dims)} disagree with floor_heightmap shape {heightmap.shape}",
                )
            self.dims = (int(heightmap.shape[0]), int(heightmap.shape[1]))
        self.heightmap = heightmap
        width, length, depth = self.floor_size
        self.hfield_size = (width / 2, length / 2, depth / 2, depth / 10)
        self._quat = euler_to_quat(self.floor_tilt, self.floor_rot_sequence)
        try:
            self.surface = HeightfieldSurface(heightmap, self.hfield_size, quat=self._quat)
        except ValueError:
            raise ValueError(
                f"floor_tilt {self.floor_tilt} leaves the floor vertical or upside down; "
                "allowed: tilts below 90 degrees",
            ) from None
        super().__init__(
            name=name,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )

    def _build(self) -> None:
        rows, cols = self.heightmap.shape
        self.spec.add_hfield(
            name="floor",
            size=list(self.hfield_size),
            nrow=rows,
            ncol=cols,
            userdata=self.heightmap.ravel().tolist(),
        )
        geom = self.spec.worldbody.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_HFIELD,
            hfieldname="floor",
            quat=self._quat.tolist(),
        )
        if self.checker_floor:
            geom.material = self._add_checker_material("floor")
        else:
            geom.rgba = list(self.terrain_color)

    def _ground_height_array(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self.surface.height(x, y)
