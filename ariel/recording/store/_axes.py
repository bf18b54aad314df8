"""Axis labels with units, whole-number ticks and titles that fit, for the figures of `ariel
report` and `ariel compare`.

Units: the morphology descriptors' (`DESCRIPTORS`: a count of modules, metres, a ratio) and
the fitness function's own (``@fitness_function(unit="m")``; none where the function does not
say or is not installed here). Counts (generations, evaluations, modules) get integer ticks.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ariel.plugins import fitness_functions
from ariel.utils import flag_argument

if TYPE_CHECKING:
    from matplotlib.axis import Axis

__all__ = [
    "DESCRIPTORS",
    "condition_colours",
    "descriptor_label",
    "fitness_label",
    "fitness_unit",
    "fitted",
    "integer_ticks",
]

#: Morphology descriptor (and ``n_joints``) -> (its unit or what it counts, whether its values
#: are whole numbers).
DESCRIPTORS: dict[str, tuple[str, bool]] = {
    "num_modules": ("modules", True),
    "num_hinges": ("hinges", True),
    "num_bricks": ("bricks", True),
    "num_limbs": ("leaf modules", True),
    "num_core_children": ("faces of the core used", True),
    "depth": ("edges, core to deepest leaf", True),
    "branching": ("children per parent module", False),
    "joints_ratio": ("hinges / modules", False),
    "symmetry": ("score, 0 to 1", False),
    "extent_x": ("m", False),
    "extent_y": ("m", False),
    "extent_z": ("m", False),
    "n_joints": ("actuated joints", True),  # not a descriptor, a MAP-Elites measure
}


def descriptor_label(name: str) -> str:
    """``num_limbs (leaf modules)``, ``extent_x (m)``; the name alone for an unknown one."""
    unit = DESCRIPTORS.get(name, ("", False))[0]
    return f"{name} ({unit})" if unit else name


#: matplotlib's tab20 with its ten dark shades first (tab10, the colour cycle: conditions up to
#: ten look as they always did), then their light shades.
_TWENTY = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
    "#aec7e8",
    "#ffbb78",
    "#98df8a",
    "#ff9896",
    "#c5b0d5",
    "#c49c94",
    "#f7b6d2",
    "#c7c7c7",
    "#dbdb8d",
    "#9edae5",
)


def condition_colours(names: Sequence[str]) -> dict[str, str]:
    """A colour per condition (``"#rrggbb"``), one rule for `ariel compare`'s figures, the
    campaign's Rerun view and the notebooks: up to ten matplotlib's colour cycle (``C0`` ...
    ``C9``); up to twenty, then tab20's light shades; more, evenly along turbo (its near-black
    ends left out). Each condition its own: the cycle repeated gave conditions 1 and 11 one
    colour, and the notebook and the Rerun view kept repeating it.

    Args:
        names: The conditions, in their order.

    Returns:
        Condition -> colour.
    """
    names = list(names)
    if len(names) <= len(_TWENTY):
        return {name: _TWENTY[i] for i, name in enumerate(names)}
    spread = np.linspace(0.08, 0.92, len(names))
    return {name: _turbo(float(x)) for name, x in zip(names, spread, strict=True)}


def _turbo(x: float) -> str:
    """Turbo at ``x`` in [0, 1] by its published polynomial fit (within 0.08 of matplotlib's
    table in each channel): no colour map to load."""
    fits = (
        (0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943),
        (0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604),
        (0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973),
    )
    channels = [min(1.0, max(0.0, sum(c * x**k for k, c in enumerate(fit)))) for fit in fits]
    return "#" + "".join(f"{round(255 * channel):02x}" for channel in channels)


def integer_ticks(axis: Axis) -> None:
    """Ticks at whole numbers only on ``axis``: for counts.

    Args:
        axis: An x or y `matplotlib.axis.Axis` (e.g. ``ax.xaxis``); changed in place.
    """
    from matplotlib.ticker import MaxNLocator, ScalarFormatter  # lazy: heavy optional library

    # min_n_ticks=1: one whole-number tick rather than fractions on a narrow range (all 9s)
    axis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    axis.set_major_formatter(ScalarFormatter())


def fitness_unit(name: str) -> str | None:
    """The unit of fitness function ``name`` (its ``unit``), None where unknown."""
    try:
        unit = getattr(fitness_functions.get(name), "unit", None)
    except Exception:  # not installed here, or broken: a label goes without its unit
        return None
    return unit if isinstance(unit, str) and unit else None


def fitness_label(name: str, maximise: bool | None = None, *, what: str = "fitness") -> str:
    """``fitness: xy_displacement (m), higher is better``: an axis label.

    Args:
        name: The fitness function's name; ``""`` (or ``what`` itself) labels ``what`` alone.
        maximise: Whether higher fitness is better, which the label then says; None says
            nothing about the direction.
        what: The quantity, e.g. ``"best fitness"``.

    Returns:
        ``what``, then ``: name`` and the fitness function's unit in parentheses where it is
        known here, then the direction when ``maximise`` is given.

    Raises:
        TypeError: When ``name`` is not a string or ``maximise`` not True, False or None.
    """
    flag_argument("maximise", maximise, none=True, function="fitness_label")
    if not isinstance(name, str):
        raise TypeError(f"fitness_label: name must be a fitness function's name, not {name!r}")
    unit = fitness_unit(name)
    text = (what if name in ("", what) else f"{what}: {name}") + (f" ({unit})" if unit else "")
    if maximise is not None:
        text += f", {'higher' if maximise else 'lower'} is better"
    return text


def fitted(text: str, width_inches: float, fontsize: float) -> str:
    """``text`` wrapped (at its spaces) into lines that fit ``width_inches`` at ``fontsize``
    points: a title that is never clipped at the figure's edge. Line breaks in ``text`` stay."""
    # An average character of DejaVu Sans is ~0.6 of the font size wide; 0.62 leaves a margin.
    per_line = max(12, int(width_inches * 72 / (fontsize * 0.62)))
    return "\n".join(
        textwrap.fill(line, per_line, break_on_hyphens=False) or line for line in text.split("\n")
    )
