"""Timewarp curves: a strictly increasing correspondence of two clips' times fitted to a path.

A clamped uniform cubic B-spline with monotone coefficients (seed 004 §5.4), or Sako's discrete
insertion/deletion corrections (seed 004 Table 1).

The B-spline basis is evaluated here (:func:`bspline_basis`, checked against SciPy's
``BSpline.design_matrix`` in the tests) rather than with SciPy, whose import (~0.3 s) would
more than double the time of a fresh ``mjmotion register``; SciPy's bounded least squares is
loaded only when the plain fit is not monotone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MjmotionError
from .paths import Path


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


def bspline_basis(x: np.ndarray, knots: np.ndarray, k: int) -> np.ndarray:
    """Values ``(P, n)`` of the ``n = len(knots) − k − 1`` B-splines of degree ``k`` at ``x: (P,)``.

    Cox–de Boor recursion over all points at once; ``knots`` non-decreasing, ``x`` within
    ``[knots[k], knots[-k-1]]`` (the last point belongs to the last non-empty span, as in SciPy).
    """
    x = np.asarray(x, dtype=float)
    t = np.asarray(knots, dtype=float)
    n = len(t) - k - 1
    span = np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)  # t[span] <= x < t[span+1]
    b = np.zeros((len(x), len(t) - 1))
    b[np.arange(len(x)), span] = 1.0
    for d in range(1, k + 1):
        left = t[d : d + len(t) - 1 - d] - t[: len(t) - 1 - d]  # t[i+d] - t[i]
        right = t[d + 1 :] - t[1 : len(t) - d]  # t[i+d+1] - t[i+1]
        wl = np.divide(x[:, None] - t[None, : len(left)], left, out=np.zeros((len(x), len(left))), where=left > 0)
        wr = np.divide(t[None, d + 1 :] - x[:, None], right, out=np.zeros((len(x), len(right))), where=right > 0)
        b = wl * b[:, :-1] + wr * b[:, 1:]
    return b[:, :n]


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
        from scipy import optimize

        res = optimize.lsq_linear(design @ lower, targets[:, col], bounds=(lb, np.full(n, np.inf)), method="bvls")
        coef[:, col] = lower @ res.x
    return coef


@dataclass(frozen=True, eq=False)
class Spline:
    """A B-spline ``u → (C,)`` evaluated with :func:`bspline_basis` (SciPy's ``BSpline`` fields).

    Attributes:
        t: ``(n + k + 1,)`` knots; c: ``(n, C)`` coefficients (control points); k: degree.
    """

    t: np.ndarray
    c: np.ndarray
    k: int

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """``(len(u), C)`` values at ``u`` (inside the knot span)."""
        return bspline_basis(np.atleast_1d(np.asarray(u, dtype=float)), self.t, self.k) @ self.c


def monotone_bspline(u: np.ndarray, targets: np.ndarray, n_intervals: int) -> Spline:
    """A clamped uniform cubic B-spline ``u → (C,)`` fitted to ``targets: (P, C)`` at the strictly
    increasing parameters ``u: (P,)``, strictly increasing in every coordinate.

    ``n_intervals`` uniform knot intervals over ``[u[0], u[-1]]`` (degree 1 when there are too
    few points for a cubic); least squares with monotone coefficients (each coordinate's
    coefficients rise by at least 1e-3 of its span per knot) and the ends pinned (weight 100).
    """
    n_int = max(1, int(n_intervals))
    k = 3 if n_int + 3 <= len(u) else 1
    inner = np.linspace(u[0], u[-1], n_int + 1)
    knots = np.r_[[u[0]] * k, inner, [u[-1]] * k]
    design = bspline_basis(u, knots, k)
    w = np.ones(len(u))
    w[[0, -1]] = 100.0  # pin the ends
    span = np.maximum(targets[-1] - targets[0], 1e-9)
    coef = _monotone_lsq(design * w[:, None], targets * w[:, None], eps=1e-3 * span / len(knots))
    return Spline(knots, coef, k)


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
    spline = monotone_bspline(u, cells, round(len(cells) / knot_spacing))
    samples = spline(np.linspace(u[0], u[-1], n_samples or len(cells)))
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
