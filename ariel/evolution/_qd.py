"""What readers of a quality-diversity run share with `MapElites` and `NoveltySearch`, without
pyribs: the default measures and their ranges, a body's measure values, the ``qd_offset``
option and the QD metrics (`archive_quality`; see `ariel.evolution._map_elites`). Readers of
runs import this module (``load_run``'s archive quality, the archive's description); the
optimizers that keep a pyribs archive are loaded only when a run uses them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from ariel.evolution._state import Body

__all__ = [
    "DEFAULT_MEASURES",
    "DEFAULT_RANGES",
    "archive_quality",
    "body_measures",
    "elite_gain",
    "resolve_qd_offset",
]

#: The archive's axes when ``measures`` is not given.
DEFAULT_MEASURES = ("num_limbs", "joints_ratio")
#: Ranges of the measures most worth mapping (others must be given).
DEFAULT_RANGES: dict[str, tuple[float, float]] = {
    "num_modules": (0.0, 20.0),
    "num_hinges": (0.0, 12.0),
    "num_bricks": (0.0, 12.0),
    "num_limbs": (0.0, 8.0),
    "num_core_children": (0.0, 4.0),
    "depth": (0.0, 10.0),
    "branching": (0.0, 1.0),
    "joints_ratio": (0.0, 1.0),
    "symmetry": (0.0, 1.0),
    "n_joints": (0.0, 12.0),
}


def body_measures(body: Body, measures: Sequence[str]) -> list[float]:
    """``body``'s value of each measure (a descriptor, or ``n_joints``)."""
    values = {**body.descriptors, "n_joints": body.n_joints}
    return [float(values.get(name, math.nan)) for name in measures]


def resolve_qd_offset(qd_offset: object, maximise: bool) -> float:
    """The ``qd_offset`` option checked: a finite number; 0 for a maximised fitness when not
    given. A minimised fitness has no natural worst value, so it must be given."""
    if qd_offset is None:
        if maximise:
            return 0.0
        raise ValueError(
            "qd_offset must be given for a minimised fitness: a fitness no elite is worse "
            "than, which counts as nothing in the QD-score (e.g. the distance to the target "
            "at the start)"
        )
    if isinstance(qd_offset, bool) or not isinstance(qd_offset, int | float):
        raise ValueError(f"qd_offset must be a number, got {qd_offset!r}")
    if not math.isfinite(qd_offset):
        raise ValueError(f"qd_offset must be finite, got {qd_offset!r}")
    return float(qd_offset)


def elite_gain(fitness: float, qd_offset: float, maximise: bool) -> float:
    """An elite's share of the QD-score: how much better than ``qd_offset`` it is, never < 0
    (pyribs' objective - qd_score_offset, the objective being fitness or -fitness)."""
    gain = fitness - qd_offset if maximise else qd_offset - fitness
    return max(0.0, float(gain))


def archive_quality(
    fitness: Sequence[float], cells: int, qd_offset: float, maximise: bool
) -> dict[str, float]:
    """The QD metrics of an archive whose elites have ``fitness``, of ``cells`` cells:
    ``coverage``, ``qd_score`` and ``norm_qd_score`` (see the module docstring). What the run
    prints and what `ariel.recording.load_run` computes from the ``archive`` table."""
    score = math.fsum(elite_gain(f, qd_offset, maximise) for f in fitness)
    return {
        "coverage": len(fitness) / cells,
        "qd_score": score,
        "norm_qd_score": score / cells,
    }
