"""Coordinate alignment along a timewarp: the floor transform moving clip B onto clip A (seed 000 §3.2)."""

from __future__ import annotations

import numpy as np

from .grid import DEFAULT_WINDOW, rigid_2d


def gaussian_smooth(x: np.ndarray, sigma: float, truncate: float = 4.0) -> np.ndarray:
    """``x: (N, C)`` smoothed along axis 0 by a Gaussian of ``sigma`` samples, edges repeated.

    SciPy's ``gaussian_filter1d(x, sigma, axis=0, mode="nearest", truncate=truncate)`` (same
    kernel, agreement checked in the tests), written out so that registering clips does not
    import SciPy (~0.3 s of a fresh ``mjmotion register``).
    """
    r = int(truncate * float(sigma) + 0.5)
    kernel = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(np.asarray(x, dtype=float), ((r, r), (0, 0)), mode="edge")
    return np.lib.stride_tricks.sliding_window_view(padded, 2 * r + 1, axis=0) @ kernel


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
        out = gaussian_smooth(out, smooth_frames)
    return out
