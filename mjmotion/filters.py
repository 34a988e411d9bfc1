"""Smoothing before differentiating, as biomechanics does for marker data.

Differentiating captured positions amplifies marker noise (at 120 fps, 1 mm of noise is ~85 mm/s
of speed and ~14 m/s² of acceleration). The judge smooths first, two ways:

- :func:`lowpass`: a 2nd-order Butterworth filter run forwards and backwards (zero lag; Winter,
  *Biomechanics and Motor Control of Human Movement*, ch. 2, uses 6 Hz for walking), for the
  accelerations of inverse dynamics;
- :func:`velocity`: the derivative of a local quadratic fitted over a short window
  (Savitzky–Golay), for foot speeds: it keeps a foot's start from rest sharp, where a 6 Hz
  low-pass would spread a swing's speed a tenth of a second into the still plant beside it.

The operations share :func:`smooth_cover` (a smooth curve never below a need: how the cleanup
lifts a foot and the variations turn a collarbone without a step) and :func:`hann_smooth`.

Both filters are written out here (SciPy's ``butter``/``filtfilt`` and ``savgol_filter`` give the same
numbers, ``tests/test_filters.py``) because importing ``scipy.signal`` pulls in ``scipy.stats``,
``interpolate`` and ``optimize``: over a second, half of a one-clip ``mjmotion evaluate``. The
recursion runs in NumPy alone (even ``scipy.linalg`` costs 0.15-0.2 s to import in every fresh
process): an FFT convolution with its impulse response for a few columns, blocked matrix products for
many; ``benchmarks/bench_judge.py`` times both against ``filtfilt``.
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


#: From this many columns up a pass runs blockwise (its fixed cost, ~0.1-0.2 ms,
#: whatever the width), below as an FFT convolution (``benchmarks/bench_judge.py``).
BLOCKED_MIN_COLUMNS = 16


def _iir_pass(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x (N, ...)`` through the 2nd-order recursion ``Σ a_k y[n−k] = Σ b_k x[n−k]`` (``a_0 = 1``)
    along axis 0, started in the steady state of its first sample (as if ``x[0]`` had always been
    the input: SciPy's ``lfilter`` with ``lfilter_zi(b, a) · x[0]``, what ``filtfilt`` does).

    Narrow inputs: a convolution with the impulse response by FFT (:func:`_fft_pass`); wide ones
    (the judge's body centres and orientations, 100-230 columns): blockwise matrix products
    (:func:`_blocked_pass`)."""
    n = x.shape[0]
    flat = x.reshape(n, -1)
    y = _blocked_pass(b, a, flat) if flat.shape[1] >= BLOCKED_MIN_COLUMNS else _fft_pass(b, a, flat)
    return y.reshape(x.shape)


def _fft_pass(b: np.ndarray, a: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """:func:`_iir_pass` of ``flat (N, K)`` as a convolution with the impulse response ``h``, by
    FFT for every column at once, plus ``x[0]`` times the response's tail ``Σ_{k>n} h[k]`` (the
    input before the first sample). ``h`` is cut where it has decayed below 1e-17 of its sum, so
    the result is the recursion's to rounding."""
    n = flat.shape[0]
    h = _impulse_response(float(b[0]), float(b[1]), float(b[2]), float(a[1]), float(a[2]))
    h = h[: min(n, h.size)]
    size = _fft_size(n + h.size - 1)
    y = np.fft.irfft(np.fft.rfft(flat, size, axis=0) * np.fft.rfft(h, size)[:, None], size, axis=0)[:n]
    gain = b.sum() / a.sum()  # Σ h: the steady state's output per unit input
    tail = gain - np.cumsum(h)  # Σ_{k>m} h[k], (≤ n,)
    y[: tail.size] += tail[:, None] * flat[0]
    return y


def _blocked_pass(b: np.ndarray, a: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """:func:`_iir_pass` of ``flat (N, K)`` in ``nb`` blocks of ``B ≈ √N`` frames: each block's
    response from rest is one matrix product of its inputs (and the two before it) with the
    filter's response matrix (:func:`_block_response`), every block and column at once; then each
    block's start state is carried from the block before (a loop over the blocks, 2 × K numbers
    each) and its free response added. Matrix products and one loop of √N steps instead of a loop
    of N (the inputs are read in place, as overlapping windows: no copies per block)."""
    n, k = flat.shape
    size = max(4, int(np.sqrt(n)))
    nb = -(-n // size)
    a1, a2 = float(a[1]), float(a[2])
    # The inputs before the first sample are x[0] (the steady state); those after the last, 0.
    padded = np.zeros((nb * size + 2, k))
    padded[:2] = flat[0]
    padded[2 : n + 2] = flat
    step = padded.strides[0]
    windows = np.lib.stride_tricks.as_strided(padded, (nb, size + 2, k), (size * step, step, padded.strides[1]), writeable=False)
    z = np.matmul(_block_response(float(b[0]), float(b[1]), float(b[2]), a1, a2, size), windows)  # (nb, B, K)
    free = _free_responses(a1, a2, size)  # (B, 2): to y[-1] = 1 and to y[-2] = 1
    ends = free[[size - 1, size - 2]]  # (2, 2): a block's last two outputs from its start state
    state = np.empty((nb, 2, k))  # (y[-1], y[-2]) before each block
    prev = np.broadcast_to((b.sum() / a.sum()) * flat[0], (2, k))  # the steady state of x[0]
    last = z[:, [size - 1, size - 2]]
    for j in range(nb):
        state[j] = prev
        prev = last[j] + ends @ prev
    z += np.matmul(free, state)
    return z.reshape(nb * size, k)[:n]


@functools.lru_cache(maxsize=64)
def _block_response(b0: float, b1: float, b2: float, a1: float, a2: float, size: int) -> np.ndarray:
    """``(size, size + 2)``: a block's outputs from rest, ``y = H u``, from its inputs ``u`` (the two
    before the block, then its own): the moving average ``b0 x[i] + b1 x[i−1] + b2 x[i−2]``, then the
    recursion ``y[i] = z[i] − a1 y[i−1] − a2 y[i−2]`` from rest — the lower-triangular Toeplitz
    matrix of its impulse response ``g``."""
    # g[0] = 1, then the free response to y[-1] = 1 (the same recursion, the same floats).
    g = np.concatenate([[1.0], _free_responses(a1, a2, size)[: size - 1, 0]])
    lag = np.subtract.outer(np.arange(size), np.arange(size))
    rest = np.where(lag >= 0, g[np.maximum(lag, 0)], 0.0)  # (size, size)
    fir = np.zeros((size, size + 2))
    idx = np.arange(size)
    fir[idx, idx], fir[idx, idx + 1], fir[idx, idx + 2] = b2, b1, b0
    out = rest @ fir
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=64)
def _free_responses(a1: float, a2: float, size: int) -> np.ndarray:
    """``(size, 2)``: the recursion's output without input from ``y[-1] = 1, y[-2] = 0`` and from
    ``y[-1] = 0, y[-2] = 1``."""
    e = np.zeros((size + 2, 2))
    e[1, 0] = 1.0
    e[0, 1] = 1.0
    for i in range(2, size + 2):
        e[i] = -a1 * e[i - 1] - a2 * e[i - 2]
    out = e[2:].copy()
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=32)
def _impulse_response(b0: float, b1: float, b2: float, a1: float, a2: float) -> np.ndarray:
    """``h[k]`` of ``(b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)`` (complex poles ``p, p̄``, as
    every 2nd-order Butterworth low-pass has) until it has decayed below 1e-17 of its sum: by
    partial fractions, ``h[0] = b2/a2 + 2 Re r`` and ``h[k] = 2 Re(r pᵏ)``."""
    p = complex(-0.5 * a1, np.sqrt(max(a2 - 0.25 * a1 * a1, 0.0)))
    if p.imag == 0.0:  # (not a Butterworth low-pass: a real double pole would need another form)
        raise ValueError(f"the filter's poles are real (a1={a1}, a2={a2})")
    q = b2 / a2
    c0, c1 = b0 - q, b1 - q * a1  # what is left of b after taking q × a out
    r = (c0 * p + c1) / (2j * p.imag)
    length = int(np.ceil(np.log(1e-17) / np.log(abs(p)))) + 1
    k = np.arange(length)
    h = 2.0 * (r * np.exp(k * np.log(p))).real
    h[0] += q
    h.flags.writeable = False
    return h


def _fft_size(n: int) -> int:
    """The least ``2^i 3^j 5^k`` at or above ``n`` (lengths pocketfft transforms fastest)."""
    best = 1 << max(n - 1, 0).bit_length()
    f5 = 1
    while f5 < best:
        f35 = f5
        while f35 < best:
            size = f35
            while size < n:
                size *= 2
            best = min(best, size)
            f35 *= 3
        f5 *= 5
    return best


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


def moving_median(x: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Median of the centred ``size`` frames along ``axis``, the ends extended by their own values
    (``scipy.ndimage.median_filter`` along one axis, ``mode="nearest"``). Of 3 frames: a one-frame
    spike is gone, while ramps, steps and plateaus are left exactly as they are."""
    return np.median(_windows(np.asarray(x, dtype=float), size, axis, "edge"), axis=-1)


def hann_smooth(x: np.ndarray, half: int, axis: int = 0) -> np.ndarray:
    """Weighted mean of the centred ``2·half + 1`` frames along ``axis`` under a Hann window (its
    two zero end taps left out), the ends extended by their own values."""
    x = np.asarray(x, dtype=float)
    if half < 1:
        return x
    window = np.hanning(2 * half + 3)[1:-1]
    return np.asarray(_windows(x, 2 * half + 1, axis, "edge") @ (window / window.sum()))


def smooth_cover(x: np.ndarray, half: int, axis: int = 0) -> np.ndarray:
    """A smooth curve never below ``x``: the maximum over the centred ``2·half + 1`` frames along
    ``axis``, then :func:`hann_smooth` over as many (each frame's window holds only values at least
    its own), the ends extended by their own values. How the cleanup lifts a foot and the
    variations turn a collarbone without a step."""
    x = np.asarray(x, dtype=float)
    return hann_smooth(_windows(x, 2 * half + 1, axis, "edge").max(axis=-1), half, axis)
