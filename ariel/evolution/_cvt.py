"""The cells of a CVT-MAP-Elites archive (``archive = "cvt"`` of ``map_elites``).

Vassiliades, Chatzilygeroudis & Mouret, *Using centroidal Voronoi tessellations to scale up
the multidimensional archive of phenotypic elites algorithm* (IEEE TEVC 22(4), 2018): the
measure space is cut into ``cells`` regions of about equal volume, each the points nearest to
one centroid, whatever the number of measures. The centroids are made as the paper and
pyribs' ``k_means_centroids`` make them (uniform samples clustered by k-means), but by our own
Lloyd iterations, so that they are the same bit for bit on every machine and thread count
(scikit-learn's k-means sums across threads in no fixed order):

* in the measures scaled to [0, 1] by their ``ranges`` (the unit cube), so that a measure
  with a wide range (``num_limbs``, 0 to 8) does not take the cells from one with a narrow one
  (``joints_ratio``, 0 to 1); a body's cell is its nearest centroid in the same scaled space;
* ``max(10000, 20 x cells)`` samples drawn uniformly from ``derive_rng(seed, "cvt-centroids")``,
  ``cells`` distinct ones of them as the first centroids (the same stream);
* Lloyd's iterations (each sample to its nearest centroid, scipy's ``KDTree`` with the leaf
  size of ``cKDTree``, 16, on one thread; each centroid to the mean of its samples,
  ``numpy.bincount``; a centroid without samples stays) until no sample changes its centroid,
  at most `ITERATIONS` times.

The run keeps its centroids (the optimizer's checkpoint state, exact) and records them
(run.json's ``archive`` description, in the measures' units), so a resumed run and a reader
use the centroids the run used, whatever this code becomes.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import KDTree

from ariel.evolution._seeds import derive_rng

__all__ = [
    "ARCHIVES",
    "DEFAULT_CELLS",
    "ITERATIONS",
    "check_archive",
    "in_measure_units",
    "scaled",
    "unit_centroids",
]

#: The kinds of archive ``map_elites`` keeps (its ``archive`` option).
ARCHIVES = ("grid", "cvt")
#: Cells of a CVT archive when ``cells`` is not given (a 8 x 8 grid's number).
DEFAULT_CELLS = 64
#: The most cells a CVT may have: pyribs' own examples use 10,000.
MAX_CVT_CELLS = 10_000
#: Lloyd's iterations at most.
ITERATIONS = 50


def check_archive(archive: object, bins: object, cells: object) -> int | None:
    """The ``archive``, ``bins`` and ``cells`` options checked together: the CVT's number of
    cells (`DEFAULT_CELLS` when not given), None for a grid. ``bins`` is a grid's option and
    ``cells`` a CVT's; each is an error with the other archive."""
    if archive not in ARCHIVES:
        raise ValueError(f"archive must be one of {', '.join(ARCHIVES)}, got {archive!r}")
    if archive == "grid":
        if cells is not None:
            raise ValueError("cells is an option of archive = 'cvt'; a grid takes bins")
        return None
    if bins is not None:
        raise ValueError("bins is an option of archive = 'grid'; a CVT takes cells")
    cells = DEFAULT_CELLS if cells is None else cells
    if isinstance(cells, bool) or not isinstance(cells, int) or cells < 1:
        raise ValueError(f"cells must be an integer >= 1 (the CVT's centroids), got {cells!r}")
    if cells > MAX_CVT_CELLS:  # its centroids' k-means: ~4 s for 10,000 cells, minutes beyond
        raise ValueError(f"cells must be at most {MAX_CVT_CELLS:,}, got {cells:,}")
    return cells


@functools.lru_cache(maxsize=8)
def unit_centroids(seed: int, cells: int, dimensions: int) -> np.ndarray:
    """The ``(cells, dimensions)`` centroids of a CVT of the unit cube for run ``seed`` (see
    the module docstring): the same for the same arguments, on any machine. Kept for the
    next call (read-only): a run makes its archive twice, when `prepare_run` checks the
    options and when the run starts."""
    rng = derive_rng(seed, "cvt-centroids")
    samples = rng.random((max(10_000, 20 * cells), dimensions))
    centroids = samples[np.sort(rng.choice(len(samples), cells, replace=False))]
    labels = None
    for _ in range(ITERATIONS):
        _, nearest = KDTree(centroids, leafsize=16).query(samples, workers=1)
        if labels is not None and np.array_equal(nearest, labels):
            break
        labels = nearest
        counts = np.bincount(labels, minlength=cells)
        for d in range(dimensions):
            sums = np.bincount(labels, weights=samples[:, d], minlength=cells)
            centroids[:, d] = np.where(counts > 0, sums / np.maximum(counts, 1), centroids[:, d])
    centroids.flags.writeable = False
    return centroids


def scaled(values: ArrayLike, ranges: Sequence[tuple[float, float]]) -> np.ndarray:
    """Measure values scaled to [0, 1] by their ranges (a value outside: the edge)."""
    low, high = np.array(ranges, dtype=np.float64).T
    return np.clip((np.asarray(values, dtype=np.float64) - low) / (high - low), 0.0, 1.0)


def in_measure_units(
    centroids: np.ndarray, ranges: Sequence[tuple[float, float]]
) -> list[list[float]]:
    """Unit-cube centroids in the measures' units (as the archive description gives them)."""
    low, high = np.array(ranges, dtype=np.float64).T
    return (low + centroids * (high - low)).tolist()
