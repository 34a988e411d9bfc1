"""Best effort where a goal cannot be reached: stop short along the offset, without jumps.

A target the arm cannot reach (beyond its limits, or with the club under the floor, or with the
second hand off the grip) is not chased: the goal is moved back along its offset to the nearest
point that can be reached (:func:`nearest_reachable`), and the shortened fractions of the
frames around it are made to change gradually (:func:`envelope`), so no joint has to jump
between a frame that reaches and one that does not. Where the importance blend would still make a
joint turn faster than it ever does in the source (a fast club sweeps the blend from 0 to 1 in a
few frames), :func:`paced_walk` lets the deviation ramp in and out at a bounded pace instead.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def nearest_reachable(margin: Callable[[float], float], length: float, start: float, resolution: float = 1e-3, max_evals: int = 40) -> float:
    """Largest fraction ``s ∈ [0, 1]`` of an offset of ``length`` metres whose ``margin(s) ≥ 0``, to ``resolution`` metres.

    ``margin(s)``: how much room the solution for fraction ``s`` has (negative: not reached);
    ``start = margin(0)`` (no offset: the source's own pose, which must be reached). The bracket
    between the last fraction that worked and the first that did not shrinks by the Illinois
    variant of regula falsi (a bisection step whenever the secant lands at the bracket's edge).
    """
    m_hi = margin(1.0)
    if length <= 0 or m_hi >= 0:
        return 1.0
    lo, hi, m_lo = 0.0, 1.0, max(float(start), 0.0)
    side = 0
    for _ in range(max_evals):
        if (hi - lo) * length <= resolution:
            break
        s = hi - m_hi * (hi - lo) / (m_hi - m_lo) if m_lo > m_hi else 0.5 * (lo + hi)
        edge = 0.05 * (hi - lo)
        if not lo + edge <= s <= hi - edge:
            s = 0.5 * (lo + hi)
        m = margin(s)
        if m >= 0:
            lo, m_lo = s, m
            if side == -1:
                m_hi *= 0.5  # Illinois: the end kept twice in a row counts for less
            side = -1
        else:
            hi, m_hi = s, m
            if side == 1:
                m_lo *= 0.5
            side = 1
    return lo


def envelope(fraction: np.ndarray, max_rate: float) -> np.ndarray:
    """The largest ``g ≤ fraction`` (``(T,)``, in [0, 1]) that changes by at most ``max_rate`` per frame.

    ``g_t = min_k (f_k + max_rate · |t − k|)`` over the shortened frames ``k`` (``f_k < 1``).
    """
    f = np.asarray(fraction, dtype=float)
    low = np.flatnonzero(f < 1.0)
    if not low.size:
        return f.copy()
    t = np.arange(len(f))
    g = np.min(f[low][None, :] + max_rate * np.abs(t[:, None] - low[None, :]), axis=1)
    return np.minimum(g, f)


def paced_walk(frames: np.ndarray, step_ok: Callable[[int, float], bool], accept: Callable[[int, float], None], iters: int = 10) -> int:
    """Walk ``frames`` in order (outward from a frame that is kept), letting each frame ``t`` go the
    largest fraction ``λ ∈ [0, 1]`` of the way from the previous frame's state to its own solution
    that ``step_ok(t, λ)`` allows (bisection; ``λ = 0`` holds the previous state).

    ``accept(t, λ)`` records frame ``t``'s choice (it becomes the previous state of the next frame).
    Returns the number of frames that could not take their own solution (``λ < 1``).
    """
    slowed = 0
    for t in frames:
        t = int(t)
        lam = 1.0
        if not step_ok(t, 1.0):
            lo, hi = 0.0, 1.0
            for _ in range(iters):
                mid = 0.5 * (lo + hi)
                if step_ok(t, mid):
                    lo = mid
                else:
                    hi = mid
            lam = lo
            slowed += 1
        accept(t, lam)
    return slowed
