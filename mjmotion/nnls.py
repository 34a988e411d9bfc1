"""Non-negative least squares for many small problems at once.

The judge's ground-reaction test (``physics.ground_reaction_residual``) asks, for every supported
frame, how close a non-negative combination of up to a few dozen force generators comes to the
wrench the motion needs: ``min ‖A x − b‖`` over ``x ≥ 0`` with ``A`` of 6 rows. Solving the frames
one at a time with ``scipy.optimize.nnls`` costs a Python call per frame and, in every fresh
process, the 0.3 s import of ``scipy.optimize`` and ``scipy.linalg``. This is Lawson and Hanson's
active-set algorithm (*Solving Least Squares Problems*, 1974, ch. 23) run on all problems in
lockstep with NumPy: each problem keeps its passive set in at most ``m`` slots (the algorithm keeps
the passive columns linearly independent, so never more than the rows), and every least-squares
step is one batched ``m × m`` solve. ``tests/test_nnls.py`` checks it against SciPy's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Solution:
    """Attributes:
    x: ``(R, n)`` the non-negative minimisers.
    residual: ``(R,)`` ``‖A x − b‖``.
    iterations: outer iterations (columns brought in) of the problem that needed most.
    """

    x: np.ndarray
    residual: np.ndarray
    iterations: int


def solve(a: np.ndarray, b: np.ndarray, allowed: np.ndarray | None = None, max_iter: int | None = None) -> Solution:
    """``min ‖a[r] x − b[r]‖`` over ``x ≥ 0`` for every problem ``r``; columns where ``allowed`` is
    False are held at 0 (they are not part of that problem).

    ``a: (R, m, n)``, ``b: (R, m)``, ``allowed: (R, n)`` bool. ``max_iter`` bounds the outer
    iterations (default ``3 n``, as SciPy's); a problem still unfinished then raises.
    """
    a_all = np.asarray(a, dtype=float)
    b_all = np.asarray(b, dtype=float)
    r_count, m, n = a_all.shape
    ok_all = np.ones((r_count, n), dtype=bool) if allowed is None else np.asarray(allowed, dtype=bool)
    slots = min(m, n)
    x = np.zeros((r_count, n))
    # Lawson-Hanson's tolerance on the dual (as SciPy's nnls): a multiple of rounding in A and b.
    scale = np.abs(a_all).max(axis=(1, 2), initial=0.0) * np.abs(b_all).max(axis=1, initial=0.0)
    tol_all = 10.0 * max(m, n) * np.finfo(float).eps * scale
    max_iter = 3 * n if max_iter is None else max_iter
    # The open problems' state; solved problems leave it (their x written out) every few rounds.
    rows = np.arange(r_count)  # which problem each open row is
    a, b, ok, tol = a_all, b_all, ok_all, tol_all
    idx = np.zeros((r_count, slots), dtype=np.intp)  # the passive column in each slot
    cols = np.zeros((r_count, m, slots))  # that column of a (0 in a free slot)
    val = np.zeros((r_count, slots))  # x at that column (0 in a free slot)
    in_p = np.zeros((r_count, n), dtype=bool)  # the passive set
    open_ = np.ones(r_count, dtype=bool)
    it = 0
    while open_.any():
        if 4 * open_.sum() < 3 * len(open_):  # a quarter are solved: keep the open ones only
            _write(x, rows[~open_], idx[~open_], val[~open_])
            keep = open_
            rows, a, b, ok, tol = rows[keep], a[keep], b[keep], ok[keep], tol[keep]
            idx, cols, val, in_p, open_ = idx[keep], cols[keep], val[keep], in_p[keep], open_[keep]
        it += 1
        if it > max_iter:
            raise RuntimeError(f"nnls: {int(open_.sum())} of {r_count} problems unfinished after {max_iter} iterations")
        # The dual A^T (b − A x) of every kept problem (cheaper than gathering the open ones).
        w = np.einsum("rmn,rm->rn", a, b - np.einsum("rms,rs->rm", cols, val))
        w[~ok | in_p | ~open_[:, None]] = -np.inf
        j = np.argmax(w, axis=1)
        used = _slot_used(cols)
        grow = open_ & (w[np.arange(len(w)), j] > tol) & ~used.all(axis=1)
        open_ &= grow
        o, j = np.flatnonzero(grow), j[grow]
        if not len(o):
            break
        slot = np.argmin(used[o], axis=1)  # the first free slot
        idx[o, slot], val[o, slot], cols[o, :, slot] = j, 0.0, a[o, :, j]
        in_p[o, j] = True
        s = _passive_lstsq(cols[o], b[o])
        # A column whose dual was positive by rounding alone takes no positive weight: that
        # problem is solved (Lawson and Hanson's test on the new coefficient; without it such a
        # column would come and go forever).
        stale = s[np.arange(len(o)), slot] <= 0.0
        if stale.any():
            so = o[stale]
            cols[so, :, slot[stale]] = 0.0
            in_p[so, j[stale]] = False
            open_[so] = False
            o, s = o[~stale], s[~stale]
        # The unconstrained optimum on the passive set, stepping back to the last feasible point
        # on the way whenever a passive coefficient would turn non-positive (and dropping it).
        while len(o):
            u = _slot_used(cols[o])
            bad = u & (s <= 0.0)
            fine = ~bad.any(axis=1)
            val[o[fine]] = s[fine]
            o, s, u, bad = o[~fine], s[~fine], u[~fine], bad[~fine]
            if not len(o):
                break
            x0 = val[o]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(bad, x0 / (x0 - s), np.inf)
            alpha = ratio.min(axis=1, keepdims=True)
            x1 = x0 + alpha * (s - x0)
            drop = u & ((x1 <= 0.0) | (ratio == alpha))
            x1[drop] = 0.0
            val[o] = x1
            dr, ds = np.nonzero(drop)
            cols[o[dr], :, ds] = 0.0
            in_p[o[dr], idx[o[dr], ds]] = False
            s = _passive_lstsq(cols[o], b[o])
    _write(x, rows, idx, val)
    res = np.linalg.norm(np.einsum("rmn,rn->rm", a_all, x) - b_all, axis=1)
    return Solution(x=x, residual=res, iterations=it)


def _slot_used(cols: np.ndarray) -> np.ndarray:
    """Which slots hold a passive column, ``(R, slots)``: a free slot's column is all zeros."""
    return np.asarray(cols.any(axis=1))


def _write(x: np.ndarray, rows: np.ndarray, idx: np.ndarray, val: np.ndarray) -> None:
    """``x[rows]`` from the slots (free slots hold 0, so writing them changes nothing that matters)."""
    nz = val != 0.0
    r, s = np.nonzero(nz)
    x[rows[r], idx[r, s]] = val[r, s]


def _passive_lstsq(cols: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares coefficients of the passive columns ``cols (R, m, slots)`` (free slots
    all zero), per slot ``(R, slots)`` with 0 in free slots: the normal equations, free slots made
    identity rows (residuals agree with SciPy's QR-based solver to ~1e-13 on the judge's problems;
    the passive columns stay independent, and a singular system falls back to the pseudo-inverse)."""
    free = ~_slot_used(cols)
    g = np.einsum("rms,rmt->rst", cols, cols)
    k = np.arange(cols.shape[2])
    g[:, k, k] += free
    rhs = np.einsum("rms,rm->rs", cols, b)[..., None]
    try:
        s = np.linalg.solve(g, rhs)[..., 0]
    except np.linalg.LinAlgError:
        s = (np.linalg.pinv(g) @ rhs)[..., 0]
    s[free] = 0.0
    return s
