"""Compiled (Numba) kernels for reading long BVH clips; imported by :mod:`mjmotion.bvh` only
when a motion section is large (importing Numba costs about half a second).

Both kernels give exactly the floats of the NumPy reader they replace (``np.loadtxt`` and
:func:`mjmotion.rotations.euler_to_quat` followed by the axis change), checked bit for bit in
``tests/test_bvh.py``. Neither raises: on anything unusual the value parser returns ``IRREGULAR`` and the
caller takes the NumPy path, whose error messages name the line and token.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Exact powers of ten (10**22 is the largest exactly representable in float64).
_POW10 = np.array([10.0**k for k in range(23)])
#: Largest integer mantissa that converts to float64 exactly (2**53).
_MAX_EXACT = 1 << 53
#: :func:`parse_values`'s status for anything irregular (the caller then takes the NumPy path).
IRREGULAR = -1
_DEG = math.pi / 180.0  # np.radians multiplies by this constant


@njit(cache=True, nogil=True)
def parse_values(buf: np.ndarray, start: int, out: np.ndarray, deferred: np.ndarray) -> int:  # pragma: no cover - compiled
    """Parse the motion section ``buf[start:]`` (``uint8`` bytes) into ``out: (frames, C) float64``.

    Accepts lines of exactly ``C`` decimal numbers (``[+-]digits[.digits][e[+-]digits]``)
    separated by spaces or tabs, ending in LF, CRLF or CR; blank lines are skipped; there must be
    exactly ``frames`` value lines. A number is converted here when Clinger's fast path makes it
    exact (an integer mantissa up to 2**53 times or over an exact power of ten: one correctly
    rounded operation, as ``np.loadtxt``'s conversion is); otherwise (long mantissa, exponent
    beyond ±22) its ``(start, end, row, col)`` goes into ``deferred: (K, 4) int64`` for the
    caller to convert with ``float``. Returns the number deferred, or ``IRREGULAR`` (anything
    else: another byte, a wrong count, more than K deferred) without raising.
    """
    n = buf.size
    frames, n_channels = out.shape
    pow10 = _POW10
    i = start
    n_deferred = 0
    row = 0
    col = 0
    while i < n:
        b = buf[i]
        if b == 32 or b == 9:
            i += 1
            continue
        if b == 10 or b == 13:
            if col != 0:
                if col != n_channels:
                    return IRREGULAR
                row += 1
                col = 0
            i += 1
            continue
        if row >= frames or col >= n_channels:
            return IRREGULAR
        tok = i
        neg = b == 45
        if neg or b == 43:
            i += 1
        mant = 0
        d0 = i
        while i < n:
            d = np.int64(buf[i]) - 48
            if d < 0 or d > 9:
                break
            mant = mant * 10 + d
            i += 1
        digits = i - d0
        exp10 = 0
        if i < n and buf[i] == 46:
            i += 1
            f0 = i
            while i < n:
                d = np.int64(buf[i]) - 48
                if d < 0 or d > 9:
                    break
                mant = mant * 10 + d
                i += 1
            exp10 = f0 - i
            digits += i - f0
        if digits == 0:
            return IRREGULAR
        if i < n:
            b = buf[i]
            if b == 101 or b == 69:
                i += 1
                eneg = False
                if i < n and (buf[i] == 45 or buf[i] == 43):
                    eneg = buf[i] == 45
                    i += 1
                e = 0
                e0 = i
                while i < n:
                    d = np.int64(buf[i]) - 48
                    if d < 0 or d > 9:
                        break
                    if e < 100000:
                        e = e * 10 + d
                    i += 1
                if i == e0:
                    return IRREGULAR
                exp10 += -e if eneg else e
                if i < n:
                    b = buf[i]
                else:
                    b = 10
            if not (b == 32 or b == 9 or b == 10 or b == 13):
                return IRREGULAR
        if digits > 18 or mant > _MAX_EXACT or exp10 > 22 or exp10 < -22:  # (> 18: int64 may overflow)
            if n_deferred == deferred.shape[0]:
                return IRREGULAR
            deferred[n_deferred, 0] = tok
            deferred[n_deferred, 1] = i
            deferred[n_deferred, 2] = row
            deferred[n_deferred, 3] = col
            n_deferred += 1
            col += 1
            continue
        v = float(mant)
        if exp10 < 0:
            v = v / pow10[-exp10]
        elif exp10 > 0:
            v = v * pow10[exp10]
        out[row, col] = -v if neg else v
        col += 1
    if col != 0:
        if col != n_channels:
            return IRREGULAR
        row += 1
    return n_deferred if row == frames else IRREGULAR


@njit(cache=True, nogil=True)
def euler_quats(values: np.ndarray, cols: np.ndarray, axes: np.ndarray, perm: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Local quaternions of every joint and frame from BVH Euler channels, in the world's axes.

    ``values: (T, C)`` degrees; ``cols, axes: (J, 3) int64`` each joint's rotation columns in
    channel order and their axes (0, 1, 2 for X, Y, Z; ``-1`` pads joints with fewer than three);
    ``perm: (3,)`` the axis change as a permutation, world component ``i`` = file component
    ``perm[i]``; ``out: (T, J, 4)`` wxyz.

    Each channel right-multiplies by the axis quaternion ``(cos h, sin h e_k)``; written with
    the non-zero terms of :func:`mjmotion.rotations.multiply` in their order, so the floats are
    identical. ``sin``/``cos`` of a column are reused while its value repeats (often a third).
    """
    t_count, j_count = out.shape[0], out.shape[1]
    n_cols = values.shape[1]
    bits = values.view(np.int64)  # a column's sine and cosine are reused while its bits repeat
    cos_c = np.empty(n_cols)
    sin_c = np.empty(n_cols)
    last = np.empty(n_cols, np.int64)
    seen = np.zeros(n_cols, np.bool_)
    p0, p1, p2 = perm[0], perm[1], perm[2]
    for t in range(t_count):
        for j in range(j_count):
            w = 1.0
            x = 0.0
            y = 0.0
            z = 0.0
            for r in range(3):
                col = cols[j, r]
                if col < 0:
                    break
                key = bits[t, col]
                if seen[col] and key == last[col]:
                    c = cos_c[col]
                    s = sin_c[col]
                else:
                    h = 0.5 * (values[t, col] * _DEG)
                    c = math.cos(h)  # LLVM fuses the pair into one sincos call
                    s = math.sin(h)
                    cos_c[col] = c
                    sin_c[col] = s
                    last[col] = key
                    seen[col] = True
                # (w, v) ⊗ (c, s e_k): for axis k, with (i, j) the next two axes cyclically,
                # w' = w c - v_k s, v_k' = w s + v_k c, v_i' = v_i c + v_j s, v_j' = v_j c - v_i s.
                k = axes[j, r]
                if k == 0:
                    w, x, y, z = w * c - x * s, w * s + x * c, y * c + z * s, z * c - y * s
                elif k == 1:
                    w, y, z, x = w * c - y * s, w * s + y * c, z * c + x * s, x * c - z * s
                else:
                    w, z, x, y = w * c - z * s, w * s + z * c, x * c + y * s, y * c - x * s
            out[t, j, 0] = w
            v = (x, y, z)
            out[t, j, 1] = v[p0]
            out[t, j, 2] = v[p1]
            out[t, j, 3] = v[p2]
