"""Smoothing before differentiating, as biomechanics does for marker data.

Differentiating captured positions amplifies marker noise (at 120 fps, 1 mm of noise is ~85 mm/s
of speed and ~14 m/s² of acceleration). The judge smooths first, two ways:

- :func:`lowpass`: a 2nd-order Butterworth filter run forwards and backwards (zero lag; Winter,
  *Biomechanics and Motor Control of Human Movement*, ch. 2, uses 6 Hz for walking), for the
  accelerations of inverse dynamics;
- :func:`velocity`: the derivative of a local quadratic fitted over a short window
  (Savitzky–Golay), for foot speeds: it keeps a foot's start from rest sharp, where a 6 Hz
  low-pass would spread a swing's speed a tenth of a second into the still plant beside it.

Both are written out here (SciPy's ``butter``/``filtfilt`` and ``savgol_filter`` give the same
numbers, ``tests/test_filters.py``) because importing ``scipy.signal`` pulls in ``scipy.stats``,
``interpolate`` and ``optimize``: over a second, half of a one-clip ``mjmotion evaluate``. The
recursion runs as one banded triangular solve per pass (LAPACK's ``dtbtrs``: forward substitution,
the recursion itself, for every column at once; 2.3x faster than ``solve_banded``'s banded LU).
"""

from __future__ import annotations

import functools

import numpy as np

from . import rotations as rot


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float | None, axis: int = 0) -> np.ndarray:
    """``x`` (any shape) low-pass filtered along ``axis`` (frames at ``fps``), zero lag.

    Each end is padded with the quadratic fitted to its first (last) frames, about three filter
    time constants long, so a constant acceleration (a ballistic flight, a steady turn) passes
    through unbent right up to the clip's ends — SciPy's default odd padding keeps only slopes.
    ``cutoff_hz=None`` or a cutoff at or above Nyquist returns ``x`` unchanged, as do clips under
    4 frames.
    """
    n = x.shape[axis]
    if cutoff_hz is None or n < 4 or cutoff_hz >= 0.5 * fps * 0.999:
        return x
    b, a = _butter(float(cutoff_hz) / (0.5 * fps))
    y = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    pad = int(np.ceil(3.0 * fps / cutoff_hz))
    fit = min(n, max(3, pad // 2))
    head, tail = _extrapolate(y[:fit][::-1], pad)[::-1], _extrapolate(y[n - fit :], pad)
    padded = np.concatenate([head, y, tail])
    out = _iir_pass(b, a, _iir_pass(b, a, padded)[::-1])[::-1][pad : pad + n]
    return np.moveaxis(out, 0, axis)


def _iir_pass(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x (N, ...)`` through the 2nd-order recursion ``Σ a_k y[n−k] = Σ b_k x[n−k]`` (``a_0 = 1``)
    along axis 0, started in the steady state of its first sample (as if ``x[0]`` had always been
    the input: SciPy's ``lfilter`` with ``lfilter_zi(b, a) · x[0]``, what ``filtfilt`` does).

    The recursion is the banded lower-triangular system ``L y = B x``: solved in one call for
    every column."""
    from scipy.linalg.lapack import dtbtrs

    n = x.shape[0]
    flat = x.reshape(n, -1)
    gain = b.sum() / a.sum()  # the steady state's output per unit input
    prev_x = np.concatenate([flat[:1], flat[:-1]])  # x[n-1], with x[-1] = x[0]
    prev2_x = np.concatenate([flat[:1], flat[:1], flat[:-2]])[:n]  # x[n-2], with x[-2] = x[-1] = x[0]
    rhs = b[0] * flat + b[1] * prev_x + b[2] * prev2_x
    # Past outputs before the first sample (the steady state's) move to the right-hand side.
    rhs[0] -= (a[1] + a[2]) * gain * flat[0]
    if n > 1:
        rhs[1] -= a[2] * gain * flat[0]
    band = np.zeros((3, n))
    band[0] = 1.0
    band[1, :-1] = a[1]
    band[2, :-2] = a[2]
    y, info = dtbtrs(band, rhs, uplo="L", diag="U")
    if info != 0:  # a unit diagonal cannot be singular: only a malformed argument gets here
        raise ValueError(f"dtbtrs: info {info}")
    return y.reshape(x.shape)


def _extrapolate(y: np.ndarray, pad: int) -> np.ndarray:
    """The ``pad`` frames after ``y (m, ...)`` on the least-squares quadratic through it."""
    m = y.shape[0]
    t = np.arange(m, dtype=float) - (m - 1)
    basis = np.stack([np.ones(m), t, t * t], axis=1)  # (m, 3)
    coef = np.linalg.lstsq(basis, y.reshape(m, -1), rcond=None)[0]  # (3, K)
    s = np.arange(1, pad + 1, dtype=float)
    return (np.stack([np.ones(pad), s, s * s], axis=1) @ coef).reshape((pad,) + y.shape[1:])


@functools.lru_cache(maxsize=32)
def _butter(wn: float) -> tuple[np.ndarray, np.ndarray]:
    """The 2nd-order digital Butterworth low-pass at ``wn`` × Nyquist: the analogue prototype
    ``1 / (s² + √2 s + 1)`` at the pre-warped cutoff ``tan(π wn / 2)``, bilinear transform."""
    w = np.tan(0.5 * np.pi * wn)
    k = w * w
    norm = 1.0 + np.sqrt(2.0) * w + k
    b = np.array([k, 2.0 * k, k]) / norm
    a = np.array([1.0, 2.0 * (k - 1.0) / norm, (1.0 - np.sqrt(2.0) * w + k) / norm])
    return b, a


def lowpass_quaternions(q: np.ndarray, fps: float, cutoff_hz: float | None) -> np.ndarray:
    """Unit quaternions ``(T, ..., 4)`` low-pass filtered over frames: signs made continuous,
    components filtered, renormalised (exact to first order for the small steps between frames)."""
    if cutoff_hz is None or q.shape[0] < 4:
        return q
    return rot.normalize(lowpass(rot.make_continuous(q), fps, cutoff_hz))


def velocity(x: np.ndarray, fps: float, window: float | None) -> np.ndarray:
    """``dx/dt`` over frames (axis 0) at ``fps``: the slope of the least-squares quadratic through
    the ``window`` seconds around each frame (an odd number of frames, at least 5; Savitzky–Golay,
    ends fitted to the nearest full window), or central differences with ``window=None`` or clips
    shorter than the window."""
    n = x.shape[0]
    frames = max(5, int(round(window * fps)) | 1) if window is not None else 0
    if window is None or n < frames:
        return np.gradient(x, 1.0 / fps, axis=0) if n > 1 else np.zeros_like(x)
    half = frames // 2
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    # Inside: a centred quadratic's slope is the centred line's, Σ k x[t+k] / Σ k².
    k = np.arange(-half, half + 1, dtype=float)
    k /= (k * k).sum()
    inner = np.zeros_like(x[half : n - half])
    for i, c in enumerate(k):
        if c:
            inner += c * x[i : n - frames + 1 + i]
    out[half : n - half] = inner
    # Ends: the quadratic through the first (last) full window, its slope at each end frame.
    t = np.arange(frames, dtype=float)
    fit = np.linalg.pinv(np.stack([np.ones(frames), t, t * t], axis=1))  # (3, frames)
    slope = fit[1] + 2.0 * t[:, None] * fit[2]  # (frames, frames): slope at frame i of the window
    out[:half] = np.tensordot(slope[:half], x[:frames], axes=1)
    out[n - half :] = np.tensordot(slope[frames - half :], x[n - frames :], axes=1)
    return out * fps


def _windows(x: np.ndarray, size: int, axis: int, pad: str | float) -> np.ndarray:
    """``x`` padded by ``size // 2`` along ``axis`` (its edge values, ``pad="edge"``, or the constant
    ``pad``) and viewed as its centred ``size``-frame windows along a new last axis."""
    half = size // 2
    widths = [(0, 0)] * x.ndim
    widths[axis] = (half, size - 1 - half)
    padded = np.pad(x, widths, mode="edge") if pad == "edge" else np.pad(x, widths, mode="constant", constant_values=pad)
    return np.lib.stride_tricks.sliding_window_view(padded, size, axis=axis)


def dilate(mask: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Boolean ``mask`` true wherever it is true within the centred ``size`` frames along ``axis``,
    the ends extended by their own values (``scipy.ndimage.maximum_filter1d``, ``mode="nearest"``,
    whose import the judge spares)."""
    return np.asarray(_windows(np.asarray(mask, dtype=bool), size, axis, "edge").any(axis=-1))


def erode(mask: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Boolean ``mask`` true only where it is true over all the centred ``size`` frames along
    ``axis``, false beyond the ends (``scipy.ndimage.minimum_filter1d``, ``mode="constant"``, ``cval=0``)."""
    return np.asarray(_windows(np.asarray(mask, dtype=bool), size, axis, False).all(axis=-1))


def moving_mean(x: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Mean of the centred ``size`` frames along ``axis``, the ends extended by their own values
    (``scipy.ndimage.uniform_filter1d``, ``mode="nearest"``; equal to rounding)."""
    return _windows(np.asarray(x, dtype=float), size, axis, "edge").mean(axis=-1)
