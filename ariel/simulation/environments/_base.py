"""BaseWorld: the MuJoCo spec every world starts from, and robot spawning.

A world owns one ``mujoco.MjSpec`` (``world.spec``). Subclasses add their floor in
``_build()`` and say how high the ground is with ``_ground_height_array(x, y)``; ``spawn()``
uses that to drop a robot so that its lowest point sits exactly 1 cm above the ground directly
under it, whatever the spawn rotation, slope or terrain.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import numbers
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np

from ariel.simulation.control_callback import control_callback_unset
from ariel.simulation.environments._clearance import collision_clearance, robot_points

__all__ = ["BaseWorld"]

#: Gap between a freshly spawned robot's lowest point and the ground under it (metres).
SPAWN_CLEARANCE = 0.01

#: Default physics step of every world (seconds); MuJoCo's own default, set explicitly.
DEFAULT_TIMESTEP = 0.002

# Texture sizes (pixels). Builtin textures are generated on every compile (spawn compiles too),
# so they are kept small: upstream's 512x3072 gradient skybox costs ~20 ms per compile, a 64 px
# one ~0.8 ms and looks the same (a smooth gradient); a 256 px checker costs ~0.1 ms.
CHECKER_TEXTURE_PX = 256
SKYBOX_TEXTURE_PX = 64

# Floor colours: the checker pair (upstream's) and the plain colour used with checker_floor=False.
CHECKER_RGB1 = (0.1, 0.2, 0.3)
CHECKER_RGB2 = (0.2, 0.3, 0.4)
PLAIN_FLOOR_RGBA = (0.15, 0.25, 0.35, 1.0)

# String values accepted for the enum-valued MjOption fields in `mujoco_config`.
_OPTION_ENUMS: dict[str, tuple[type, str]] = {
    "integrator": (mujoco.mjtIntegrator, "mjINT_"),
    "cone": (mujoco.mjtCone, "mjCONE_"),
    "solver": (mujoco.mjtSolver, "mjSOL_"),
    "jacobian": (mujoco.mjtJacobian, "mjJAC_"),
}

_EULER_AXES = frozenset("xyzXYZ")


# --------------------------------------------------------------------------------------------
# Small validators shared by all worlds (one-line errors that say what is allowed).
# --------------------------------------------------------------------------------------------
def as_vector(
    value: Any,
    length: int,
    what: str,
    *,
    positive: bool = False,
) -> tuple[float, ...]:
    """Return `value` as a tuple of `length` finite floats, or raise a one-line ValueError."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"{what} must be {length} numbers, got {value!r}",
        ) from None
    if array.shape != (length,):
        raise ValueError(f"{what} must be {length} numbers, got {value!r}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{what} must be finite numbers (no NaN/inf), got {value!r}")
    if positive and not np.all(array > 0):
        raise ValueError(f"{what} must be positive numbers, got {value!r}")
    return tuple(float(v) for v in array)


def as_positive_float(value: Any, what: str) -> float:
    """Return `value` as a finite float > 0, or raise a one-line ValueError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what} must be a positive number, got {value!r}")
    number = float(value)
    if not math.isfinite(number) or number <= 0:
        raise ValueError(f"{what} must be a positive finite number, got {value!r}")
    return number


def as_bool(value: Any, what: str) -> bool:
    """Return `value` if it is a bool, else raise a one-line ValueError."""
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{what} must be True or False, got {value!r}")
    return bool(value)


def as_dims(value: Any, what: str = "dims") -> tuple[int, int]:
    """Return (rows, cols) as two ints >= 2, or raise a one-line ValueError."""
    try:
        rows, cols = value
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be two integers >= 2 (rows, cols), got {value!r}") from None
    for n in (rows, cols):
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
            raise ValueError(f"{what} must be two integers >= 2 (rows, cols), got {value!r}")
    return int(rows), int(cols)


def as_rotation_sequence(value: Any) -> str:
    """Validate a MuJoCo Euler sequence: 3 letters from xyzXYZ (upper case = intrinsic)."""
    if not isinstance(value, str) or len(value) != 3 or not set(value) <= _EULER_AXES:
        raise ValueError(
            f"rotation sequence must be 3 letters from 'xyzXYZ' (e.g. 'XYZ'), got {value!r}",
        )
    return value


def euler_to_quat(degrees: Sequence[float], sequence: str = "XYZ") -> np.ndarray:
    """Euler angles in DEGREES -> MuJoCo quaternion (w, x, y, z)."""
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.deg2rad(np.asarray(degrees, dtype=float)), sequence)
    return quat


def quat_to_mat(quat: Sequence[float]) -> np.ndarray:
    """MuJoCo quaternion (w, x, y, z) -> 3x3 rotation matrix."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)


def as_name(value: Any) -> str:
    """A world name: a non-empty string."""
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"name must be a non-empty string, got {value!r}")
    return value


@functools.cache
def _option_names(cls: type) -> tuple[str, ...]:
    """The keyword options a world class accepts: the parameters of its ``__init__``."""
    parameters = inspect.signature(cls.__init__).parameters.values()
    return tuple(
        sorted(
            p.name
            for p in parameters
            if p.name != "self" and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)
        ),
    )


@functools.cache
def _mjoption_fields() -> tuple[str, ...]:
    """Names of the settable fields of ``spec.option`` (what `mujoco_config` may override)."""
    option = mujoco.MjSpec().option
    return tuple(
        sorted(
            name
            for name in dir(option)
            if not name.startswith("_") and not callable(getattr(option, name))
        ),
    )


def _config_items(config: Any) -> dict[str, Any]:
    """Turn a `mujoco_config` (mapping, dataclass or plain object) into a dict of overrides."""
    if config is None:
        return {}
    if isinstance(config, Mapping):
        items = dict(config)
    elif dataclasses.is_dataclass(config) and not isinstance(config, type):
        items = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    elif hasattr(config, "__dict__"):
        items = {k: v for k, v in vars(config).items() if not k.startswith("_")}
    else:
        raise TypeError(
            f"mujoco_config must be a mapping or an object with attributes, "
            f"got {type(config).__name__}",
        )
    allowed = _mjoption_fields()
    for key in items:
        if key not in allowed:
            raise ValueError(
                f"unknown mujoco_config option {key!r}; allowed: {', '.join(allowed)}",
            )
    return items


def _option_value(key: str, value: Any) -> Any:
    """Convert enum names given as strings ('implicitfast', 'RK4', 'newton', ...) to enums."""
    if key in _OPTION_ENUMS and isinstance(value, str):
        enum, prefix = _OPTION_ENUMS[key]
        member = getattr(enum, prefix + value.upper(), None)
        if member is None:
            names = ", ".join(m.removeprefix(prefix).lower() for m in enum.__members__)
            raise ValueError(f"unknown {key} {value!r}; allowed: {names}")
        return member
    if key == "timestep":
        return as_positive_float(value, "mujoco_config timestep")
    return value


# --------------------------------------------------------------------------------------------
class BaseWorld:
    """A MuJoCo world: an ``MjSpec`` with lights, cameras and settings, and ``spawn()``.

    Options are keyword-only, in every world. The integrator is implicitfast.

    The base world has no floor; its ground is the plane z = 0, which ``spawn()`` uses.

    Args:
        name: the world's name (a non-empty string, also the spec's model name, title-cased);
            ``None`` gives the class's ``name``.
        timestep: the physics step in seconds (> 0), always set explicitly; ``None`` gives
            0.002 s (MuJoCo's default).
        mujoco_config: a mapping, dataclass or object whose fields are ``spec.option`` fields,
            e.g. ``{"timestep": 0.001, "integrator": "RK4"}`` (enum fields take their names as
            strings). Stored in ``self.mujoco_config`` and applied after everything else; a
            timestep given here must agree with ``timestep``.
        load_precompiled: accepted for compatibility with upstream ARIEL and ignored: worlds
            are always generated (cheaply).

    Raises:
        TypeError: a positional argument or an option the world does not take, or a
            ``mujoco_config`` that is neither a mapping nor an object with attributes.
        ValueError: an option's value is not allowed (the message says what is), e.g. an
            unknown ``mujoco_config`` field or two different timesteps.

    Example:
        ```python
        import mujoco

        from ariel.simulation.environments import SimpleFlatWorld

        world = SimpleFlatWorld(timestep=0.001, mujoco_config={"integrator": "RK4"})
        robot = mujoco.MjSpec()  # a stand-in robot: one 10 cm box
        core = robot.worldbody.add_body(name="core")
        core.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.05])
        model = world.spawn(robot, position=(0.0, 0.0, 0.0)).compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        print(model.opt.timestep, round(float(data.qpos[2]), 3))  # 0.001 0.06: 1 cm up
        ```
    """

    name: str = "base-world"
    spawn_prefix: ClassVar[str] = "robot"
    default_spawn_position: ClassVar[tuple[float, float, float]] = (0.0, 0.0, 0.0)
    default_spawn_rotation: ClassVar[tuple[float, float, float]] = (0.0, 0.0, 0.0)
    is_precompiled: ClassVar[bool] = False
    #: Names of the geoms that make up the ground (spawn() measures clearance against them).
    ground_geoms: ClassVar[tuple[str, ...]] = ()

    def __new__(cls, *args: Any, **kwargs: Any) -> BaseWorld:
        # Checked here so every subclass gets the same one-line error listing its own options.
        allowed = _option_names(cls)
        if args:
            raise TypeError(
                f"{cls.__name__} takes keyword options only; allowed: {', '.join(allowed)}",
            )
        for key in kwargs:
            if key not in allowed:
                raise TypeError(
                    f"unknown option {key!r} for {cls.__name__}; allowed: {', '.join(allowed)}",
                )
        return super().__new__(cls)

    def __init__(
        self,
        *,
        name: str | None = None,
        timestep: float | None = None,
        mujoco_config: Any = None,
        load_precompiled: bool = False,
    ) -> None:
        """Build the spec: settings, visuals, light, cameras, then the subclass's floor."""
        self.name = as_name(type(self).name if name is None else name)
        self.load_precompiled = bool(load_precompiled)  # accepted, ignored (see class doc)
        self.spawns = 0
        overrides = {k: _option_value(k, v) for k, v in _config_items(mujoco_config).items()}
        self.mujoco_config = {} if mujoco_config is None else mujoco_config
        if timestep is not None:
            timestep = as_positive_float(timestep, "timestep")
            if overrides.get("timestep", timestep) != timestep:
                raise ValueError(
                    f"timestep={timestep} conflicts with mujoco_config timestep "
                    f"{overrides['timestep']}; give it once",
                )
        self.spec = self._init_spec(DEFAULT_TIMESTEP if timestep is None else timestep)
        self._build()
        for key, value in overrides.items():
            try:
                setattr(self.spec.option, key, value)
            except (TypeError, ValueError) as error:
                message = str(error).splitlines()[0]
                raise ValueError(f"bad mujoco_config value for {key!r}: {message}") from None
        self.timestep = float(self.spec.option.timestep)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, timestep={self.timestep})"

    # ---------------------------------------------------------------------------------------
    # Spec construction
    # ---------------------------------------------------------------------------------------
    def _init_spec(self, timestep: float) -> mujoco.MjSpec:
        """A spec with upstream ARIEL's settings, visuals, skybox, light and two cameras."""
        spec = mujoco.MjSpec()
        spec.modelname = self.name.replace("-", " ").replace("_", " ").title()
        spec.copy_during_attach = True  # spawn() copies the robot, the caller's spec is untouched

        spec.option.timestep = timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST

        spec.compiler.autolimits = True
        spec.compiler.balanceinertia = True
        spec.compiler.degree = False

        visual = spec.visual
        visual.global_.offwidth = 1280
        visual.global_.offheight = 960
        visual.global_.azimuth = 140
        visual.global_.elevation = -20
        visual.headlight.diffuse = [0.6, 0.6, 0.6]
        visual.headlight.ambient = [0.1, 0.1, 0.1]
        visual.headlight.specular = [0.9, 0.9, 0.9]
        visual.rgba.force = [1, 0, 0, 1]
        visual.rgba.haze = [0.15, 0.25, 0.35, 1]
        visual.map.force = 0.01
        visual.scale.forcewidth = 0.3
        visual.scale.contactwidth = 0.5
        visual.scale.contactheight = 0.2
        visual.quality.shadowsize = 8192

        spec.add_texture(
            name="skybox",
            type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
            rgb1=[61 / 255, 163 / 255, 179 / 255],
            rgb2=[82 / 255, 57 / 255, 153 / 255],
            width=SKYBOX_TEXTURE_PX,
            height=6 * SKYBOX_TEXTURE_PX,
        )
        spec.worldbody.add_light(
            name="light",
            type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
            pos=[0, 0, 1],
            dir=[0, 0, -1],
            castshadow=False,
        )
        ortho = spec.worldbody.add_camera(
            name="ortho-cam",
            pos=[-5, 0, 5],
            fovy=5,
            proj=mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC,
        )
        ortho.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        ortho.alt.xyaxes = [0, -1, 0, 0.75, 0, 0.75]
        pretty = spec.worldbody.add_camera(
            name="pretty-cam",
            pos=[-0.015, -3.003, 1.765],
            fovy=45,
        )
        pretty.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        pretty.alt.xyaxes = [1, -0.005, 0, 0.002, 0.507, 0.862]
        return spec

    def _build(self) -> None:
        """Add the world's floor and objects to ``self.spec`` (the base world has none)."""

    def _add_checker_material(
        self,
        name: str,
        *,
        rgb1: Sequence[float] = CHECKER_RGB1,
        rgb2: Sequence[float] = CHECKER_RGB2,
        texrepeat: Sequence[float] = (3, 3),
        reflectance: float = 0.0,
    ) -> str:
        """Add a checker texture and a material (both called `name`); return the name."""
        self.spec.add_texture(
            name=name,
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
            rgb1=list(rgb1),
            rgb2=list(rgb2),
            width=CHECKER_TEXTURE_PX,
            height=CHECKER_TEXTURE_PX,
        )
        material = self.spec.add_material(
            name=name,
            texrepeat=list(texrepeat),
            texuniform=True,
            reflectance=reflectance,
        )
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
        return name

    # ---------------------------------------------------------------------------------------
    # Ground
    # ---------------------------------------------------------------------------------------
    def ground_height(self, x: Any, y: Any) -> Any:
        """Height (world z) of the ground directly under world point(s) (x, y).

        Vectorised: x and y broadcast; returns a float for scalar input, else an array.
        """
        xs, ys = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        heights = np.asarray(self._ground_height_array(xs, ys), dtype=float)
        heights = np.broadcast_to(heights, xs.shape)
        return float(heights) if heights.ndim == 0 else heights.copy()

    def _ground_height_array(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Ground height for arrays x, y of equal shape (base world: the plane z = 0)."""
        return np.zeros_like(x)

    # ---------------------------------------------------------------------------------------
    # Spawning
    # ---------------------------------------------------------------------------------------
    def spawn(
        self,
        robot_spec: mujoco.MjSpec,
        position: Sequence[float] | None = None,
        rotation: Sequence[float] | None = None,
        spawn_prefix: str | None = None,
        *,
        correct_collision_with_floor: bool = True,
        validate_no_collisions: bool = False,
        rotation_sequence: str = "XYZ",
    ) -> mujoco.MjSpec:
        """Attach a copy of `robot_spec` to the world with a free joint; return ``self.spec``.

        `position` (x, y, z) places the robot's frame; `rotation` is Euler angles in DEGREES
        in `rotation_sequence` (upper case = intrinsic axes). Names get the prefix
        ``f"{spawn_prefix or 'robot'}{n}_"`` with n = 1, 2, ... per world.

        With `correct_collision_with_floor` (default) the robot is then moved along world z so
        that its lowest geom point is 1 cm above the ground directly under it, plus `position`'s
        z as extra height (upstream: z is a drop height; at z = 0 the robot rests 1 cm up). This
        holds for any rotation (roll and pitch included: the shift is along world z), on slopes
        and on heightfields. How: compile the world with the robot, run ``mj_kinematics``,
        estimate the clearance from points on every geom's surface against
        ``ground_height``, then make it exact with MuJoCo's own collision detection between the
        robot and the world's ground geoms (a bisection on the robot's height with
        ``mj_kinematics`` + ``mj_collision``; it catches a heightfield bump under the middle of
        a face). ``MjSpec.compile()`` runs a globally set ``mjcb_control`` (and fails on a
        Python one), so spawn() unsets it while it compiles and puts it back afterwards; the
        other calls never run it. (Compiling ``world.spec`` yourself still needs it unset, as
        the tutorials do with ``mujoco.set_mjcb_control(None)``.)

        `validate_no_collisions` warns (``RuntimeWarning``) about contacts of the new robot at
        its spawn pose; it uses ``mj_fwdPosition``, which doesn't call ``mjcb_control`` either.
        """
        if not isinstance(robot_spec, mujoco.MjSpec):
            raise TypeError(f"robot_spec must be a mujoco.MjSpec, got {type(robot_spec).__name__}")
        pos = np.array(
            as_vector(
                self.default_spawn_position if position is None else position,
                3,
                "spawn position",
            ),
        )
        rot = as_vector(
            self.default_spawn_rotation if rotation is None else rotation,
            3,
            "spawn rotation",
        )
        sequence = as_rotation_sequence(rotation_sequence)
        if spawn_prefix is not None and (not isinstance(spawn_prefix, str) or not spawn_prefix):
            raise ValueError(f"spawn_prefix must be a non-empty string, got {spawn_prefix!r}")
        quat = euler_to_quat(rot, sequence)

        self.spawns += 1
        prefix = f"{spawn_prefix or self.spawn_prefix}{self.spawns}_"
        site = self.spec.worldbody.add_site(pos=pos.tolist(), quat=quat.tolist())
        body = site.attach_body(robot_spec.worldbody, prefix)
        try:
            body.add_freejoint()
            if correct_collision_with_floor:
                lift = SPAWN_CLEARANCE + pos[2] - self._lowest_clearance(body.name)
                # The body's position is expressed in the (rotated) site frame.
                body.pos = (quat_to_mat(quat).T @ np.array([0.0, 0.0, lift])).tolist()
            if validate_no_collisions:
                self._warn_about_contacts(body.name)
        except Exception:
            # Leave the world as it was: no half-spawned robot.
            self.spec.delete(body)
            self.spec.delete(site)
            self.spawns -= 1
            raise
        return self.spec

    def _compile_at_rest(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """The world as it is now, compiled for positions and contacts (no rendering).

        Builtin textures (the skybox, checker floors) cost most of a world's compile and play
        no part in positions or contacts, so they are compiled at their smallest size here
        and their sizes put back afterwards: ``self.spec`` ends as it began.
        """
        textures = [
            (texture, texture.width, texture.height)
            for texture in self.spec.textures
            if texture.builtin != mujoco.mjtBuiltin.mjBUILTIN_NONE
        ]
        try:
            for texture, _width, _height in textures:
                texture.width = 1
                # A cube or skybox texture holds its 6 faces stacked: height 6 * width.
                texture.height = 1 if texture.type == mujoco.mjtTexture.mjTEXTURE_2D else 6
            with control_callback_unset():
                model = self.spec.compile()
        finally:
            for texture, width, height in textures:
                texture.width = width
                texture.height = height
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)  # positions only; never calls mjcb_control
        return model, data

    @staticmethod
    def _robot_geoms(model: mujoco.MjModel, body_name: str) -> np.ndarray:
        body_id = model.body(body_name).id
        # The spawned body hangs off the world body, so it is the root of its own subtree.
        return np.flatnonzero(model.body_rootid[model.geom_bodyid] == body_id)

    def _lowest_clearance(self, body_name: str) -> float:
        """Smallest vertical gap between the robot (as compiled now) and the ground under it."""
        model, data = self._compile_at_rest()
        body_id = model.body(body_name).id
        geoms = self._robot_geoms(model, body_name)
        points = robot_points(model, data, geoms)
        if len(points) == 0:  # no geoms: keep the body's origin off the ground
            x, y, z = data.xpos[body_id]
            return float(z - self.ground_height(x, y))
        estimate = float(np.min(points[:, 2] - self.ground_height(points[:, 0], points[:, 1])))
        ground = [model.geom(name).id for name in self.ground_geoms]
        if not ground:
            return estimate
        free_z = int(model.jnt_qposadr[model.body_jntadr[body_id]]) + 2
        return collision_clearance(model, data, free_z, geoms, np.array(ground), estimate)

    def _warn_about_contacts(self, body_name: str) -> None:
        model, data = self._compile_at_rest()
        mujoco.mj_fwdPosition(model, data)  # computes contacts; no control callback
        robot = set(self._robot_geoms(model, body_name).tolist())
        pairs = []
        for contact in data.contact[: data.ncon]:
            g1, g2 = int(contact.geom1), int(contact.geom2)
            if g1 in robot or g2 in robot:
                pairs.append(f"{model.geom(g1).name or g1}/{model.geom(g2).name or g2}")
        if pairs:
            warnings.warn(
                f"spawned robot {body_name!r} starts in contact: {', '.join(pairs)}",
                RuntimeWarning,
                stacklevel=3,
            )
