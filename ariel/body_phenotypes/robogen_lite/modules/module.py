"""Base class shared by the core, brick and hinge modules.

A module owns a fresh, private ``mujoco.MjSpec`` holding only itself. Its root body ``.body``
is what a parent attaches (``parent.sites[face].attach_body(body=child.body, prefix=...)``, the
plain MuJoCo call). Every module grows along its local +y axis from its origin; the orientation
of the site it is attached to decides where it points.
"""

from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from typing import ClassVar

import mujoco

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces, ModuleType
from ariel.errors import FaceNotAvailableError
from ariel.utils import accept_aliases

__all__ = ["FaceNotAvailableError", "Module", "ModuleSites", "growth_axis_quat", "rgba"]


class ModuleSites(dict[ModuleFaces, mujoco.MjsSite]):
    """The attachment sites of one module, keyed by face.

    Only the faces the module physically has are present; looking up another one raises
    `FaceNotAvailableError` naming the module type and the faces it has.

    Args:
        module_type: Type of the module the sites belong to (named in the error message).
        sites: ``(face, site)`` pairs of the faces the module has.
    """

    def __init__(
        self, module_type: ModuleType, sites: Iterable[tuple[ModuleFaces, mujoco.MjsSite]]
    ):
        super().__init__(sites)
        self.module_type = module_type

    def __missing__(self, key: object) -> mujoco.MjsSite:
        have = ", ".join(face.name for face in self)
        what = key.name if isinstance(key, ModuleFaces) else repr(key)
        if not isinstance(key, ModuleFaces):
            what = f"{what} (not a ModuleFaces member)"
        raise FaceNotAvailableError(
            f"face {what} is not available on a {self.module_type.name} module; it has: {have}"
        )


def rgba(red: int, green: int, blue: int, alpha: float = 1.0) -> list[float]:
    """RGBA in 0..1 from 0..255 colour components.

    Args:
        red: Red component, 0..255.
        green: Green component, 0..255.
        blue: Blue component, 0..255.
        alpha: Opacity, already in 0..1 (1 is opaque); passed through unchanged.

    Returns:
        ``[red, green, blue, alpha]``, each in 0..1, as MuJoCo's ``rgba`` expects.
    """
    return [red / 255.0, green / 255.0, blue / 255.0, alpha]


def growth_axis_quat(degrees: float) -> list[float]:
    """Quaternion (w, x, y, z) of a rotation by ``degrees`` about the local +y (growth) axis.

    Args:
        degrees: Rotation angle in degrees (right-hand rule about +y).

    Returns:
        The unit quaternion ``[cos(a/2), 0, sin(a/2), 0]`` for the angle ``a`` in radians.
    """
    half = math.radians(degrees) / 2.0
    return [math.cos(half), 0.0, math.sin(half), 0.0]


def _check_degrees(degrees: object) -> float:
    if isinstance(degrees, bool) or not isinstance(degrees, numbers.Real):
        raise TypeError(f"rotation must be a number of degrees, got {type(degrees).__name__}")
    value = float(degrees)
    if not math.isfinite(value):
        raise ValueError(f"rotation must be a finite number of degrees, got {value}")
    return value


class Module(ABC):
    """A robogen-lite module: ``.spec``, ``.body``, ``.sites``, ``.index``, ``.module_type``.

    Subclasses set the class attribute ``module_type`` and build their spec in ``_build``.
    The root body is named after the type in lower case (e.g. "hinge").

    Args:
        index: The module index (its node id in the robot graph), kept as ``.index``.

    Raises:
        NotImplementedError: If the subclass does not define ``module_type``.
        TypeError: If ``index`` is not an int (a bool is refused too).
    """

    module_type: ClassVar[ModuleType]

    def __init__(self, index: int) -> None:
        if not isinstance(getattr(type(self), "module_type", None), ModuleType):
            raise NotImplementedError(
                f"{type(self).__name__} must define a class attribute module_type"
            )
        if isinstance(index, bool) or not isinstance(index, numbers.Integral):
            raise TypeError(f"module index must be an int, got {type(index).__name__}")
        self.index: int = int(index)
        self.rotation: float = 0.0
        self.spec: mujoco.MjSpec = mujoco.MjSpec()
        # Module code works in radians (quaternions are set explicitly anyway).
        self.spec.compiler.degree = False
        self.body: mujoco.MjsBody = self.spec.worldbody.add_body(name=self.module_type.name.lower())
        faces = self._build(self.body)
        self.sites: ModuleSites = ModuleSites(self.module_type, faces)

    @abstractmethod
    def _build(self, body: mujoco.MjsBody) -> Sequence[tuple[ModuleFaces, mujoco.MjsSite]]:
        """Add geoms, joints, actuators to ``self.spec``; return the attachment sites."""

    @accept_aliases(angle="degrees")
    def rotate(self, degrees: float) -> None:
        """Set the module's rotation about its own +y growth axis (absolute, in degrees).

        Upstream's keyword ``angle=`` is accepted too."""
        value = _check_degrees(degrees)
        self.body.quat = growth_axis_quat(value)
        self.rotation = value

    def __repr__(self) -> str:
        return f"{type(self).__name__}(index={self.index}, rotation={self.rotation:g})"
