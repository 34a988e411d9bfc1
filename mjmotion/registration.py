"""Registration curves: which frames of two (or n) clips correspond, and how to line them up.

Seed 000 §3.1 and seed 004 §4–5 (after Kovar & Gleicher 2003):

1. :func:`distance_grid` — for every frame pair, the weighted squared distance between the
   point clouds of joint positions over a ``2L+1``-frame window, minimised over a rotation about
   the vertical axis and a floor translation (closed form, seed 000 Eq. 3–5).
2. :func:`find_path` — a minimal-cost path through the grid: continuity, monotonicity and a
   slope limit (seed 000 Eq. 6), fixed corners or a fixed start with a free end on the boundary
   (least average cell cost, seed 004 §4.3); ``dp`` (dynamic programming) is exact, ``brute``,
   ``greedy`` and ``threshold`` are Sako's alternatives (seed 004 §5.2).
3. :func:`timewarp_curve` — a strictly increasing cubic B-spline fitted to the path (seed 004
   §5.4), or :func:`discrete_timewarp` (Sako's insertion/deletion, seed 004 Table 1).
4. :func:`alignment_curve` — the 2D rigid transform that moves clip B onto clip A at every
   timewarp sample, smoothed.
5. :func:`register` (two clips) and :func:`register_many` (n clips to a reference, seed 000).

World is Z-up: the floor is the ``(x, y)`` plane, so seed 000's ``(x, z)`` are our ``(x, y)``.
"""

from __future__ import annotations

import functools
import heapq
import math
import re
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import interpolate, optimize
from scipy.ndimage import gaussian_filter1d

from .errors import MjmotionError
from .skeleton import Motion, Skeleton

#: Default half-window L: clouds of 2L+1 = 5 frames (seed 000 §3.1, Kovar & Gleicher).
DEFAULT_WINDOW = 2
#: Largest grid (cells) built in memory: 5000 × 5000 float64 is 200 MB plus the DP's int8 tables.
MAX_CELLS = 25_000_000
#: Joints that carry no gait information in our clips (fingers, eyes hold constant poses).
_UNWEIGHTED = re.compile(r"finger|thumb|index|mid\d|ring|pinky|eye|carpal|nub", re.IGNORECASE)

METHODS = ("dp", "greedy", "threshold", "brute")
#: Grids from this size use the Numba DP kernel by default (below it NumPy's is quicker than loading Numba).
NUMBA_MIN_CELLS = 2_000_000


# --------------------------------------------------------------------------------------------
# 1. distance grid
# --------------------------------------------------------------------------------------------
def joint_weights(skeleton: Skeleton, weights: dict[str, float] | None = None) -> np.ndarray:
    """Per-joint weights ``(J,)``: 1 for body joints, 0 for fingers and eyes, overridden by ``weights``.

    ``weights`` maps joint names to non-negative numbers (unknown names are an error).
    """
    w = np.array([0.0 if _UNWEIGHTED.search(n) else 1.0 for n in skeleton.names])
    for name, value in (weights or {}).items():
        if not (np.isfinite(value) and value >= 0):
            raise MjmotionError(f"joint weight for {name!r} must be a non-negative number, got {value}")
        w[skeleton.index(name)] = float(value)
    if w.sum() <= 0:
        raise MjmotionError("every joint weight is zero; at least one joint must count in the distance")
    return w


def _window_clouds(positions: np.ndarray, window: int, weights: np.ndarray) -> dict[str, np.ndarray]:
    """Weighted, horizontally centred window clouds of one clip.

    ``positions: (T, J, 3)`` → features ``(T, K·J)`` per axis (already multiplied by √w, the
    horizontal ones centred on each window's weighted mean), the means ``(T, 2)`` and the
    weighted squared norms ``(T,)``. Windows are clamped at the clip's ends (edge frames repeat).
    """
    t, j, _ = positions.shape
    k = 2 * window + 1
    idx = np.clip(np.arange(t)[:, None] + np.arange(-window, window + 1)[None, :], 0, t - 1)
    cloud = positions[idx].reshape(t, k * j, 3)  # (T, K·J, 3)
    w = np.tile(weights, k)
    w = w / w.sum()  # Σ w = 1 over the cloud (seed 004 §4.2.1)
    mean = np.einsum("p,tpc->tc", w, cloud[:, :, :2])
    sw = np.sqrt(w)
    cx = (cloud[:, :, 0] - mean[:, 0:1]) * sw
    cy = (cloud[:, :, 1] - mean[:, 1:2]) * sw
    cz = cloud[:, :, 2] * sw
    return {
        "x": cx,
        "y": cy,
        "z": cz,
        "mean": mean,
        "hh": np.einsum("tp,tp->t", cx, cx) + np.einsum("tp,tp->t", cy, cy),
        "zz": np.einsum("tp,tp->t", cz, cz),
    }


@dataclass(frozen=True)
class Grid:
    """Frame-to-frame distances of two clips.

    Attributes:
        cost: ``(nA, nB)`` float64, m² — weighted mean squared point distance after the best 2D
            rigid alignment (seed 000 Eq. 2; weights sum to one over each cloud).
        window: the half-window ``L`` (clouds of ``2L+1`` frames).
    """

    cost: np.ndarray
    window: int


def check_grid_size(n_a: int, n_b: int, max_cells: int = MAX_CELLS) -> None:
    """Refuse grids that would not fit in memory, saying what to do instead."""
    cells = n_a * n_b
    if cells > max_cells:
        factor = math.ceil(math.sqrt(cells / max_cells))
        raise MjmotionError(
            f"registering {n_a} × {n_b} frames needs a {cells:,}-cell grid (about {cells * 11 / 1e9:.1f} GB "
            f"with the path search), above the {max_cells:,}-cell limit; register shorter excerpts "
            f"(--frames) or resample both clips at least {factor}× lower (--fps)"
        )


def distance_grid(
    positions_a: np.ndarray,
    positions_b: np.ndarray,
    weights: np.ndarray | None = None,
    window: int = DEFAULT_WINDOW,
    max_cells: int = MAX_CELLS,
) -> Grid:
    """The registration grid (seed 000 §3.1 Eq. 2–5), every sum a matrix product.

    ``positions_a: (nA, J, 3)``, ``positions_b: (nB, J, 3)`` world joint positions (metres);
    ``weights: (J,)`` non-negative (default 1). Cell ``[i, j]`` is
    ``min_{θ,t} Σ_k w_k ‖p_k − (R_θ p'_k + t)‖²`` over the windows around frame ``i`` of A and
    frame ``j`` of B. After centring each window on its weighted mean, with
    ``a = Σ w (x x' + y y')`` and ``b = Σ w (y x' − x y')`` the optimum is ``θ = atan2(b, a)`` and
    the horizontal residual ``Σ w|c|² + Σ w|c'|² − 2√(a² + b²)``; heights add ``Σ w (z − z')²``.
    """
    pa, pb = np.asarray(positions_a, dtype=float), np.asarray(positions_b, dtype=float)
    if pa.ndim != 3 or pb.ndim != 3 or pa.shape[1:] != pb.shape[1:] or pa.shape[2] != 3:
        raise MjmotionError(f"distance_grid needs (T, J, 3) positions with equal J, got {pa.shape} and {pb.shape}")
    if window < 0:
        raise MjmotionError(f"the window half-width must be ≥ 0 frames, got {window}")
    check_grid_size(len(pa), len(pb), max_cells)
    w = np.ones(pa.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    keep = w > 0  # joints of weight zero add nothing but work
    ca, cb = _window_clouds(pa[:, keep], window, w[keep]), _window_clouds(pb[:, keep], window, w[keep])
    # a and b from one product: [[x, y], [y, −x]]_A · [x, y]_Bᵀ
    right = np.concatenate([cb["x"], cb["y"]], axis=1)
    left = np.block([[ca["x"], ca["y"]], [ca["y"], -ca["x"]]])
    ab = left @ right.T
    a, b = ab[: len(pa)], ab[len(pa) :]
    zz = ca["z"] @ cb["z"].T
    cost = ca["hh"][:, None] + cb["hh"][None, :] - 2.0 * np.hypot(a, b)
    cost += ca["zz"][:, None] + cb["zz"][None, :] - 2.0 * zz
    np.maximum(cost, 0.0, out=cost)  # round-off can dip a hair below zero
    return Grid(cost=cost, window=window)


def rigid_2d(cloud_a: np.ndarray, cloud_b: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Best floor transforms moving clouds B onto clouds A (seed 000 Eq. 3–5).

    ``cloud_a, cloud_b: (N, P, 3)`` corresponding points, ``weights: (P,)`` → ``(N, 3)`` rows
    ``[theta, tx, ty]`` such that ``Rz(theta) p' + (tx, ty)`` best matches ``p`` on the floor.
    """
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    ma = np.stack([cloud_a[:, :, 0] @ w, cloud_a[:, :, 1] @ w], axis=1)  # (N, 2) weighted means
    mb = np.stack([cloud_b[:, :, 0] @ w, cloud_b[:, :, 1] @ w], axis=1)
    ax, ay = cloud_a[:, :, 0] - ma[:, :1], cloud_a[:, :, 1] - ma[:, 1:]
    bx, by = cloud_b[:, :, 0] - mb[:, :1], cloud_b[:, :, 1] - mb[:, 1:]
    a = (ax * bx + ay * by) @ w
    b = (ay * bx - ax * by) @ w
    theta = np.arctan2(b, a)
    c, s = np.cos(theta), np.sin(theta)
    tx = ma[:, 0] - (c * mb[:, 0] - s * mb[:, 1])
    ty = ma[:, 1] - (s * mb[:, 0] + c * mb[:, 1])
    return np.stack([theta, tx, ty], axis=1)


# --------------------------------------------------------------------------------------------
# 2. minimal-cost path
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SlopeLimit:
    """At most ``horizontal`` consecutive steps advancing only B and ``vertical`` advancing only A."""

    horizontal: int
    vertical: int

    @staticmethod
    def default(n_a: int, n_b: int) -> SlopeLimit:
        """Seed 000 Eq. 6, ``W_h = min(1.5·width/height, 2)`` (width = frames of B), rounded up.

        Eq. 6 gives fractions; the ceiling gives equal-length clips W = 2 (Kovar & Gleicher's
        recommended 2–3) and still lets the short axis take single steps.
        """
        return SlopeLimit(
            horizontal=int(math.ceil(min(1.5 * n_b / n_a, 2.0))),
            vertical=int(math.ceil(min(1.5 * n_a / n_b, 2.0))),
        )

    @staticmethod
    def of(w: int | None, n_a: int, n_b: int) -> SlopeLimit:
        if w is None:
            return SlopeLimit.default(n_a, n_b)
        if int(w) != w or w < 0:
            raise MjmotionError(f"the slope limit must be a whole number of steps ≥ 0, got {w}")
        return SlopeLimit(int(w), int(w))


@dataclass(frozen=True)
class Path:
    """A path through the grid.

    Attributes:
        cells: ``(P, 2)`` int, ``[i, j]`` frame of A and frame of B, each step ``(1,1)``,
            ``(1,0)`` or ``(0,1)``.
        cost: sum of the visited cells' costs (m²).
        method: which search found it.
    """

    cells: np.ndarray
    cost: float
    method: str = "dp"

    @property
    def mean_cost(self) -> float:
        return self.cost / len(self.cells)


def _end_objective(total: np.ndarray, length: np.ndarray) -> np.ndarray:
    return total / np.maximum(length, 1)


def check_path(cells: np.ndarray, slope: SlopeLimit) -> None:
    """Raise ``AssertionError`` unless ``cells`` is continuous, monotone and within the slope limit."""
    steps = np.diff(cells, axis=0)
    ok = {(1, 1), (1, 0), (0, 1)}
    assert all(tuple(s) in ok for s in steps), "path steps must be (1,1), (1,0) or (0,1)"
    for kind, limit in (((1, 0), slope.vertical), ((0, 1), slope.horizontal)):
        run = 0
        for s in steps:
            run = run + 1 if tuple(s) == kind else 0
            assert run <= limit, f"more than {limit} consecutive {kind} steps"


def _reachable(di: int, dj: int, run_h: int, run_v: int, slope: SlopeLimit) -> bool:
    """Whether ``(di, dj)`` more steps can be made to the corner given the current runs.

    Diagonals first is optimal: the ``|di − dj|`` straight steps fill the ``min(di, dj) + 1`` gaps
    between diagonals, the first gap continuing the current run.
    """
    if dj >= di:
        return dj - di <= slope.horizontal * (di + 1) - run_h
    return di - dj <= slope.vertical * (dj + 1) - run_v


def _dp_tables_numpy(c: np.ndarray, wv: int, wh: int, bp_dtype) -> tuple[np.ndarray, ...]:
    """Row-by-row NumPy DP (see :func:`dp_path`): back-pointers and the boundary values."""
    n_a, n_b = c.shape
    s_n = 1 + wv + wh  # state 0 = D, 1..wv = V_r, wv+1..wv+wh = H_r
    not_v = np.r_[0, np.arange(1 + wv, s_n)]
    not_h = np.arange(0, 1 + wv)
    cols = np.arange(n_b)
    bp_d = np.zeros((n_a, n_b), dtype=bp_dtype)
    bp_v = np.zeros((n_a, n_b), dtype=bp_dtype)
    bp_h = np.zeros((n_a, n_b), dtype=bp_dtype)
    last_col = np.full((n_a, s_n), np.inf)
    last_col_len = np.zeros((n_a, s_n))
    prev, prev_len = np.full((s_n, n_b), np.inf), np.zeros((s_n, n_b))
    for i in range(n_a):
        ci = c[i]
        cur = np.full((s_n, n_b), np.inf)
        cur_len = np.zeros((s_n, n_b))
        if i == 0:
            cur[0, 0] = ci[0]
            cur_len[0, 0] = 1
        else:
            k = np.argmin(prev, axis=0)
            cur[0, 1:] = ci[1:] + prev[k, cols][:-1]
            cur_len[0, 1:] = prev_len[k, cols][:-1] + 1
            bp_d[i, 1:] = k[:-1]
            if wv:
                kv = np.argmin(prev[not_v], axis=0)
                cur[1] = ci + prev[not_v][kv, cols]
                cur_len[1] = prev_len[not_v][kv, cols] + 1
                bp_v[i] = not_v[kv]
                cur[2 : 1 + wv] = ci + prev[1:wv]
                cur_len[2 : 1 + wv] = prev_len[1:wv] + 1
        if wh:
            kh = np.argmin(cur[not_h], axis=0)
            cur[1 + wv, 1:] = ci[1:] + cur[not_h][kh, cols][:-1]
            cur_len[1 + wv, 1:] = cur_len[not_h][kh, cols][:-1] + 1
            bp_h[i, 1:] = not_h[kh][:-1]
            for r in range(2, wh + 1):
                cur[wv + r, 1:] = ci[1:] + cur[wv + r - 1, :-1]
                cur_len[wv + r, 1:] = cur_len[wv + r - 1, :-1] + 1
        last_col[i] = cur[:, -1]
        last_col_len[i] = cur_len[:, -1]
        prev, prev_len = cur, cur_len
    return bp_d, bp_v, bp_h, prev, prev_len, last_col, last_col_len


@functools.lru_cache(maxsize=1)
def _dp_tables_numba():
    """The same DP as one compiled loop over cells (Numba), or ``None`` without Numba."""
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=True, nogil=True)
    def tables(c, wv, wh, bp_d, bp_v, bp_h):  # pragma: no cover - compiled
        n_a, n_b = c.shape
        s_n = 1 + wv + wh
        inf = np.inf
        prev = np.full((n_b, s_n), inf)  # [column, state]: a cell's states are contiguous
        prev_len = np.zeros((n_b, s_n))
        cur = np.full((n_b, s_n), inf)
        cur_len = np.zeros((n_b, s_n))
        # per finished cell: the best state overall (for D), without V (for V_1), without H (for H_1)
        p_all = np.zeros(n_b, np.int64)
        p_nv = np.zeros(n_b, np.int64)
        c_all = np.zeros(n_b, np.int64)
        c_nv = np.zeros(n_b, np.int64)
        c_nh = np.zeros(n_b, np.int64)
        last_col = np.full((n_a, s_n), inf)
        last_col_len = np.zeros((n_a, s_n))
        for i in range(n_a):
            for j in range(n_b):
                cij = c[i, j]
                for s in range(s_n):
                    cur[j, s] = inf
                    cur_len[j, s] = 0.0
                if i == 0 and j == 0:
                    cur[0, 0] = cij
                    cur_len[0, 0] = 1.0
                if i > 0 and j > 0:  # diagonal from any state
                    k = p_all[j - 1]
                    cur[j, 0] = cij + prev[j - 1, k]
                    cur_len[j, 0] = prev_len[j - 1, k] + 1.0
                    bp_d[i, j] = k
                if i > 0 and wv > 0:  # first A-only step: from D or any H
                    k = p_nv[j]
                    cur[j, 1] = cij + prev[j, k]
                    cur_len[j, 1] = prev_len[j, k] + 1.0
                    bp_v[i, j] = k
                    for r in range(2, wv + 1):
                        cur[j, r] = cij + prev[j, r - 1]
                        cur_len[j, r] = prev_len[j, r - 1] + 1.0
                if j > 0 and wh > 0:  # first B-only step: from D or any V
                    k = c_nh[j - 1]
                    cur[j, 1 + wv] = cij + cur[j - 1, k]
                    cur_len[j, 1 + wv] = cur_len[j - 1, k] + 1.0
                    bp_h[i, j] = k
                    for r in range(2, wh + 1):
                        cur[j, wv + r] = cij + cur[j - 1, wv + r - 1]
                        cur_len[j, wv + r] = cur_len[j - 1, wv + r - 1] + 1.0
                # the cell's summaries, first minimum in state order (as NumPy's argmin)
                k_all, k_nh = 0, 0
                for s in range(1, 1 + wv):
                    if cur[j, s] < cur[j, k_nh]:
                        k_nh = s
                k_all = k_nh
                k_nv = 0
                for s in range(1 + wv, s_n):
                    if cur[j, s] < cur[j, k_all]:
                        k_all = s
                    if cur[j, s] < cur[j, k_nv]:
                        k_nv = s
                c_all[j], c_nv[j], c_nh[j] = k_all, k_nv, k_nh
            for s in range(s_n):
                last_col[i, s] = cur[n_b - 1, s]
                last_col_len[i, s] = cur_len[n_b - 1, s]
            prev, cur = cur, prev
            prev_len, cur_len = cur_len, prev_len
            p_all, c_all = c_all, p_all
            p_nv, c_nv = c_nv, p_nv
        return prev.T.copy(), prev_len.T.copy(), last_col, last_col_len

    return tables


def dp_path(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool = True,
    start: tuple[int, int] = (0, 0),
    backend: str = "auto",
) -> Path:
    """Exact minimal-cost path by dynamic programming over (cell, run) states.

    States at a cell: arrived diagonally (``D``), by the r-th consecutive A-only step
    (``V_r``, r ≤ W_v) or by the r-th consecutive B-only step (``H_r``, r ≤ W_h); the slope
    limit is part of the state, so the optimum is exact. ``free_end``: end on the last row or
    column, at the boundary cell whose cheapest path has the least average cost (seed 004 §4.3);
    otherwise end at the far corner. ``backend``: ``"numpy"`` (one vectorised pass per row: ``D``
    and ``V`` from the previous row, ``H_r`` by shifts within the row), ``"numba"`` (a compiled
    loop over cells, measured faster in benchmarks/bench_registration.py) or ``"auto"`` (Numba
    when installed and the grid has at least :data:`NUMBA_MIN_CELLS` cells or Numba is loaded).
    """
    c = np.ascontiguousarray(np.asarray(cost, dtype=float)[start[0] :, start[1] :])
    n_a, n_b = c.shape
    wv, wh = slope.vertical, slope.horizontal
    bp_dtype = np.int8 if 1 + wv + wh <= 127 else np.int32
    # Numba's import and cache load cost ~0.3–1 s once, so "auto" takes it only where it pays:
    # big grids, or a process that has loaded it already
    use_numba = backend == "numba" or (backend == "auto" and (c.size >= NUMBA_MIN_CELLS or "numba" in sys.modules))
    kernel = _dp_tables_numba() if use_numba else None
    if backend == "numba" and kernel is None:
        raise MjmotionError("the numba DP backend needs numba (pip install numba)")
    if backend not in ("auto", "numba", "numpy"):
        raise MjmotionError(f"unknown DP backend {backend!r}; expected auto, numba or numpy")
    if kernel is not None:
        bp_d, bp_v, bp_h = (np.zeros((n_a, n_b), dtype=bp_dtype) for _ in range(3))
        prev, prev_len, last_col, last_col_len = kernel(c, wv, wh, bp_d, bp_v, bp_h)
    else:
        bp_d, bp_v, bp_h, prev, prev_len, last_col, last_col_len = _dp_tables_numpy(c, wv, wh, bp_dtype)
    if free_end:
        # per boundary cell its cheapest path (any state), then the least average (seed 004 §4.3)
        cands = []
        for vals, lens, cell in ((prev.T, prev_len.T, lambda k: (n_a - 1, k)), (last_col, last_col_len, lambda k: (k, n_b - 1))):
            s_best = np.argmin(vals, axis=1)
            tot = vals[np.arange(len(vals)), s_best]
            obj = _end_objective(tot, lens[np.arange(len(vals)), s_best])
            k = int(np.argmin(obj))
            cands.append((obj[k], cell(k), int(s_best[k]), tot[k]))
        _, (i, j), s, total = min(cands, key=lambda c: c[0])
    else:
        s = int(np.argmin(prev[:, -1]))
        i, j = n_a - 1, n_b - 1
        total = prev[s, -1]
    if not np.isfinite(total):
        raise MjmotionError(
            f"no path joins the corners of a {n_a} × {n_b}-frame grid within the slope limit "
            f"(W_h={wh}, W_v={wv}: at most {wv + 1} frames of A per frame of B and {wh + 1} of B per frame of A); "
            "raise --slope-limit or register with a free end"
        )
    cells = [(i, j)]
    while (i, j) != (0, 0):
        if s == 0:
            s, i, j = int(bp_d[i, j]), i - 1, j - 1
        elif s <= wv:
            s, i = (int(bp_v[i, j]) if s == 1 else s - 1), i - 1
        else:
            s, j = (int(bp_h[i, j]) if s == 1 + wv else s - 1), j - 1
        cells.append((i, j))
    cells_arr = np.array(cells[::-1], dtype=int) + np.asarray(start, dtype=int)
    return Path(cells=cells_arr, cost=float(total), method="dp")


def _moves(run_h: int, run_v: int, slope: SlopeLimit) -> list[tuple[int, int, int, int]]:
    """Allowed steps ``(di, dj, new_run_h, new_run_v)``, diagonal first (Sako's shorter-path preference)."""
    out = [(1, 1, 0, 0)]
    if run_v < slope.vertical:
        out.append((1, 0, 0, run_v + 1))
    if run_h < slope.horizontal:
        out.append((0, 1, run_h + 1, 0))
    return out


def _search(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool,
    start: tuple[int, int],
) -> Path:
    """Depth-first enumeration of every path (Sako's brute-force recursion, seed 004 Fig. 13).

    Tracks, per end cell, the cheapest path; ``free_end`` then picks the least average cost like
    :func:`dp_path`.
    """
    n_a, n_b = cost.shape
    end_best: dict[tuple[int, int], tuple[float, tuple]] = {}
    si, sj = start
    stack: list[tuple[int, int, int, int, float, tuple]] = [(si, sj, 0, 0, float(cost[si, sj]), ((si, sj),))]
    while stack:
        i, j, rh, rv, total, path = stack.pop()
        on_end = (i == n_a - 1 or j == n_b - 1) if free_end else (i == n_a - 1 and j == n_b - 1)
        if on_end:
            old = end_best.get((i, j))
            if old is None or total < old[0]:
                end_best[(i, j)] = (total, path)
        children: list[tuple[int, int, int, int, float, tuple]] = []
        for di, dj, nrh, nrv in _moves(rh, rv, slope):
            ni, nj = i + di, j + dj
            if ni >= n_a or nj >= n_b:
                continue
            if not free_end and not _reachable(n_a - 1 - ni, n_b - 1 - nj, nrh, nrv, slope):
                continue
            children.append((ni, nj, nrh, nrv, total + float(cost[ni, nj]), path + ((ni, nj),)))
        stack.extend(reversed(children))  # pop order: diagonal, then the straight steps
    if not end_best:
        raise MjmotionError(f"no path joins the corners of a {n_a} × {n_b} grid within the slope limit")
    best = min(end_best.values(), key=lambda v: v[0] / len(v[1]) if free_end else v[0])
    return Path(cells=np.array(best[1], dtype=int), cost=best[0])


def _pruned_search(cost: np.ndarray, slope: SlopeLimit, free_end: bool, start: tuple[int, int], prune_above: float, max_nodes: int) -> Path:
    """Sako's recursion with an area threshold, expanding partial paths in order of progress.

    Cells costlier than ``prune_above`` are never entered. Partial paths are expanded by
    increasing ``i + j`` (ties: diagonal-first, Sako's shorter-path preference) and a path
    reaching a (cell, run) state no cheaper than an earlier one is dropped, so every state is
    expanded once with its cheapest cost; Sako's depth-first order re-expands states and is
    exponential in the worst case (her Table 4: 21–36 s).
    """
    n_a, n_b = cost.shape
    si, sj = start
    if cost[si, sj] > prune_above:
        raise MjmotionError("the start cell is above the area threshold; raise the threshold")
    best: dict[tuple[int, int, int, int], tuple[float, int, tuple | None]] = {(si, sj, 0, 0): (float(cost[si, sj]), 1, None)}
    heap = [(si + sj, si, sj, 0, 0)]
    end_best: dict[tuple[int, int], tuple[float, int, tuple]] = {}
    nodes = 0
    while heap:
        _, i, j, rh, rv = heapq.heappop(heap)
        key = (i, j, rh, rv)
        total, length, _ = best[key]
        nodes += 1
        if nodes > max_nodes:
            raise MjmotionError(
                f"the threshold search expanded more than {max_nodes:,} partial paths on a {n_a} × {n_b} grid; "
                "use --method dp (exact and fast) or lower the area threshold"
            )
        on_end = (i == n_a - 1 or j == n_b - 1) if free_end else (i == n_a - 1 and j == n_b - 1)
        if on_end and ((i, j) not in end_best or total < end_best[(i, j)][0]):
            end_best[(i, j)] = (total, length, key)
        for di, dj, nrh, nrv in _moves(rh, rv, slope):
            ni, nj = i + di, j + dj
            if ni >= n_a or nj >= n_b or cost[ni, nj] > prune_above:
                continue
            if not free_end and not _reachable(n_a - 1 - ni, n_b - 1 - nj, nrh, nrv, slope):
                continue
            nt = total + float(cost[ni, nj])
            nkey = (ni, nj, nrh, nrv)
            old = best.get(nkey)
            if old is not None and old[0] <= nt:
                continue
            if old is None:
                heapq.heappush(heap, (ni + nj, ni, nj, nrh, nrv))
            best[nkey] = (nt, length + 1, key)
    if not end_best:
        raise MjmotionError("no path reaches the end under the area threshold; raise the threshold or use --method dp")
    total, length, last = min(end_best.values(), key=lambda v: v[0] / v[1] if free_end else v[0])
    cells = []
    node: tuple | None = last
    while node is not None:
        cells.append(node[:2])
        node = best[node][2]
    return Path(cells=np.array(cells[::-1], dtype=int), cost=total)


def brute_path(cost: np.ndarray, slope: SlopeLimit, free_end: bool = True, start: tuple[int, int] = (0, 0)) -> Path:
    """Every path enumerated (seed 004 §5.2 method 1); only for grids of at most 100 cells."""
    if cost.size > 100:
        raise MjmotionError(f"brute force enumerates exponentially many paths; a {cost.shape} grid is too big (≤ 100 cells)")
    p = _search(np.asarray(cost, dtype=float), slope, free_end, start)
    return Path(p.cells, p.cost, "brute")


def threshold_path(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool = True,
    start: tuple[int, int] = (0, 0),
    area_threshold: float = 0.35,
    max_nodes: int = 5_000_000,
) -> Path:
    """Sako's recursion with thresholds (seed 004 §5.2 method 3), see :func:`_pruned_search`.

    Cells above ``area_threshold × max cost`` are never entered (Sako found 0.30–0.35 best).
    With ``area_threshold ≥ 1`` nothing is pruned and the result is the DP optimum.
    """
    c = np.asarray(cost, dtype=float)
    p = _pruned_search(c, slope, free_end, start, area_threshold * float(c.max()), max_nodes)
    return Path(p.cells, p.cost, "threshold")


def greedy_path(cost: np.ndarray, slope: SlopeLimit, free_end: bool = True, start: tuple[int, int] = (0, 0)) -> Path:
    """Always the cheapest allowed next cell (seed 004 §5.2 method 2; fast, not optimal)."""
    c = np.asarray(cost, dtype=float)
    n_a, n_b = c.shape
    i, j = start
    rh = rv = 0
    cells = [(i, j)]
    total = float(c[i, j])
    while (i < n_a - 1 and j < n_b - 1) if free_end else (i, j) != (n_a - 1, n_b - 1):
        options = [
            (float(c[i + di, j + dj]), di, dj, nrh, nrv)
            for di, dj, nrh, nrv in _moves(rh, rv, slope)
            if i + di < n_a and j + dj < n_b and (free_end or _reachable(n_a - 1 - i - di, n_b - 1 - j - dj, nrh, nrv, slope))
        ]
        if not options:
            raise MjmotionError(f"greedy search is stuck at cell ({i}, {j}) by the slope limit; use --method dp")
        val, di, dj, rh, rv = min(options, key=lambda o: o[0])
        i, j = i + di, j + dj
        cells.append((i, j))
        total += val
    return Path(np.array(cells, dtype=int), total, "greedy")


def auto_start(cost: np.ndarray, fraction: float = 1 / 3) -> tuple[int, int]:
    """The cheapest cell in the first third of the first row or column (seed 004 §5.3, Fig. 16)."""
    n_a, n_b = cost.shape
    row = cost[0, : max(1, int(n_b * fraction))]
    col = cost[: max(1, int(n_a * fraction)), 0]
    return (0, int(np.argmin(row))) if row.min() <= col.min() else (int(np.argmin(col)), 0)


def find_path(
    cost: np.ndarray,
    method: str = "dp",
    slope_limit: int | None = None,
    loop: bool = False,
    start: tuple[int, int] | str = (0, 0),
    **options: Any,
) -> Path:
    """Dispatch to a path search. ``loop``: fixed corners (seed 000); else free end (seed 004 §4.3).

    ``start``: a cell, or ``"auto"`` for :func:`auto_start` (only with a free end).
    """
    c = np.asarray(cost, dtype=float)
    slope = SlopeLimit.of(slope_limit, *c.shape)
    if isinstance(start, str):
        if start != "auto":
            raise MjmotionError(f"start must be a cell (i, j) or 'auto', got {start!r}")
        start = (0, 0) if loop else auto_start(c)
    cell = (int(start[0]), int(start[1]))
    if loop and cell != (0, 0):
        raise MjmotionError("a looping (fixed-corner) registration starts at the corner (0, 0)")
    free = not loop
    if method == "dp":
        return dp_path(c, slope, free, cell)
    if method == "greedy":
        return greedy_path(c, slope, free, cell)
    if method == "threshold":
        return threshold_path(c, slope, free, cell, **options)
    if method == "brute":
        return brute_path(c, slope, free, cell)
    raise MjmotionError(f"unknown path method {method!r}; expected one of {', '.join(METHODS)}")


# --------------------------------------------------------------------------------------------
# 3. timewarp curve
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TimewarpCurve:
    """A strictly increasing correspondence of clip times.

    Attributes:
        samples: ``(N, 2)`` float frames ``[tA, tB]``, strictly increasing in both columns.
        kind: ``"bspline"`` or ``"discrete"``.
    """

    samples: np.ndarray
    kind: str = "bspline"

    def b_of_a(self, t_a: np.ndarray) -> np.ndarray:
        """Frames of B matching frames ``t_a`` of A (linear between samples, clamped)."""
        return np.interp(t_a, self.samples[:, 0], self.samples[:, 1])

    def a_of_b(self, t_b: np.ndarray) -> np.ndarray:
        return np.interp(t_b, self.samples[:, 1], self.samples[:, 0])


def _monotone_lsq(design: np.ndarray, targets: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Least-squares B-spline coefficients ``(n, C)`` for ``targets: (P, C)`` with
    ``c[k+1] − c[k] ≥ eps[col]`` (hence strictly increasing splines: a spline's derivative is a
    spline whose coefficients are these differences). ``design: (P, n)`` already weighted."""
    coef, *_ = np.linalg.lstsq(design, targets, rcond=None)
    n = design.shape[1]
    for col in range(targets.shape[1]):
        if np.all(np.diff(coef[:, col]) >= eps[col]):
            continue
        # c = L δ with L lower-triangular ones: δ_0 free, δ_k ≥ eps
        lower = np.tril(np.ones((n, n)))
        lb = np.full(n, eps[col])
        lb[0] = -np.inf
        res = optimize.lsq_linear(design @ lower, targets[:, col], bounds=(lb, np.full(n, np.inf)), method="bvls")
        coef[:, col] = lower @ res.x
    return coef


def timewarp_curve(path: Path | np.ndarray, knot_spacing: float = 8.0, n_samples: int | None = None) -> TimewarpCurve:
    """Clamped uniform cubic B-spline through the path, strictly increasing in both clips' times.

    Parameter ``u = i + j`` (each step of the path raises it by 1 or 2, so it is strictly
    increasing); each coordinate is fitted as a spline of ``u`` with one knot every
    ``knot_spacing`` path cells (seed 000: 5–10 frames) and monotone coefficients; the ends are
    pinned to the path's ends (seed 004 §5.4). Sampled at ``n_samples`` (default: the path length)
    uniform values of ``u``.
    """
    cells = np.asarray(path.cells if isinstance(path, Path) else path, dtype=float)
    if len(cells) < 2:
        raise MjmotionError("a timewarp curve needs a path of at least 2 cells; the clips are too short")
    u = cells[:, 0] + cells[:, 1]
    n_int = max(1, int(round(len(cells) / knot_spacing)))
    k = 3 if n_int + 3 <= len(cells) else 1
    inner = np.linspace(u[0], u[-1], n_int + 1)
    knots = np.r_[[u[0]] * k, inner, [u[-1]] * k]
    design = interpolate.BSpline.design_matrix(u, knots, k)
    w = np.ones(len(u))
    w[[0, -1]] = 100.0  # pin the ends
    n = n_samples or len(cells)
    us = np.linspace(u[0], u[-1], n)
    span = np.maximum(cells[-1] - cells[0], 1e-9)
    coef = _monotone_lsq(design.toarray() * w[:, None], cells * w[:, None], eps=1e-3 * span / len(knots))
    samples = interpolate.BSpline(knots, coef, k)(us)
    samples = np.clip(samples, cells.min(axis=0), cells.max(axis=0))
    keep = np.r_[True, np.all(np.diff(samples, axis=0) > 0, axis=1)]
    return TimewarpCurve(samples=samples[keep], kind="bspline")


def discrete_timewarp(path: Path | np.ndarray) -> TimewarpCurve:
    """Sako's discrete corrections (seed 004 §5.3, Table 1): one B time per frame of A.

    Deletion: several B frames on one A frame → their mean (an interpolated frame). Insertion:
    one B frame over several A frames → B times spread linearly toward the next B frame. A run
    at the very end with nowhere to spread is dropped.
    """
    cells = np.asarray(path.cells if isinstance(path, Path) else path)
    rows, inv = np.unique(cells[:, 0], return_inverse=True)
    tb = np.bincount(inv, weights=cells[:, 1]) / np.bincount(inv)
    out_a: list[float] = []
    out_b: list[float] = []
    k = 0
    while k < len(rows):
        m = k
        while m + 1 < len(rows) and tb[m + 1] == tb[k]:
            m += 1
        if m + 1 < len(rows):
            span = tb[m + 1] - tb[k]
            r = m - k + 1
            out_b.extend(tb[k] + span * np.arange(r) / r)
            out_a.extend(rows[k : m + 1])
        else:
            out_b.append(tb[k])
            out_a.append(rows[k])
        k = m + 1
    return TimewarpCurve(samples=np.stack([np.asarray(out_a, float), np.asarray(out_b, float)], axis=1), kind="discrete")


# --------------------------------------------------------------------------------------------
# 4. alignment
# --------------------------------------------------------------------------------------------
def _interp_positions(positions: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Joint positions ``(T, J, 3)`` at fractional ``frames`` (any shape, clamped) → ``frames.shape + (J, 3)``."""
    f = np.clip(frames, 0, len(positions) - 1)
    i0 = np.floor(f).astype(int)
    i1 = np.minimum(i0 + 1, len(positions) - 1)
    a = (f - i0)[..., None, None]
    return positions[i0] * (1 - a) + positions[i1] * a


def alignment_curve(
    positions_a: np.ndarray,
    positions_b: np.ndarray,
    samples: np.ndarray,
    weights: np.ndarray | None = None,
    window: int = DEFAULT_WINDOW,
    smooth_frames: float = 6.0,
) -> np.ndarray:
    """Floor transforms ``(N, 3)`` ``[theta, tx, ty]`` moving B onto A at each timewarp sample.

    ``samples: (N, 2)`` ``[tA, tB]``; each transform is seed 000 Eq. 3–5 on the windows around
    the two (fractional) times, then smoothed with a Gaussian of ``smooth_frames`` samples
    (theta unwrapped first) so that the alignment changes gradually along the curve.
    """
    off = np.arange(-window, window + 1)
    ta = samples[:, 0:1] + off[None]
    tb = samples[:, 1:2] + off[None]
    w = np.ones(positions_a.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    keep = w > 0
    ca = _interp_positions(positions_a[:, keep], ta).reshape(len(samples), -1, 3)
    cb = _interp_positions(positions_b[:, keep], tb).reshape(len(samples), -1, 3)
    out = rigid_2d(ca, cb, np.tile(w[keep], len(off)))
    out[:, 0] = np.unwrap(out[:, 0])
    if smooth_frames > 0 and len(out) > 1:
        out = gaussian_filter1d(out, smooth_frames, axis=0, mode="nearest")
    return out


# --------------------------------------------------------------------------------------------
# 5. registration of two and of n clips
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PairRegistration:
    """Everything :func:`register` finds for clips A and B (frames of each clip)."""

    grid: Grid
    path: Path
    curve: TimewarpCurve
    alignment: np.ndarray  # (N, 3) theta, tx, ty per curve sample: applied to B to match A
    timing_s: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        """The JSON record of ``mjmotion register`` (keys documented in the issue/CLI help)."""
        return {
            "frames": list(self.grid.cost.shape),
            "path": self.path.cells.tolist(),
            "path_cost": self.path.cost,
            "mean_cost": self.path.mean_cost,
            "method": self.path.method,
            "timewarp": np.round(self.curve.samples, 4).tolist(),
            "alignment": np.round(self.alignment, 6).tolist(),
            "timing_s": self.timing_s,
        }


def positions_of(motion: Motion) -> np.ndarray:
    """World joint positions ``(T, J, 3)`` through MuJoCo (imported lazily)."""
    from .kinematics import joint_positions

    return joint_positions(motion)


def _prepare(motions: list[Motion]) -> None:
    first = motions[0]
    for m in motions[1:]:
        first.skeleton.require_same_topology(m.skeleton, f"{first.name or 'clip 1'} and {m.name or 'another clip'}")
        if abs(m.fps - first.fps) > 1e-3 * first.fps:
            raise MjmotionError(
                f"{m.name or 'a clip'} runs at {m.fps:g} fps and {first.name or 'the first'} at {first.fps:g} fps; "
                "resample them to one rate first (--fps)"
            )


def register(
    a: Motion,
    b: Motion,
    window: int = DEFAULT_WINDOW,
    slope_limit: int | None = None,
    loop: bool = False,
    method: str = "dp",
    start: tuple[int, int] | str = "auto",
    curve: str = "bspline",
    weights: dict[str, float] | None = None,
    positions: tuple[np.ndarray, np.ndarray] | None = None,
    max_cells: int = MAX_CELLS,
) -> PairRegistration:
    """Register clip B to clip A: grid, path, timewarp curve and alignment (seed 000 §3.1).

    ``start="auto"`` starts a free-end path at the best cell of the first third of the first row
    or column (seed 004 §5.3), so clips need not begin in phase; ``loop`` pins both corners.
    ``positions`` may pass precomputed ``(T, J, 3)`` joint positions of both clips.
    Clips shorter than the window still work (windows repeat edge frames); a clip of one
    frame cannot be registered.
    """
    _prepare([a, b])
    if min(a.n_frames, b.n_frames) < 2:
        raise MjmotionError(f"registration needs clips of at least 2 frames (got {a.n_frames} and {b.n_frames})")
    check_grid_size(a.n_frames, b.n_frames, max_cells)
    w = joint_weights(a.skeleton, weights)
    pa, pb = positions if positions is not None else (positions_of(a), positions_of(b))
    t0 = time.perf_counter()
    grid = distance_grid(pa, pb, w, window, max_cells)
    t1 = time.perf_counter()
    path = find_path(grid.cost, method, slope_limit, loop, start)
    t2 = time.perf_counter()
    if curve == "bspline":
        tw = timewarp_curve(path)
    elif curve == "discrete":
        tw = discrete_timewarp(path)
    else:
        raise MjmotionError(f"unknown timewarp curve {curve!r}; expected bspline or discrete")
    align = alignment_curve(pa, pb, tw.samples, w, window)
    t3 = time.perf_counter()
    return PairRegistration(grid, path, tw, align, {"grid": t1 - t0, "path": t2 - t1, "curve": t3 - t2})


@dataclass(frozen=True)
class Registration:
    """n clips registered to a reference (seed 000 §3.1, last paragraphs).

    Attributes:
        times: ``(N, n)`` float frames, column ``k`` the time of clip ``k``; every column strictly
            increasing. Row ``m`` is one instant of the registration.
        alignment: ``(N, n, 3)`` ``[theta, tx, ty]`` moving clip ``k`` onto the reference.
        reference: index of the reference clip (its column is sampled once per frame).
        mean_costs: ``(n,)`` mean path cost of each clip against the reference (0 for itself).
    """

    times: np.ndarray
    alignment: np.ndarray
    reference: int
    mean_costs: np.ndarray

    @property
    def n_clips(self) -> int:
        return self.times.shape[1]

    def at(self, tau: np.ndarray) -> np.ndarray:
        """Clip times ``(len(tau), n)`` at reference times ``tau`` (frames of the reference)."""
        ref = self.times[:, self.reference]
        return np.stack([np.interp(tau, ref, self.times[:, k]) for k in range(self.n_clips)], axis=1)


def choose_reference(motions: list[Motion], positions: list[np.ndarray], window: int = DEFAULT_WINDOW) -> int:
    """The clip most like the others: least summed mean path cost (seed 000: prefer a walk to a sprint)."""
    n = len(motions)
    if n <= 2:
        return 0
    w = joint_weights(motions[0].skeleton)
    score = np.zeros(n)
    for a in range(n):
        for b in range(a + 1, n):
            g = distance_grid(positions[a], positions[b], w, window)
            p = dp_path(g.cost, SlopeLimit.default(*g.cost.shape), True, auto_start(g.cost))
            score[a] += p.mean_cost
            score[b] += p.mean_cost
    return int(np.argmin(score))


def register_many(
    motions: list[Motion],
    reference: int | None = None,
    window: int = DEFAULT_WINDOW,
    slope_limit: int | None = None,
    loop: bool = False,
    start: tuple[int, int] | str = "auto",
    positions: list[np.ndarray] | None = None,
) -> Registration:
    """n-way registration: n−1 timewarp curves to a reference, merged into one curve of n-vectors.

    The reference is sampled once per frame over the span every curve covers (seed 000 samples it
    every 5–10 frames and fits a spline; our per-pair curves are splines already, so sampling them
    densely is the same curve).
    """
    if len(motions) < 1:
        raise MjmotionError("registration needs at least one clip")
    _prepare(motions)
    pos = positions if positions is not None else [positions_of(m) for m in motions]
    ref = choose_reference(motions, pos, window) if reference is None else int(reference)
    n = len(motions)
    curves: list[TimewarpCurve | None] = []
    aligns: list[np.ndarray | None] = []
    costs = np.zeros(n)
    for k in range(n):
        if k == ref:
            curves.append(None)
            aligns.append(None)
            continue
        pr = register(motions[ref], motions[k], window, slope_limit, loop, "dp", start, positions=(pos[ref], pos[k]))
        curves.append(pr.curve)
        aligns.append(pr.alignment)
        costs[k] = pr.path.mean_cost
    lo = max([c.samples[0, 0] for c in curves if c is not None], default=0.0)
    hi = min([c.samples[-1, 0] for c in curves if c is not None], default=motions[ref].n_frames - 1.0)
    if hi - lo < 1:
        raise MjmotionError("the registered clips share less than one frame of the reference; they cannot be blended")
    tau = np.arange(lo, hi + 1e-9, 1.0)
    times = np.empty((len(tau), n))
    align = np.zeros((len(tau), n, 3))
    for k, (curve_k, align_k) in enumerate(zip(curves, aligns, strict=True)):
        if curve_k is None or align_k is None:
            times[:, k] = tau
            continue
        s = curve_k.samples
        times[:, k] = np.interp(tau, s[:, 0], s[:, 1])
        for c in range(3):
            align[:, k, c] = np.interp(tau, s[:, 0], align_k[:, c])
    keep = np.r_[True, np.all(np.diff(times, axis=0) > 0, axis=1)]
    return Registration(times=times[keep], alignment=align[keep], reference=ref, mean_costs=costs)
