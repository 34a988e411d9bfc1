"""Minimal-cost paths through the registration grid (seed 000 Eq. 6, seed 004 §4.3 and §5.2).

Continuity, monotonicity and a slope limit; fixed corners (least total cost) or a fixed start
with a free end on the boundary, by one of two objectives (:data:`FREE_END_RULES`): Kovar &
Gleicher's — the least-total path to each boundary cell, then the one of least average cell cost —
or the least average cell cost over every path. ``dp`` (dynamic programming over (cell, run)
states; for the second objective Dinkelbach's parametric search over DP passes) solves each
exactly, as ``brute`` (every path, within a time budget) does by enumeration; ``greedy`` and
``threshold`` are Sako's alternatives (threshold exact over the cells under its threshold).
"""

from __future__ import annotations

import functools
import heapq
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import compiled
from ..errors import MjmotionError, is_whole

METHODS = ("dp", "greedy", "threshold", "brute")
#: The NumPy DP's time per grid cell (``benchmarks/bench_compiled.py``: 80–100 ns at slope limit 2).
NUMPY_SECONDS_PER_CELL = 1.0e-7
#: Grids from this size use the Numba DP kernel by default even in a fresh process: NumPy's DP
#: would take longer than the kernel's first call on a machine (:data:`mjmotion.compiled.COLD_START_S`).
NUMBA_MIN_CELLS = int(compiled.COLD_START_S / NUMPY_SECONDS_PER_CELL)


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


def _end_rank(objective: float, cell: tuple[int, int]) -> tuple[float, int]:
    """How a free-ended search orders its ends: the least objective; of equally good ends the one nearest
    the far corner (a still clip against itself ties at every end, and the first one, half of it at the
    slope limit, halved its blend). Every search takes the same end."""
    return objective, -(int(cell[0]) + int(cell[1]))


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
    """Row-by-row NumPy DP (see :func:`dp_path`): back-pointers and the boundary values.

    Two row buffers are swapped from row to row and every step writes into them (``out=``); a
    state's predecessor is gathered by flat index (``take``), not by a 2D fancy index.
    """
    n_a, n_b = c.shape
    s_n = 1 + wv + wh
    not_v = np.r_[0, np.arange(1 + wv, s_n)]
    cols = np.arange(n_b)
    bp_d = np.zeros((n_a, n_b), dtype=bp_dtype)
    bp_v = np.zeros((n_a, n_b), dtype=bp_dtype)
    bp_h = np.zeros((n_a, n_b), dtype=bp_dtype)
    last_col = np.full((n_a, s_n), np.inf)
    last_col_len = np.zeros((n_a, s_n))
    # two row buffers swapped each row: only column 0's D and H states need resetting
    prev, cur = np.full((s_n, n_b), np.inf), np.full((s_n, n_b), np.inf)
    prev_len, cur_len = np.zeros((s_n, n_b)), np.zeros((s_n, n_b))
    flat_prev, flat_prev_len = prev.reshape(-1), prev_len.reshape(-1)
    nv_rows = np.empty((len(not_v), n_b))
    for i in range(n_a):
        ci = c[i]
        if i == 0:
            cur[0, 0] = ci[0]
            cur_len[0, 0] = 1
        else:
            cur[0, 0], cur_len[0, 0] = np.inf, 0.0
            k = np.argmin(prev[:, :-1], axis=0)
            idx = k * n_b + cols[:-1]
            np.add(ci[1:], flat_prev.take(idx), out=cur[0, 1:])
            np.add(flat_prev_len.take(idx), 1.0, out=cur_len[0, 1:])
            bp_d[i, 1:] = k
            if wv:
                np.take(prev, not_v, axis=0, out=nv_rows)
                kv = np.argmin(nv_rows, axis=0)
                sv = not_v[kv]
                idx = sv * n_b + cols
                np.add(ci, flat_prev.take(idx), out=cur[1])
                np.add(flat_prev_len.take(idx), 1.0, out=cur_len[1])
                bp_v[i] = sv
                np.add(ci, prev[1:wv], out=cur[2 : 1 + wv])
                np.add(prev_len[1:wv], 1.0, out=cur_len[2 : 1 + wv])
        if wh:
            cur[1 + wv :, 0], cur_len[1 + wv :, 0] = np.inf, 0.0
            kh = np.argmin(cur[: 1 + wv, :-1], axis=0)  # from D or any V (rows 0..wv, a view)
            idx = kh * n_b + cols[:-1]
            flat_cur, flat_cur_len = cur.reshape(-1), cur_len.reshape(-1)
            np.add(ci[1:], flat_cur.take(idx), out=cur[1 + wv, 1:])
            np.add(flat_cur_len.take(idx), 1.0, out=cur_len[1 + wv, 1:])
            bp_h[i, 1:] = kh
            for r in range(2, wh + 1):
                np.add(ci[1:], cur[wv + r - 1, :-1], out=cur[wv + r, 1:])
                np.add(cur_len[wv + r - 1, :-1], 1.0, out=cur_len[wv + r, 1:])
        last_col[i] = cur[:, -1]
        last_col_len[i] = cur_len[:, -1]
        prev, cur = cur, prev
        prev_len, cur_len = cur_len, prev_len
        flat_prev, flat_prev_len = prev.reshape(-1), prev_len.reshape(-1)
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


#: Free-end objectives of :func:`dp_path`: Kovar & Gleicher's rule (the least-total path to each
#: boundary cell, then the least mean of those), or the least mean cell cost over every path.
FREE_END_RULES = ("per-end", "mean")
#: Dinkelbach passes before :func:`least_mean_path` gives up (each pass lowers the mean; 2–5 suffice).
MAX_RATIO_PASSES = 100


def _check_rule(rule: str) -> None:
    if rule not in FREE_END_RULES:
        raise MjmotionError(f"unknown free-end rule {rule!r}; expected {' or '.join(FREE_END_RULES)}")


def _dp_backend(size: int, backend: str):
    """The Numba DP kernel, or ``None`` for NumPy's (see :func:`dp_path`)."""
    if backend not in ("auto", "numba", "numpy"):
        raise MjmotionError(f"unknown DP backend {backend!r}; expected auto, numba or numpy")
    # Numba's import and cache load cost ~0.5 s once (~2 s compiling on a cold cache), so "auto"
    # takes it only where it pays end to end: grids that big, or a process that has loaded it already
    loaded = _dp_tables_numba.cache_info().currsize > 0 and compiled.ready(_dp_tables_numba())
    use_numba = backend == "numba" or (backend == "auto" and (size >= NUMBA_MIN_CELLS or loaded))
    kernel = _dp_tables_numba() if use_numba else None
    if backend == "numba" and kernel is None:
        raise MjmotionError("the numba DP backend needs numba (pip install numba)")
    return kernel


def _dp_pass(c: np.ndarray, slope: SlopeLimit, free_end: bool, rule: str, kernel) -> tuple[np.ndarray, float]:
    """One DP over ``c`` (the grid from the start cell): the path's cells and the value it minimises.

    ``rule``: ``"sum"`` ends where the total is least (the far corner without ``free_end``, else
    any boundary cell and state); ``"per-end"`` takes each boundary cell's cheapest total, then
    the least average of those (Kovar & Gleicher).
    """
    n_a, n_b = c.shape
    wv, wh = slope.vertical, slope.horizontal
    bp_dtype = np.int8 if 1 + wv + wh <= 127 else np.int32
    if kernel is not None:
        bp_d, bp_v, bp_h = (np.zeros((n_a, n_b), dtype=bp_dtype) for _ in range(3))
        prev, prev_len, last_col, last_col_len = kernel(c, wv, wh, bp_d, bp_v, bp_h)
    else:
        bp_d, bp_v, bp_h, prev, prev_len, last_col, last_col_len = _dp_tables_numpy(c, wv, wh, bp_dtype)
    if not free_end:
        s = int(np.argmin(prev[:, -1]))
        i, j, value = n_a - 1, n_b - 1, float(prev[s, -1])
    else:
        cands = []
        for vals, lens, cell in ((prev.T, prev_len.T, lambda k: (n_a - 1, k)), (last_col, last_col_len, lambda k: (k, n_b - 1))):
            s_best = np.argmin(vals, axis=1)  # per boundary cell its cheapest path (any state)
            tot = vals[np.arange(len(vals)), s_best]
            obj = _end_objective(tot, lens[np.arange(len(vals)), s_best]) if rule == "per-end" else tot
            # (the last of the least along the boundary: the end nearest the far corner, _end_rank)
            k = int(np.flatnonzero(obj == obj.min())[-1]) if np.isfinite(obj.min()) else 0
            cands.append((float(obj[k]), cell(k), int(s_best[k])))
        value, (i, j), s = min(cands, key=lambda c: _end_rank(c[0], c[1]))
    if not np.isfinite(value):
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
    return np.array(cells[::-1], dtype=int), value


def least_mean_path(cost: np.ndarray, solve, first: np.ndarray) -> tuple[np.ndarray, float, int]:
    """The path of least mean cell cost, by Dinkelbach's parametric search.

    ``solve(lam)`` returns ``(cells, value)``: a path minimising ``Σ (cost − lam)`` over its cells,
    and that minimum. With ``lam`` the mean of the best path so far, a negative minimum is a path
    of lower mean (``Σ c − lam·len < 0``); a minimum of zero proves no path has a lower mean
    (every path has ``Σ c ≥ lam·len``). Each pass lowers ``lam`` and the paths are finite, so it
    ends, in 2–5 passes on our grids. ``first``: a path to start from. Returns ``(cells, total,
    passes)``.
    """
    cells = first
    total = float(cost[cells[:, 0], cells[:, 1]].sum())
    for passes in range(1, MAX_RATIO_PASSES + 1):
        lam = total / len(cells)
        cand, value = solve(lam)
        # zero within round-off of the sums: no path is cheaper on average
        if value >= -1e-12 * max(abs(lam), 1e-300) * (cost.shape[0] + cost.shape[1]):
            return cells, total, passes
        cells = cand
        total = float(cost[cells[:, 0], cells[:, 1]].sum())
    raise MjmotionError(f"the least-mean path search did not settle in {MAX_RATIO_PASSES} passes")  # pragma: no cover


def dp_path(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool = True,
    start: tuple[int, int] = (0, 0),
    backend: str = "auto",
    rule: str = "per-end",
) -> Path:
    """Exact minimal-cost path by dynamic programming over (cell, run) states.

    States at a cell: arrived diagonally (``D``), by the r-th consecutive A-only step
    (``V_r``, r ≤ W_v) or by the r-th consecutive B-only step (``H_r``, r ≤ W_h); the slope
    limit is part of the state, so the optimum is exact. Without ``free_end`` the path ends at
    the far corner with the least total cost. With ``free_end`` it ends on the last row or column
    and ``rule`` says which path, both exact: ``"per-end"`` (default; seed 004 §4.3, Kovar &
    Gleicher) the least-total path to each boundary cell, then of those the one of least mean
    cell cost — one pass; ``"mean"`` the least mean cell cost over every path to the boundary
    (:func:`least_mean_path`: a DP per pass on the grid less the current mean). A path's mean
    drops when it trades a diagonal step for two straight ones through cells cheaper than its
    mean, so ``"mean"`` paths stair-step along the valley (on the daz walks and runs 18–46 %
    more cells) and recover known warps a little less well (experiments/path_search.py).
    ``backend``: ``"numpy"`` (one vectorised pass per row: ``D`` and ``V`` from the previous row,
    ``H_r`` by shifts within the row), ``"numba"`` (a compiled loop over cells, measured faster
    in benchmarks/bench_registration.py) or ``"auto"`` (Numba when installed and the kernel is
    loaded in this process already or the grid has at least :data:`NUMBA_MIN_CELLS` cells: the
    rule of :mod:`mjmotion.compiled`).
    """
    _check_rule(rule)
    c = np.ascontiguousarray(np.asarray(cost, dtype=float)[start[0] :, start[1] :])
    kernel = _dp_backend(c.size, backend)
    offset = np.asarray(start, dtype=int)
    if not free_end:
        cells, total = _dp_pass(c, slope, False, "sum", kernel)
        return Path(cells=cells + offset, cost=total, method="dp")
    cells, _ = _dp_pass(c, slope, True, "per-end", kernel)
    if rule == "mean":
        cells, _, _ = least_mean_path(c, lambda lam: _dp_pass(c - lam, slope, True, "sum", kernel), cells)
    return Path(cells=cells + offset, cost=float(c[cells[:, 0], cells[:, 1]].sum()), method="dp")


def _moves(run_h: int, run_v: int, slope: SlopeLimit) -> list[tuple[int, int, int, int]]:
    """Allowed steps ``(di, dj, new_run_h, new_run_v)``, diagonal first (Sako's shorter-path preference)."""
    out = [(1, 1, 0, 0)]
    if run_v < slope.vertical:
        out.append((1, 0, 0, run_v + 1))
    if run_h < slope.horizontal:
        out.append((0, 1, run_h + 1, 0))
    return out


def count_paths(shape: tuple[int, int], slope: SlopeLimit, free_end: bool = True, start: tuple[int, int] = (0, 0)) -> float:
    """How many paths :func:`brute_path` enumerates on a grid of ``shape`` (float; ``inf`` past 1e308).

    The DP of :func:`dp_path` with sums of counts for minima: paths from ``start`` to the far corner,
    or with ``free_end`` every path that ends on the last row or column (a path along the boundary
    counts at each cell it ends on, as the search records it).
    """
    n_a, n_b = shape[0] - start[0], shape[1] - start[1]
    wv, wh = slope.vertical, slope.horizontal
    prev = np.zeros((1 + wv + wh, n_b))
    boundary = 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(n_a):
            cur = np.zeros_like(prev)
            if i == 0:
                cur[0, 0] = 1.0
            else:
                cur[0, 1:] = prev.sum(axis=0)[:-1]  # a diagonal step from any state
                if wv:
                    cur[1] = prev[0] + prev[1 + wv :].sum(axis=0)  # the first A-only step: from D or H
                    cur[2 : 1 + wv] = prev[1:wv]
            if wh:
                cur[1 + wv, 1:] = cur[: 1 + wv].sum(axis=0)[:-1]  # the first B-only step: from D or V
                for r in range(2, wh + 1):
                    cur[wv + r, 1:] = cur[wv + r - 1, :-1]
            if free_end:
                boundary += float(cur[:, -1].sum()) if i < n_a - 1 else float(cur.sum())
            prev = cur
    return boundary if free_end else float(prev[:, -1].sum())


def _search(cost: np.ndarray, slope: SlopeLimit, free_end: bool, start: tuple[int, int], rule: str, time_limit_s: float | None) -> Path:
    """Depth-first enumeration of every path (Sako's brute-force recursion, seed 004 Fig. 13).

    Keeps the least total (fixed corners); with a free end, per boundary cell the least-total
    path (``rule="per-end"``, then the least mean of those) or the least mean over every path
    (``"mean"``): the objectives of :func:`dp_path`. Stops with an error once ``time_limit_s``
    is spent, or earlier when the rate so far says the remaining paths (:func:`count_paths`)
    would take longer.
    """
    n_a, n_b = cost.shape
    si, sj = start
    total_paths = count_paths(cost.shape, slope, free_end, start)
    end_best: dict[tuple[int, int], tuple[float, list]] = {}
    best_mean, best_mean_path, best_mean_end = math.inf, None, (n_a, n_b)  # (beyond every end: no tie replaces nothing)
    path: list[tuple[int, int]] = []
    stack: list[tuple[int, int, int, int, float, int]] = [(si, sj, 0, 0, float(cost[si, sj]), 0)]
    done = nodes = 0
    t0 = time.perf_counter()
    while stack:
        i, j, rh, rv, total, depth = stack.pop()
        del path[depth:]
        path.append((i, j))
        nodes += 1
        if time_limit_s is not None and nodes % 65536 == 0:
            _check_budget(time.perf_counter() - t0, done, total_paths, time_limit_s, cost.shape)
        if (i == n_a - 1 or j == n_b - 1) if free_end else (i == n_a - 1 and j == n_b - 1):
            done += 1
            old = end_best.get((i, j))
            if old is None or total < old[0]:
                end_best[(i, j)] = (total, list(path))
            if _end_rank(total / len(path), (i, j)) < _end_rank(best_mean, best_mean_end):
                best_mean, best_mean_path, best_mean_end = total / len(path), (total, list(path)), (i, j)
        children: list[tuple[int, int, int, int, float, int]] = []
        for di, dj, nrh, nrv in _moves(rh, rv, slope):
            ni, nj = i + di, j + dj
            if ni >= n_a or nj >= n_b:
                continue
            if not free_end and not _reachable(n_a - 1 - ni, n_b - 1 - nj, nrh, nrv, slope):
                continue
            children.append((ni, nj, nrh, nrv, total + float(cost[ni, nj]), depth + 1))
        stack.extend(reversed(children))  # pop order: diagonal, then the straight steps
    if not end_best:
        raise MjmotionError(f"no path joins the corners of a {n_a} × {n_b} grid within the slope limit")
    if not free_end:
        best = end_best[(n_a - 1, n_b - 1)]
    elif rule == "mean":
        assert best_mean_path is not None
        best = best_mean_path
    else:
        best = min(end_best.items(), key=lambda kv: _end_rank(kv[1][0] / len(kv[1][1]), kv[0]))[1]
    return Path(cells=np.array(best[1], dtype=int), cost=best[0])


def _check_budget(elapsed: float, done: int, total: float, limit: float, shape: tuple[int, int]) -> None:
    """Stop brute force past its time budget, or once its rate shows it cannot finish within it."""
    rate = done / max(elapsed, 1e-9)
    left = (total - done) / rate if rate > 0 else math.inf
    if elapsed <= limit and (elapsed < min(1.0, 0.05 * limit) or elapsed + left <= limit):
        return
    eta = "more than the age of the universe" if left > 4e17 else f"about {_duration(elapsed + left)}"
    raise MjmotionError(
        f"brute force on a {shape[0]} × {shape[1]} grid: {total:.3g} paths within the slope limit; {done:,} enumerated in "
        f"{elapsed:.1f} s ({rate:.3g} paths/s), so all of them would take {eta}, over the {limit:g} s budget; "
        "raise the budget (--time-limit), register shorter excerpts, or use --method dp (exact)"
    )


def _duration(seconds: float) -> str:
    for unit, size in (("years", 3.156e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _pruned_search(
    cost: np.ndarray, slope: SlopeLimit, free_end: bool, start: tuple[int, int], allowed: np.ndarray, max_nodes: int, rule: str = "per-end"
) -> Path:
    """Sako's recursion with an area threshold, expanding partial paths in order of progress.

    Only ``allowed`` cells are entered. Partial paths are expanded by increasing ``i + j``
    (ties: diagonal-first, Sako's shorter-path preference) and a path reaching a (cell, run)
    state no cheaper than an earlier one is dropped, so every state is expanded once with its
    cheapest cost; Sako's depth-first order re-expands states and is exponential in the worst
    case (her Table 4: 21–36 s). Ends like :func:`_dp_pass`: ``rule`` ``"per-end"`` or ``"sum"``
    (the least total over the boundary; costs may be negative).
    """
    n_a, n_b = cost.shape
    si, sj = start
    if not allowed[si, sj]:
        raise MjmotionError("the start cell costs more than the area threshold allows; raise the threshold (--area-threshold)")
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
                "use --method dp (exact and fast) or lower the area threshold (--area-threshold)"
            )
        on_end = (i == n_a - 1 or j == n_b - 1) if free_end else (i == n_a - 1 and j == n_b - 1)
        if on_end and ((i, j) not in end_best or total < end_best[(i, j)][0]):
            end_best[(i, j)] = (total, length, key)
        for di, dj, nrh, nrv in _moves(rh, rv, slope):
            ni, nj = i + di, j + dj
            if ni >= n_a or nj >= n_b or not allowed[ni, nj]:
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
        raise MjmotionError("no path reaches the end under the area threshold; raise the threshold (--area-threshold) or use --method dp")
    total, length, last = min(end_best.values(), key=lambda v: _end_rank(v[0] / v[1] if free_end and rule == "per-end" else v[0], v[2][:2]))
    cells = []
    node: tuple | None = last
    while node is not None:
        cells.append(node[:2])
        node = best[node][2]
    return Path(cells=np.array(cells[::-1], dtype=int), cost=total)


#: Default time budget of :func:`brute_path` (seconds).
BRUTE_TIME_LIMIT_S = 60.0


def brute_path(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool = True,
    start: tuple[int, int] = (0, 0),
    rule: str = "per-end",
    time_limit_s: float | None = BRUTE_TIME_LIMIT_S,
) -> Path:
    """Every path enumerated (seed 004 §5.2 method 1), within a time budget; ``rule`` as :func:`dp_path`'s.

    The number of paths grows exponentially (:func:`count_paths`: 10 × 10 cells at W = 2 have
    1.1 million to the boundary, 13 × 13 117 million); the search stops with an error saying how
    long all of them would take once ``time_limit_s`` is spent or its rate shows it cannot finish
    in time (``None``: no limit).
    """
    _check_rule(rule)
    if time_limit_s is not None and not time_limit_s > 0:
        raise MjmotionError(f"the brute-force time budget must be a positive number of seconds, got {time_limit_s}")
    p = _search(np.asarray(cost, dtype=float), slope, free_end, start, rule, time_limit_s)
    return Path(p.cells, p.cost, "brute")


def threshold_path(
    cost: np.ndarray,
    slope: SlopeLimit,
    free_end: bool = True,
    start: tuple[int, int] = (0, 0),
    area_threshold: float = 0.35,
    max_nodes: int = 5_000_000,
    rule: str = "per-end",
) -> Path:
    """Sako's recursion with thresholds (seed 004 §5.2 method 3), see :func:`_pruned_search`.

    Cells above ``area_threshold × max cost`` are never entered (Sako found 0.30–0.35 best).
    Its objective is :func:`dp_path`'s (``rule="mean"``: by :func:`least_mean_path` over searches
    of ``cost − mean``), so with ``area_threshold ≥ 1`` nothing is pruned and the result is the
    DP optimum.
    """
    _check_rule(rule)
    c = np.asarray(cost, dtype=float)
    allowed = c <= area_threshold * float(c.max())
    p = _pruned_search(c, slope, free_end, start, allowed, max_nodes)
    if free_end and rule == "mean":

        def solve(lam: float) -> tuple[np.ndarray, float]:
            q = _pruned_search(c - lam, slope, True, start, allowed, max_nodes, rule="sum")
            return q.cells, q.cost

        cells, total, _ = least_mean_path(c, solve, p.cells)
        p = Path(cells, total)
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
    rule: str = "per-end",
    **options: Any,
) -> Path:
    """Dispatch to a path search. ``loop``: fixed corners (seed 000); else free end (seed 004 §4.3)
    chosen by ``rule`` (:data:`FREE_END_RULES`, see :func:`dp_path`; greedy has its own).

    ``start``: a cell, or ``"auto"`` for :func:`auto_start` (only with a free end). ``options``:
    ``area_threshold``/``max_nodes`` for threshold, ``time_limit_s`` for brute.
    """
    c = np.asarray(cost, dtype=float)
    slope = SlopeLimit.of(slope_limit, *c.shape)
    _check_rule(rule)
    if isinstance(start, str):
        if start != "auto":
            raise MjmotionError(f"start must be a cell (i, j) or 'auto', got {start!r}")
        start = (0, 0) if loop else auto_start(c)
    ok = isinstance(start, (tuple, list)) and len(start) == 2 and all(is_whole(x) for x in start)
    if not ok or not (0 <= start[0] < c.shape[0] and 0 <= start[1] < c.shape[1]):  # (-1 wrapped to the last row)
        raise MjmotionError(f"start={start!r}: expected a cell (i, j) of the {c.shape[0]}×{c.shape[1]} grid, or 'auto'")
    cell = (int(start[0]), int(start[1]))
    if loop and cell != (0, 0):
        raise MjmotionError("a looping (fixed-corner) registration starts at the corner (0, 0)")
    free = not loop
    if method == "dp":
        return dp_path(c, slope, free, cell, rule=rule)
    if method == "greedy":
        return greedy_path(c, slope, free, cell)
    if method == "threshold":
        return threshold_path(c, slope, free, cell, rule=rule, **options)
    if method == "brute":
        return brute_path(c, slope, free, cell, rule=rule, **options)
    raise MjmotionError(f"unknown path method {method!r}; expected one of {', '.join(METHODS)}")
