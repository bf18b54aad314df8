"""Speed work on `build` must not change what it builds: compiled model bytes are pinned.

The digests below were computed before the build path was made faster (issue 18): a sha256 of
``mj_saveModel``'s bytes of the compiled world, and of the descriptors, for a few 20-module
tree, cppn and nde bodies, on flat ground and on rugged terrain with a rotated spawn (the spawn
height comes from a collision bisection there). Run this file as a script to print them.
"""

from __future__ import annotations

import hashlib
import json
import sys

import mujoco
import numpy as np
import pytest

from ariel.body_phenotypes.robogen_lite.cppn_encoder import CPPNEncoder
from ariel.ec.genotypes.tree.operators import random_tree
from ariel.evaluation import BodySpec, EvaluationTask, _engine, build

WORLDS = {"flat": (0.0, 0.0, 0.0), "rugged": (10.0, 20.0, 30.0)}

EXPECTED: dict[str, tuple[str, str]] = {
    "tree0-flat": (
        "c6b9b68a3a409c1bd58dc536b59008ee2790021ec886529f2d7279bbdef9740b",
        "596981eb326c4abc10235c0b405a0b444cdd87814c193bf9f9e1bb5caf7cfccb",
    ),
    "tree0-rugged": (
        "32919d926c6a0d22418d772a068fdc458f6ad5a10d748090532a5d48e303665a",
        "596981eb326c4abc10235c0b405a0b444cdd87814c193bf9f9e1bb5caf7cfccb",
    ),
    "cppn0-flat": (
        "a63263c252db9708f1cd7d7b552f2eb6b1bba2194784994176025b15722a9dbe",
        "fefc261a5aca615567fcdfb5567333c42828ffcc25aa72cac1411de1fda4055b",
    ),
    "cppn0-rugged": (
        "9afd74658f3a329199a8cdae0430441426113755cfb6f5f02b7669b057992bde",
        "fefc261a5aca615567fcdfb5567333c42828ffcc25aa72cac1411de1fda4055b",
    ),
    "nde0-flat": (
        "d014b04b14e404b97525014055f67c33cb9e8b60321a2f9f6d335fb0c278ef90",
        "e87b03586af6e40dcf0a6f0791d6b5b34d4d6591733a2f2150f4e50555f00387",
    ),
    "nde0-rugged": (
        "e862d1acf75ad483222f9407de2bd7ac388c679056786583e486c019b2334005",
        "e87b03586af6e40dcf0a6f0791d6b5b34d4d6591733a2f2150f4e50555f00387",
    ),
    "tree1-flat": (
        "b4777e1cacb2c38cc19b29dc098bbf5a5682e6341e32a0337ee920b439c331c3",
        "1de7a17cdcfa25abe02a835f71b60cc5527bb73514ce19e8d793918793cdc2cb",
    ),
    "tree1-rugged": (
        "908dcd3d781a03b34524aa3810dad16d162038b6f3ebbb886234cddc894de4fb",
        "1de7a17cdcfa25abe02a835f71b60cc5527bb73514ce19e8d793918793cdc2cb",
    ),
    "cppn1-flat": (
        "71639254b286349aa4026f22d6ecf36416fa22e63438dfb7cc9465e9a66fbcd7",
        "2a6d1a7b9e12f5a32c00db088901a1d4925822b77d29cc36900209eeb3c23c9d",
    ),
    "cppn1-rugged": (
        "d6c0dca3a763901990ed50fbbbddc63a79be2acf8163b16da3e9f95fc5f99973",
        "2a6d1a7b9e12f5a32c00db088901a1d4925822b77d29cc36900209eeb3c23c9d",
    ),
    "nde1-flat": (
        "5322ba323ffb6ed56ed14cfc385d81ddbd641249280beaa03e742362800dd485",
        "414942121248073496d0ec3dcfa51eee095966b3fe81b8e68e5b47877a518e41",
    ),
    "nde1-rugged": (
        "c17a6ae627dca950c3d66c48dc59f9470b6ceb716c432bb5ba4f0a0e126d726e",
        "414942121248073496d0ec3dcfa51eee095966b3fe81b8e68e5b47877a518e41",
    ),
}


def _bodies() -> list[tuple[str, BodySpec]]:
    rng = np.random.default_rng(7)
    bodies = []
    for i in range(2):
        bodies.append(
            (f"tree{i}", BodySpec("tree", random_tree(20, rng=rng).to_dict(), {"max_modules": 20}))
        )
        cppn = CPPNEncoder(max_modules=20).random_genotype(rng)
        bodies.append((f"cppn{i}", BodySpec("cppn", cppn, {"max_modules": 20})))
        nde = rng.random((3, 64)).tolist()
        bodies.append((f"nde{i}", BodySpec("nde", nde, {"number_of_modules": 20})))
    return bodies


def _digests(body: BodySpec, world: str) -> tuple[str, str]:
    _engine._BUILD_CACHE.clear()
    task = EvaluationTask(body=body, duration=1.0, world=world, spawn_rotation=WORLDS[world])
    built = build(task)
    buffer = np.zeros(mujoco.mj_sizeModel(built.model), dtype=np.uint8)
    mujoco.mj_saveModel(built.model, None, buffer)
    model = hashlib.sha256(buffer.tobytes()).hexdigest()
    descriptors = hashlib.sha256(json.dumps(built.descriptors, sort_keys=True).encode()).hexdigest()
    return model, descriptors


CASES = [(name, body, world) for name, body in _bodies() for world in WORLDS]


@pytest.mark.parametrize(("name", "body", "world"), CASES, ids=[f"{n}-{w}" for n, _b, w in CASES])
def test_compiled_model_bytes_are_unchanged(name: str, body: BodySpec, world: str) -> None:
    assert _digests(body, world) == EXPECTED[f"{name}-{world}"]


if __name__ == "__main__":
    json.dump({f"{n}-{w}": _digests(b, w) for n, b, w in CASES}, sys.stdout, indent=4)
