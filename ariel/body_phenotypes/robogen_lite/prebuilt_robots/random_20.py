"""A reproducible random 20-module body grown from the core's side faces."""

from __future__ import annotations

import random

import mujoco

from ariel.body_phenotypes.robogen_lite.config import ModuleFaces
from ariel.body_phenotypes.robogen_lite.modules.brick import BrickModule
from ariel.body_phenotypes.robogen_lite.modules.core import CoreModule
from ariel.body_phenotypes.robogen_lite.modules.hinge import HingeModule
from ariel.body_phenotypes.robogen_lite.modules.module import Module

__all__ = ["random_spider20"]

_HINGE_PROBABILITY = 0.6
_ROTATIONS = (0, 45, 90)


def random_spider20(seed: int | None = 1337) -> CoreModule:
    """Grow 19 random modules onto the core (20 modules in all).

    Open sites start as the core's FRONT, LEFT, BACK, RIGHT. Each new module takes a random
    open site (removing it), is a hinge with probability 0.6 (rotation 0/45/90 uniformly) or
    else a brick, gets the prefix ``m{index}`` and opens all of its own sites.

    Args:
        seed: Seed of the body's own ``random.Random(seed)``: the same seed gives the same
            body. With None the seed is drawn from Python's global ``random`` generator (so
            ``random.seed(...)`` makes it reproducible).

    Returns:
        The body's core module; its ``.spec`` is the body's ``mujoco.MjSpec``.
    """
    rng = random.Random(random.getrandbits(64) if seed is None else seed)
    core = CoreModule(index=0)
    open_sites: list[mujoco.MjsSite] = [
        core.sites[face]
        for face in (ModuleFaces.FRONT, ModuleFaces.LEFT, ModuleFaces.BACK, ModuleFaces.RIGHT)
    ]
    for index in range(1, 20):
        site = open_sites.pop(rng.randrange(len(open_sites)))
        module: Module
        if rng.random() < _HINGE_PROBABILITY:
            module = HingeModule(index=index)
            module.rotate(rng.choice(_ROTATIONS))
        else:
            module = BrickModule(index=index)
        site.attach_body(body=module.body, prefix=f"m{index}")
        open_sites.extend(module.sites.values())
    return core
