"""Minimal-cost paths through the registration grid (seed 000 Eq. 6, seed 004 §4.3 and §5.2).

Continuity, monotonicity and a slope limit; fixed corners or a fixed start with a free end on
the boundary (least average cell cost). ``dp`` (dynamic programming over (cell, run) states) is
exact; ``brute``, ``greedy`` and ``threshold`` are Sako's alternatives.
"""

from __future__ import annotations

import functools
import heapq
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import compiled
from ..errors import MjmotionError

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
    when installed and the kernel is loaded in this process already or the grid has at least
    :data:`NUMBA_MIN_CELLS` cells: the rule of :mod:`mjmotion.compiled`).
    """
    c = np.ascontiguousarray(np.asarray(cost, dtype=float)[start[0] :, start[1] :])
    n_a, n_b = c.shape
    wv, wh = slope.vertical, slope.horizontal
    bp_dtype = np.int8 if 1 + wv + wh <= 127 else np.int32
    # Numba's import and cache load cost ~0.5 s once (~2 s compiling on a cold cache), so "auto"
    # takes it only where it pays end to end: grids that big, or a process that has loaded it already
    loaded = _dp_tables_numba.cache_info().currsize > 0 and compiled.ready(_dp_tables_numba())
    use_numba = backend == "numba" or (backend == "auto" and (c.size >= NUMBA_MIN_CELLS or loaded))
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
