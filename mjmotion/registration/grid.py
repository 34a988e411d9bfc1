"""The registration grid: frame-to-frame distances of two clips (seed 000 §3.1 Eq. 2–5).

For every frame pair, the weighted squared distance between the point clouds of joint positions
over a ``2L+1``-frame window, minimised over a rotation about the vertical axis and a floor
translation, in closed form; every sum is a matrix product.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import MjmotionError
from ..skeleton import Skeleton

#: Default half-window L: clouds of 2L+1 = 5 frames (seed 000 §3.1, Kovar & Gleicher).
DEFAULT_WINDOW = 2
#: Largest grid (cells) built in memory: 5000 × 5000 float64 is 200 MB plus the DP's int8 tables.
MAX_CELLS = 25_000_000
#: Joints that carry no gait information in our clips (fingers, eyes hold constant poses).
_UNWEIGHTED = re.compile(r"finger|thumb|index|mid\d|ring|pinky|eye|carpal|nub", re.IGNORECASE)


def joint_weights(skeleton: Skeleton, weights: dict[str, float] | None = None) -> np.ndarray:
    """Per-joint weights ``(J,)``: 1 for body joints, 0 for fingers and eyes, overridden by ``weights``.

    ``weights`` maps joint names to non-negative numbers (unknown names are an error).
    """
    w = np.array([0.0 if _UNWEIGHTED.search(n) else 1.0 for n in skeleton.names])
    for name, value in (weights or {}).items():
        if not (np.isfinite(value) and value >= 0):
            raise MjmotionError(f"joint weight for {name!r} must be a non-negative number, got {value}")
        w[skeleton.index(name)] = float(value)
    if w.sum() <= 0:
        raise MjmotionError("every joint weight is zero; at least one joint must count in the distance")
    return w


def _window_clouds(positions: np.ndarray, window: int, weights: np.ndarray) -> dict[str, np.ndarray]:
    """Weighted, horizontally centred window clouds of one clip.

    ``positions: (T, J, 3)`` → features ``(T, K·J)`` per axis (already multiplied by √w, the
    horizontal ones centred on each window's weighted mean), the means ``(T, 2)`` and the
    weighted squared norms ``(T,)``. Windows are clamped at the clip's ends (edge frames repeat).
    """
    t, j, _ = positions.shape
    k = 2 * window + 1
    idx = np.clip(np.arange(t)[:, None] + np.arange(-window, window + 1)[None, :], 0, t - 1)
    cloud = positions[idx].reshape(t, k * j, 3)  # (T, K·J, 3)
    w = np.tile(weights, k)
    w = w / w.sum()  # Σ w = 1 over the cloud (seed 004 §4.2.1)
    mean = np.einsum("p,tpc->tc", w, cloud[:, :, :2])
    sw = np.sqrt(w)
    cx = (cloud[:, :, 0] - mean[:, 0:1]) * sw
    cy = (cloud[:, :, 1] - mean[:, 1:2]) * sw
    cz = cloud[:, :, 2] * sw
    return {
        "x": cx,
        "y": cy,
        "z": cz,
        "mean": mean,
        "hh": np.einsum("tp,tp->t", cx, cx) + np.einsum("tp,tp->t", cy, cy),
        "zz": np.einsum("tp,tp->t", cz, cz),
    }


@dataclass(frozen=True)
class Grid:
    """Frame-to-frame distances of two clips.

    Attributes:
        cost: ``(nA, nB)`` float64, m² — weighted mean squared point distance after the best 2D
            rigid alignment (seed 000 Eq. 2; weights sum to one over each cloud).
        window: the half-window ``L`` (clouds of ``2L+1`` frames).
    """

    cost: np.ndarray
    window: int


def check_grid_size(n_a: int, n_b: int, max_cells: int = MAX_CELLS) -> None:
    """Refuse grids that would not fit in memory, saying what to do instead."""
    cells = n_a * n_b
    if cells > max_cells:
        factor = math.ceil(math.sqrt(cells / max_cells))
        raise MjmotionError(
            f"registering {n_a} × {n_b} frames needs a {cells:,}-cell grid (about {cells * 11 / 1e9:.1f} GB "
            f"with the path search), above the {max_cells:,}-cell limit; register shorter excerpts "
            f"(--frames) or resample both clips at least {factor}× lower (--fps)"
        )


def distance_grid(
    positions_a: np.ndarray,
    positions_b: np.ndarray,
    weights: np.ndarray | None = None,
    window: int = DEFAULT_WINDOW,
    max_cells: int = MAX_CELLS,
    frames_a: np.ndarray | None = None,
    frames_b: np.ndarray | None = None,
) -> Grid:
    """The registration grid (seed 000 §3.1 Eq. 2–5), every sum a matrix product.

    ``positions_a: (nA, J, 3)``, ``positions_b: (nB, J, 3)`` world joint positions (metres);
    ``weights: (J,)`` non-negative (default 1); ``frames_a``, ``frames_b``: only these frames'
    rows and columns (windows still from the whole clips). Cell ``[i, j]`` is
    ``min_{θ,t} Σ_k w_k ‖p_k − (R_θ p'_k + t)‖²`` over the windows around frame ``i`` of A and
    frame ``j`` of B. After centring each window on its weighted mean, with
    ``a = Σ w (x x' + y y')`` and ``b = Σ w (y x' − x y')`` the optimum is ``θ = atan2(b, a)`` and
    the horizontal residual ``Σ w|c|² + Σ w|c'|² − 2√(a² + b²)``; heights add ``Σ w (z − z')²``.
    """
    pa, pb = np.asarray(positions_a, dtype=float), np.asarray(positions_b, dtype=float)
    if pa.ndim != 3 or pb.ndim != 3 or pa.shape[1:] != pb.shape[1:] or pa.shape[2] != 3:
        raise MjmotionError(f"distance_grid needs (T, J, 3) positions with equal J, got {pa.shape} and {pb.shape}")
    if window < 0:
        raise MjmotionError(f"the window half-width must be ≥ 0 frames, got {window}")
    rows = np.arange(len(pa)) if frames_a is None else np.asarray(frames_a, dtype=int)
    cols = np.arange(len(pb)) if frames_b is None else np.asarray(frames_b, dtype=int)
    check_grid_size(len(rows), len(cols), max_cells)
    w = np.ones(pa.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    keep = w > 0  # joints of weight zero add nothing but work
    ca, cb = _window_clouds(pa[:, keep], window, w[keep]), _window_clouds(pb[:, keep], window, w[keep])
    if frames_a is not None or frames_b is not None:
        ca, cb = {k: v[rows] for k, v in ca.items()}, {k: v[cols] for k, v in cb.items()}
    # a and b from one product: [[x, y], [y, −x]]_A · [x, y]_Bᵀ
    right = np.concatenate([cb["x"], cb["y"]], axis=1)
    left = np.block([[ca["x"], ca["y"]], [ca["y"], -ca["x"]]])
    ab = left @ right.T
    a, b = ab[: len(rows)], ab[len(rows) :]
    zz = ca["z"] @ cb["z"].T
    cost = ca["hh"][:, None] + cb["hh"][None, :] - 2.0 * np.hypot(a, b)
    cost += ca["zz"][:, None] + cb["zz"][None, :] - 2.0 * zz
    np.maximum(cost, 0.0, out=cost)  # round-off can dip a hair below zero
    return Grid(cost=cost, window=window)


def rigid_2d(cloud_a: np.ndarray, cloud_b: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Best floor transforms moving clouds B onto clouds A (seed 000 Eq. 3–5).

    ``cloud_a, cloud_b: (N, P, 3)`` corresponding points, ``weights: (P,)`` → ``(N, 3)`` rows
    ``[theta, tx, ty]`` such that ``Rz(theta) p' + (tx, ty)`` best matches ``p`` on the floor.
    """
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    ma = np.stack([cloud_a[:, :, 0] @ w, cloud_a[:, :, 1] @ w], axis=1)  # (N, 2) weighted means
    mb = np.stack([cloud_b[:, :, 0] @ w, cloud_b[:, :, 1] @ w], axis=1)
    ax, ay = cloud_a[:, :, 0] - ma[:, :1], cloud_a[:, :, 1] - ma[:, 1:]
    bx, by = cloud_b[:, :, 0] - mb[:, :1], cloud_b[:, :, 1] - mb[:, 1:]
    a = (ax * bx + ay * by) @ w
    b = (ay * bx - ax * by) @ w
    theta = np.arctan2(b, a)
    c, s = np.cos(theta), np.sin(theta)
    tx = ma[:, 0] - (c * mb[:, 0] - s * mb[:, 1])
    ty = ma[:, 1] - (s * mb[:, 0] + c * mb[:, 1])
    return np.stack([theta, tx, ty], axis=1)
