"""Registration curves: which frames of two (or n) clips correspond, and how to line them up.

Seed 000 §3.1 and seed 004 §4–5 (after Kovar & Gleicher 2003), one module per step:

1. :mod:`.grid` — :func:`distance_grid`: for every frame pair, the weighted squared distance
   between the point clouds of joint positions over a ``2L+1``-frame window, minimised over a
   rotation about the vertical axis and a floor translation (closed form, seed 000 Eq. 3–5).
2. :mod:`.paths` — :func:`find_path`: a minimal-cost path through the grid: continuity,
   monotonicity and a slope limit (seed 000 Eq. 6), fixed corners or a fixed start with a free
   end on the boundary (seed 004 §4.3: Kovar & Gleicher's least-total path to each boundary cell,
   then the least average, or the least average over every path); ``dp`` (dynamic programming,
   exact for each), ``brute``, ``greedy`` and ``threshold`` (Sako's alternatives, seed 004 §5.2).
3. :mod:`.curves` — :func:`timewarp_curve`: a strictly increasing cubic B-spline fitted to the
   path (seed 004 §5.4), or :func:`discrete_timewarp` (Sako's insertion/deletion, Table 1).
4. :mod:`.align` — :func:`alignment_curve`: the 2D rigid transform that moves clip B onto clip A
   at every timewarp sample, smoothed.
5. :mod:`.pairs` — :func:`register` (two clips); :mod:`.nway` — :func:`register_many` (n clips to
   a reference, one n-dimensional B-spline, seed 000); :mod:`.blendability` — whether a pair can be
   blended at all (seed 004 §7.2).

World is Z-up: the floor is the ``(x, y)`` plane, so seed 000's ``(x, z)`` are our ``(x, y)``.
"""

from .align import alignment_curve
from .blendability import Blendability, blendability, self_similarity
from .curves import TimewarpCurve, discrete_timewarp, timewarp_curve
from .grid import DEFAULT_WINDOW, MAX_CELLS, Grid, check_grid_size, distance_grid, joint_weights, rigid_2d
from .nway import Registration, choose_reference, combine, register_many
from .pairs import PairRegistration, positions_of, register
from .paths import (
    BRUTE_TIME_LIMIT_S,
    FREE_END_RULES,
    METHODS,
    NUMBA_MIN_CELLS,
    Path,
    SlopeLimit,
    auto_start,
    brute_path,
    check_path,
    count_paths,
    dp_path,
    find_path,
    greedy_path,
    least_mean_path,
    threshold_path,
)

__all__ = [
    "BRUTE_TIME_LIMIT_S",
    "Blendability",
    "DEFAULT_WINDOW",
    "FREE_END_RULES",
    "MAX_CELLS",
    "METHODS",
    "NUMBA_MIN_CELLS",
    "Grid",
    "PairRegistration",
    "Path",
    "Registration",
    "SlopeLimit",
    "TimewarpCurve",
    "alignment_curve",
    "auto_start",
    "blendability",
    "brute_path",
    "check_grid_size",
    "check_path",
    "choose_reference",
    "combine",
    "count_paths",
    "discrete_timewarp",
    "distance_grid",
    "dp_path",
    "find_path",
    "greedy_path",
    "joint_weights",
    "least_mean_path",
    "positions_of",
    "register",
    "register_many",
    "rigid_2d",
    "self_similarity",
    "threshold_path",
    "timewarp_curve",
]
