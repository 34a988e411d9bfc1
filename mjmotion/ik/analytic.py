"""Analytic two-bone IK (a leg or an arm), vectorised over frames.

Shared by the footskate cleanup (legs onto their plants), the variations' cleanup (feet back
on their footprints, the second hand back on the club) and the launch grid (an arm re-aimed at a
new hit point, :mod:`mjmotion.launchgrid`). The middle joint bends about a given
axis to get the reach, then the upper joint swings the limb onto the target.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot


def shortest_arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Shortest rotations ``(T, 4)`` taking directions ``a`` onto ``b`` (``(T, 3)``); a half turn
    about x where they are opposite."""
    a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    w = 1.0 + np.sum(a * b, axis=-1, keepdims=True)
    q = np.concatenate([w, np.cross(a, b)], axis=-1)
    return rot.normalize(np.where(w > 1e-9, q, np.array([0.0, 1.0, 0.0, 0.0])))


#: A limb bent by less than this sine is straight: its bend plane is rounding noise (captured
#: "straight" knees cross at 1e-9 m²), so the fallback axis is used instead.
STRAIGHT_SINE = 1e-4


def bend_axes(top: np.ndarray, mid: np.ndarray, end: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Unit bend axes ``(T, 3)``: ``(mid − top) × (end − mid)``, or ``fallback`` where the limb is straight."""
    u, v = mid - top, end - mid
    n = np.cross(u, v)
    nn = np.linalg.norm(n, axis=-1, keepdims=True)
    lengths = np.linalg.norm(u, axis=-1, keepdims=True) * np.linalg.norm(v, axis=-1, keepdims=True)
    f = fallback / np.maximum(np.linalg.norm(fallback, axis=-1, keepdims=True), 1e-12)
    return np.where(nn > STRAIGHT_SINE * lengths, n / np.maximum(nn, 1e-12), f)


def two_bone(top: np.ndarray, mid: np.ndarray, end: np.ndarray, target: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotations that put ``end`` on ``target``, the bones keeping their lengths.

    ``top, mid, end, target: (T, 3)`` world positions (hip, knee, ankle); ``axis: (T, 3)`` unit
    bend axes (see :func:`bend_axes`). Returns world rotations ``r_top (T, 4)`` about ``top`` and
    ``r_mid (T, 4)`` about ``mid`` (applied before ``r_top``), and ``short (T,)``: how many metres
    the target stays out of reach (0 where reached; the reach is clamped to the limb's range).
    """
    u, v = mid - top, end - mid
    l1 = np.linalg.norm(u, axis=-1)
    l2 = np.linalg.norm(v, axis=-1)
    bend = np.arctan2(np.sum(np.cross(u, v) * axis, axis=-1), np.sum(u * v, axis=-1))
    d_raw = np.linalg.norm(target - top, axis=-1)
    d = np.clip(d_raw, np.abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6)
    cos_inner = np.clip((l1**2 + l2**2 - d**2) / np.maximum(2 * l1 * l2, 1e-12), -1.0, 1.0)
    r_mid = rot.exp(axis * (np.pi - np.arccos(cos_inner) - bend)[..., None])
    r_top = shortest_arc(u + rot.rotate(r_mid, v), target - top)
    return r_top, r_mid, np.abs(d_raw - d)


def two_bone_ik(
    top: np.ndarray, mid: np.ndarray, end: np.ndarray, target: np.ndarray, fallback: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`two_bone` with the bend axes chosen for a limb: its current bending plane, or
    ``fallback: (T, 3)`` where it is straight (default: perpendicular to the upper bone and the
    target; :func:`mjmotion.cleanup.knee_hinge_axis` gives a knee's own).

    ``top, mid, end, target: (T, 3)`` (hip, knee, ankle). Returns world rotations ``(T, 4)`` wxyz
    for the upper bone (``r_top``, about ``top``) and the lower bone (``r_mid``, about ``mid``,
    applied before ``r_top``), and ``reached: (T,)`` bool.
    """
    if fallback is None:
        fallback = np.cross(mid - top, target - top)
    axis = bend_axes(top, mid, end, fallback=fallback)
    r_top, r_mid, short = two_bone(top, mid, end, target, axis)
    return r_top, r_mid, short <= 1e-9
