"""OlympicArena: a walled track, flat -> rugged -> incline, with a target at the far end."""

from __future__ import annotations

import math
import numbers
from typing import Any

import mujoco
import numpy as np

from ariel.simulation.environments._base import (
    PLAIN_FLOOR_RGBA,
    BaseWorld,
    as_bool,
    as_dims,
    as_positive_float,
)
from ariel.simulation.environments._compound import TERRAIN_COLOR
from ariel.simulation.environments._rugged import DEFAULT_TERRAIN_SEED, check_seed
from ariel.simulation.environments._terrain import HeightfieldSurface
from ariel.simulation.environments.heightmaps import rugged_heightmap, smooth_edges_heightmap

__all__ = ["OlympicArena"]

# Where the flat section ends and the rugged one starts (as upstream), so a robot spawned at the
# origin stands on the flat section, 0.5 m before the rough ground.
_RUGGED_START_X = 0.5
_SLAB = 0.1  # thickness of the floor, incline and platform boxes
_WALL_THICKNESS = 0.05
_WALL_DEPTH = 0.1  # how far walls reach below the floor they stand on
_WALL_RGBA = (0.75, 0.75, 0.8, 0.5)
_TARGET_RADIUS = 0.1
_TARGET_RGBA = (1.0, 0.1, 0.1, 0.7)
_FINISH_RGBA = (0.9, 0.9, 0.9, 1.0)
_GRID_RGBA = (0.2, 0.3, 0.4, 1.0)

#: How a geom looks: ``{"material": name}`` or ``{"rgba": [r, g, b, a]}`` (add_geom keywords).
_Look = dict[str, str | list[float]]


def _upstream_lengths(
    section_length: float | None, incline_axis: str, rugged_length: float, incline_length: float
) -> tuple[float, float]:
    """The rugged and incline lengths, given as ours or as upstream's keywords.

    Upstream's ``section_length`` is the half-length of its rugged and incline sections (1.0
    -> 2 m each, our defaults); its track also runs along +x, so only an incline about the y
    axis ("y", upstream's default) fits it.
    """
    if incline_axis != "y":
        raise ValueError(
            f"incline_axis must be 'y' (the track runs along +x, the incline rises toward "
            f"the target); got {incline_axis!r}"
        )
    if section_length is not None:
        if (rugged_length, incline_length) != (2.0, 2.0):
            raise ValueError("give section_length or rugged_length/incline_length, not both")
        full = 2.0 * as_positive_float(section_length, "section_length")
        rugged_length = incline_length = full
    return rugged_length, incline_length


def _incline_degrees(value: object) -> float:
    """The incline's slope checked: a number within (-45, 45) degrees."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"incline_degrees must be a number, got {value!r}")
    if not -45.0 < float(value) < 45.0:
        raise ValueError(f"incline_degrees must be within (-45, 45), got {value!r}")
    return float(value)


class OlympicArena(BaseWorld):
    """A rectangular arena along +x with walls and a target marker (body "target").

    Track (y in [-arena_width/2, arena_width/2]):

    * flat: box "floor", top at z = 0, x in [0.5 - flat_length, 0.5] (the origin is on it);
    * rugged: heightfield "rugged_field" in body "rugged_section", x in [0.5, 0.5 +
      rugged_length], Perlin hills of total height `rugged_height`, flush with the flat floor
      at its borders;
    * incline: box "inclined_section", `incline_length` along a slope of `incline_degrees`
      (positive: uphill toward the target);
    * platform: box "finish_platform" of `platform_length`; the target (a see-through red ball
      that nothing collides with) stands at its centre, ``self.target_position``.

    Walls `wall_height` high (above the floor beside them) run along both sides and both ends.
    Deterministic by default (seed 42); ``seed=None`` draws fresh hills from
    NumPy's global RNG (``np.random.seed`` makes them repeat).

    Args:
        name: the world's name (a non-empty string); ``None`` gives ``"olympic_arena"``.
        arena_width: the track's width along y, in metres (> 0).
        flat_length: the flat section's length along x, in metres (> 0).
        rugged_length: the rugged section's length along x, in metres (> 0).
        incline_length: the incline's length along its slope, in metres (> 0).
        incline_degrees: the incline's slope in degrees, within (-45, 45); negative slopes
            downhill.
        platform_length: the finish platform's length along x, in metres (> 0).
        wall_height: the walls' height above the floor beside them, in metres (> 0).
        rugged_resolution: the rugged heightfield's rows and columns (>= 2).
        rugged_scale: the Perlin noise's feature size, in heightfield pixels per lattice cell
            (> 0).
        rugged_height: the total height of the rugged hills, in metres (> 0).
        seed: the hills' noise seed (same seed, same hills); ``None`` draws one from NumPy's
            global RNG.
        checker_floor: checkered floors (``True``) or plain-coloured ones.
        timestep: the physics step in seconds (> 0); ``None`` gives 0.002.
        mujoco_config: ``spec.option`` overrides, applied last (see `BaseWorld`).
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored.
        section_length: upstream's half-length of the rugged and incline sections: sets both
            lengths to twice this value (> 0); ``None`` leaves them to ``rugged_length`` and
            ``incline_length``.
        incline_axis: upstream's axis of the incline; only ``"y"`` (the default) fits the
            track along +x.

    Raises:
        ValueError: an option's value is not allowed, ``incline_axis`` is not ``"y"``, or
            ``section_length`` is given with non-default ``rugged_length`` /
            ``incline_length`` (and see `BaseWorld`).
    """

    name = "olympic_arena"
    ground_geoms = ("floor", "rugged_floor", "inclined_section", "finish_platform")

    def __init__(
        self,
        *,
        name: str | None = None,
        arena_width: float = 2.0,
        flat_length: float = 3.0,
        rugged_length: float = 2.0,
        incline_length: float = 2.0,
        incline_degrees: float = 15.0,
        platform_length: float = 1.5,
        wall_height: float = 0.3,
        rugged_resolution: int = 64,
        rugged_scale: float = 5.0,
        rugged_height: float = 0.07,
        seed: int | None = DEFAULT_TERRAIN_SEED,
        checker_floor: bool = True,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = True,
        section_length: float | None = None,
        incline_axis: str = "y",
    ) -> None:
        rugged_length, incline_length = _upstream_lengths(
            section_length, incline_axis, rugged_length, incline_length
        )
        self.arena_width = as_positive_float(arena_width, "arena_width")
        self.flat_length = as_positive_float(flat_length, "flat_length")
        self.rugged_length = as_positive_float(rugged_length, "rugged_length")
        self.incline_length = as_positive_float(incline_length, "incline_length")
        self.platform_length = as_positive_float(platform_length, "platform_length")
        self.wall_height = as_positive_float(wall_height, "wall_height")
        self.rugged_scale = as_positive_float(rugged_scale, "rugged_scale")
        self.rugged_height = as_positive_float(rugged_height, "rugged_height")
        self.rugged_resolution = as_dims(
            (rugged_resolution, rugged_resolution), "rugged_resolution"
        )[0]
        self.incline_degrees = _incline_degrees(incline_degrees)
        self.checker_floor = as_bool(checker_floor, "checker_floor")
        self.seed = check_seed(type(self).__name__, seed)  # as the other terrain worlds
        self._lay_out()
        self._make_rugged_surface()
        super().__init__(
            name=name,
            timestep=timestep,
            mujoco_config=mujoco_config,
            load_precompiled=load_precompiled,
        )

    def _lay_out(self) -> None:
        """Section boundaries along x, the platform height and the target's position."""
        theta = math.radians(self.incline_degrees)
        self._tan = math.tan(theta)
        self.x_start = _RUGGED_START_X - self.flat_length
        self.x_rugged_end = _RUGGED_START_X + self.rugged_length
        self.x_incline_end = self.x_rugged_end + self.incline_length * math.cos(theta)
        self.platform_height = self.incline_length * math.sin(theta)
        self.x_end = self.x_incline_end + self.platform_length
        self.target_position = (
            0.5 * (self.x_incline_end + self.x_end),
            0.0,
            self.platform_height,
        )

    def _make_rugged_surface(self) -> None:
        """The rugged section's heightmap, its heightfield's position and size, and its
        surface (what `ground_height` reads)."""
        res = self.rugged_resolution
        heightmap = rugged_heightmap((res, res), self.rugged_scale, seed=self.seed)
        self.rugged_heightmap = heightmap * smooth_edges_heightmap((res, res), 0.1)
        # MuJoCo rescales the map to [0, rugged_height]; shift it so the border (map value 0)
        # is flush with the flat floor at z = 0.
        low, high = float(self.rugged_heightmap.min()), float(self.rugged_heightmap.max())
        border = (0.0 - low) / (high - low) if high > low else 0.0
        self._rugged_pos = (
            0.5 * (_RUGGED_START_X + self.x_rugged_end),
            0.0,
            -self.rugged_height * border,
        )
        self._rugged_size = (
            self.rugged_length / 2,
            self.arena_width / 2,
            self.rugged_height,
            self.rugged_height / 10,
        )
        self.rugged_surface = HeightfieldSurface(
            self.rugged_heightmap,
            self._rugged_size,
            pos=self._rugged_pos,
        )

    # ---------------------------------------------------------------------------------------
    def _build(self) -> None:
        look_grid, look_finish = self._looks()
        self._add_flat_section(look_grid)
        self._add_rugged_section()
        incline = self._add_incline(look_grid)
        self._add_platform_and_target(look_finish)
        self._add_walls(*incline)

    def _looks(self) -> tuple[_Look, _Look]:
        """How the track and the finish platform look: checker materials (added to the spec)
        or plain colours."""
        if self.checker_floor:
            grid = self._add_checker_material("grid", reflectance=0.1)
            finish = self._add_checker_material(
                "finish_line",
                rgb1=(0.0, 0.0, 0.0),
                rgb2=(1.0, 1.0, 1.0),
                texrepeat=(8, 8),
                reflectance=0.1,
            )
            look_grid: _Look = {"material": grid}
            look_finish: _Look = {"material": finish}
        else:
            look_grid = {"rgba": list(PLAIN_FLOOR_RGBA)}
            look_finish = {"rgba": list(_FINISH_RGBA)}
        return look_grid, look_finish

    def _add_flat_section(self, look_grid: _Look) -> None:
        """1. Flat section."""
        self.spec.worldbody.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0.5 * (self.x_start + _RUGGED_START_X), 0.0, -_SLAB / 2],
            size=[self.flat_length / 2, self.arena_width / 2, _SLAB / 2],
            **look_grid,
        )

    def _add_rugged_section(self) -> None:
        """2. Rugged section."""
        spec, world = self.spec, self.spec.worldbody
        res = self.rugged_resolution
        spec.add_hfield(
            name="rugged_field",
            size=list(self._rugged_size),
            nrow=res,
            ncol=res,
            userdata=self.rugged_heightmap.ravel().tolist(),
        )
        rugged = world.add_body(name="rugged_section", pos=list(self._rugged_pos))
        rugged.add_geom(
            name="rugged_floor",
            type=mujoco.mjtGeom.mjGEOM_HFIELD,
            hfieldname="rugged_field",
            rgba=list(TERRAIN_COLOR),
        )

    def _add_incline(self, look_grid: _Look) -> tuple[np.ndarray, np.ndarray, list]:
        """3. Incline: its top face runs from (x_rugged_end, 0) up to the platform. Returns the
        middle of its top face, the top face's normal and its quaternion (for its walls)."""
        theta = math.radians(self.incline_degrees)
        along = np.array([math.cos(theta), 0.0, math.sin(theta)])
        normal = np.array([-math.sin(theta), 0.0, math.cos(theta)])
        start = np.array([self.x_rugged_end, 0.0, 0.0])
        incline_quat = [math.cos(-theta / 2), 0.0, math.sin(-theta / 2), 0.0]  # about y
        middle = start + 0.5 * self.incline_length * along
        self.spec.worldbody.add_geom(
            name="inclined_section",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=(middle - normal * _SLAB / 2).tolist(),
            quat=incline_quat,
            size=[self.incline_length / 2, self.arena_width / 2, _SLAB / 2],
            **look_grid,
        )
        return middle, normal, incline_quat

    def _add_platform_and_target(self, look_finish: _Look) -> None:
        """4. Platform with the finish pattern and the target."""
        world = self.spec.worldbody
        top = self.platform_height
        world.add_geom(
            name="finish_platform",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0.5 * (self.x_incline_end + self.x_end), 0.0, top - _SLAB / 2],
            size=[self.platform_length / 2, self.arena_width / 2, _SLAB / 2],
            **look_finish,
        )
        target = world.add_body(name="target", pos=list(self.target_position))
        target.add_geom(
            name="target",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            pos=[0.0, 0.0, _TARGET_RADIUS],
            size=[_TARGET_RADIUS, 0.0, 0.0],
            rgba=list(_TARGET_RGBA),
            contype=0,
            conaffinity=0,
        )

    def _add_walls(self, middle: np.ndarray, normal: np.ndarray, incline_quat: list) -> None:
        """5. Walls: sides per section (each as high as wall_height above its floor), two ends.
        ``middle``, ``normal``, ``incline_quat``: the incline's (`_add_incline`)."""
        world = self.spec.worldbody
        top = self.platform_height
        wall: dict[str, Any] = {"type": mujoco.mjtGeom.mjGEOM_BOX, "rgba": list(_WALL_RGBA)}
        side_y = self.arena_width / 2 + _WALL_THICKNESS / 2
        height = self.wall_height + _WALL_DEPTH
        for side, y in (("left", side_y), ("right", -side_y)):
            x0, x1 = self.x_start - _WALL_THICKNESS, self.x_rugged_end
            world.add_geom(
                name=f"wall_{side}_flat",
                pos=[0.5 * (x0 + x1), y, 0.5 * (self.wall_height - _WALL_DEPTH)],
                size=[0.5 * (x1 - x0), _WALL_THICKNESS / 2, height / 2],
                **wall,
            )
            # Overlap the neighbouring walls so the joints at the slope's ends leave no gap.
            centre = middle + normal * 0.5 * (self.wall_height - _WALL_DEPTH)
            world.add_geom(
                name=f"wall_{side}_incline",
                pos=[centre[0], y, centre[2]],
                quat=incline_quat,
                size=[self.incline_length / 2 + 0.1, _WALL_THICKNESS / 2, height / 2],
                **wall,
            )
            x0, x1 = self.x_incline_end, self.x_end + _WALL_THICKNESS
            world.add_geom(
                name=f"wall_{side}_platform",
                pos=[0.5 * (x0 + x1), y, top + 0.5 * (self.wall_height - _WALL_DEPTH)],
                size=[0.5 * (x1 - x0), _WALL_THICKNESS / 2, height / 2],
                **wall,
            )
        end_half_y = self.arena_width / 2 + _WALL_THICKNESS
        world.add_geom(
            name="wall_start",
            pos=[
                self.x_start - _WALL_THICKNESS / 2,
                0.0,
                0.5 * (self.wall_height - _WALL_DEPTH),
            ],
            size=[_WALL_THICKNESS / 2, end_half_y, height / 2],
            **wall,
        )
        world.add_geom(
            name="wall_end",
            pos=[
                self.x_end + _WALL_THICKNESS / 2,
                0.0,
                top + 0.5 * (self.wall_height - _WALL_DEPTH),
            ],
            size=[_WALL_THICKNESS / 2, end_half_y, height / 2],
            **wall,
        )

    def _ground_height_array(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Piecewise: flat (0), the heightfield, the incline plane, the platform."""
        heights = np.zeros_like(x)
        rugged = (x > _RUGGED_START_X) & (x < self.x_rugged_end)
        if np.any(rugged):
            heights[rugged] = self.rugged_surface.height(x[rugged], y[rugged])
        incline = (x >= self.x_rugged_end) & (x < self.x_incline_end)
        heights[incline] = (x[incline] - self.x_rugged_end) * self._tan
        heights[x >= self.x_incline_end] = self.platform_height
        return heights
