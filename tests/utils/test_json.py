"""Non-finite floats on their way to JSON: the checkpoint keeps them exactly, the other
records write them as null; both are strict JSON."""

from __future__ import annotations

import json
import math

from ariel.evolution._state import from_json_safe, to_json_safe
from ariel.recording.store._files import json_text

DATA = {"best": math.inf, "scores": (1.5, math.nan, -math.inf), "nested": [{"x": 0.1}]}


def _strict(text: str) -> object:
    def refuse(token: str) -> None:
        raise AssertionError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_the_checkpoint_form_round_trips_every_float() -> None:
    back = from_json_safe(_strict(json.dumps(to_json_safe(DATA))))
    assert back["best"] == math.inf and back["scores"][2] == -math.inf
    assert math.isnan(back["scores"][1]) and back["scores"][0] == 1.5
    assert back["nested"] == [{"x": 0.1}]


def test_records_write_non_finite_floats_as_null() -> None:
    assert _strict(json_text(DATA)) == {
        "best": None,
        "scores": [1.5, None, None],
        "nested": [{"x": 0.1}],
    }
