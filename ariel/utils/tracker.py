"""Tracker: record attributes of named MuJoCo objects (e.g. the core geom's ``xpos``) over a run.

Tutorial API (upstream ARIEL §12)::

    tracker = Tracker(mujoco.mjtObj.mjOBJ_GEOM, "core", ["xpos"])
    tracker.setup(world.spec, data)   # bind every geom whose name contains "core"
    tracker.update(data)              # append a copy of each attribute (Controller does this)
    tracker.history["xpos"][0]        # list of (3,) arrays for the first bound object
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from typing import Any

import mujoco
import numpy as np

__all__ = ["Tracker"]

logger = logging.getLogger(__name__)


def _attributes_of(obj_type: Any) -> tuple[str, ...] | None:
    """The attributes ``data.bind`` gives an object of this type (``mjOBJ_GEOM``: ``xpos``,
    ``xmat``, ...), from MuJoCo's binding class; None where MuJoCo has none to read."""
    try:
        kind = mujoco.mjtObj(obj_type).name.removeprefix("mjOBJ_").capitalize()
    except (TypeError, ValueError):
        return None
    views = getattr(mujoco._structs, f"_MjData{kind}Views", None)
    return None if views is None else tuple(n for n in dir(views) if not n.startswith("_"))


def _check_attributes(obj_type: Any, attributes: list[str]) -> None:
    allowed = _attributes_of(obj_type)
    for attribute in attributes:
        if not isinstance(attribute, str):
            raise TypeError(
                "Tracker: observable_attributes must be a list of attribute names such as "
                f"['xpos']; it holds {type(attribute).__name__} {attribute!r}"
            )
        if allowed is not None and attribute not in allowed:
            raise ValueError(
                f"Tracker: observable_attributes has {attribute!r}, which a bound "
                f"{getattr(obj_type, 'name', obj_type)} lacks; allowed: {', '.join(allowed)}"
            )


class Tracker:
    """Binds MuJoCo objects by type and name substring and records their attributes.

    ``history[attribute][index]`` is a list with one copy of the attribute per ``update``,
    ``index`` numbering the bound objects in spec traversal order.

    Args:
        mujoco_obj_to_find: Type of object to bind (e.g. ``mujoco.mjtObj.mjOBJ_GEOM``). If it
            or ``name_to_bind`` is None, both default: geoms whose name contains "core".
        name_to_bind: Substring of the names of the objects to bind (see above for None).
        observable_attributes: Names of the bound objects' attributes to record (e.g.
            ``["xpos"]``, the default when None); a list, not one string.
        quiet: Do not log the note that the default geoms/"core" are tracked.

    Raises:
        TypeError: If ``observable_attributes`` is a single string.
        ValueError: If it names an attribute that objects of this type lack (the message
            lists the allowed ones: ``xpos``, ``xmat``, ``xquat`` for geoms).
    """

    def __init__(
        self,
        mujoco_obj_to_find: mujoco.mjtObj | None = None,
        name_to_bind: str | None = None,
        observable_attributes: Sequence[str] | None = None,
        quiet: bool = False,
    ) -> None:
        if mujoco_obj_to_find is None or name_to_bind is None:
            mujoco_obj_to_find = mujoco.mjtObj.mjOBJ_GEOM
            name_to_bind = "core"
            if not quiet:
                logger.info(
                    "Tracker: no object type/name given; tracking geoms whose name contains 'core'"
                )
        if isinstance(observable_attributes, str) or not isinstance(
            observable_attributes, Iterable | None
        ):
            raise TypeError(
                f"Tracker: observable_attributes must be a list of names, e.g. ['xpos']; "
                f"got {type(observable_attributes).__name__} {observable_attributes!r}"
            )
        self.mujoco_obj_to_find = mujoco_obj_to_find
        self.name_to_bind = name_to_bind
        self.observable_attributes: list[str] = (
            ["xpos"] if observable_attributes is None else list(observable_attributes)
        )
        _check_attributes(mujoco_obj_to_find, self.observable_attributes)
        self.history: dict[str, dict[int, list[Any]]] = {}
        self.geoms: list[Any] = []
        self.to_track: list[Any] | None = None

    @property
    def is_set_up(self) -> bool:
        """Whether ``setup`` has bound this tracker to a model's data."""
        return self.to_track is not None

    def setup(self, world: mujoco.MjSpec, data: mujoco.MjData) -> None:
        """Bind every object of the chosen type whose name contains ``name_to_bind``.

        ``data`` must come from a model compiled from ``world``. History lists that already
        exist are kept (so a re-setup continues them).
        """
        worldbody = getattr(world, "worldbody", None)
        if worldbody is None:
            raise TypeError(
                f"Tracker.setup needs the world's mujoco.MjSpec (e.g. world.spec); "
                f"got {type(world).__name__}"
            )
        self.geoms = list(worldbody.find_all(self.mujoco_obj_to_find))
        self.to_track = [data.bind(obj) for obj in self.geoms if self.name_to_bind in obj.name]
        if not self.to_track:
            logger.warning(
                "Tracker found no %s whose name contains %r; nothing will be recorded",
                self.mujoco_obj_to_find,
                self.name_to_bind,
            )
        for attribute in self.observable_attributes:
            per_object = self.history.setdefault(attribute, {})
            for index in range(len(self.to_track)):
                per_object.setdefault(index, [])

    def update(self, data: mujoco.MjData | None = None) -> None:
        """Append a copy of every observed attribute of every bound object.

        A tracker that was never set up records nothing. ``data`` is accepted for the tutorial
        signature; the bindings already point at the data given to ``setup``.
        """
        if self.to_track is None:
            return
        for index, bound in enumerate(self.to_track):
            for attribute in self.observable_attributes:
                self.history[attribute][index].append(np.array(getattr(bound, attribute)))

    def reset(self) -> None:
        """Empty every history list (attribute and object keys are kept)."""
        for per_object in self.history.values():
            for values in per_object.values():
                values.clear()
