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
from numpy.lib.stride_tricks import sliding_window_view

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


def _window_clouds(
    positions: np.ndarray,
    window: int,
    weights: np.ndarray,
    xy: np.ndarray,
    z: np.ndarray,
    scale: float = 1.0,
    z_scale: float = 1.0,
    frames: np.ndarray | None = None,
) -> np.ndarray:
    """Weighted, horizontally centred window clouds of one clip, written into GEMM operands.

    ``positions: (T, J, 3)``, ``weights: (J,)`` (joints of weight zero are left out); ``frames``:
    only the windows around these frames (``F`` of them, default all ``T``). Writes ``xy: (F, 2, P)`` the horizontal features (each window centred on its weighted mean, times
    ``scale·√w``) and ``z: (F, P)`` the heights times ``z_scale·√w`` (both may be views into
    larger operands; ``P = K·J'``); returns ``norms: (T,)`` each window's weighted squared norm
    (``(F,)``: horizontal, centred, plus heights; unscaled). Point ``k·J' + j`` is kept joint ``j`` at frame
    ``t + k − L``; windows are clamped at the clip's ends (edge frames repeat). The clip is
    gathered and weighted once, per coordinate, into one ``(3, T+2L, J')`` buffer; window ``t`` is
    then the contiguous run of ``P`` values from frame ``t`` on, a view of it, so the only ``K``-fold
    writes are the operands themselves (the weights sum to one over a window, seed 004 §4.2.1).
    """
    t = positions.shape[0]
    k = 2 * window + 1
    joints = np.flatnonzero(weights > 0)
    n_j = len(joints)
    wn = weights[joints] / (k * weights[joints].sum())  # per point of a window: Σ over the window = 1
    sw = np.sqrt(wn)
    factor = np.stack([scale * sw, scale * sw, z_scale * sw])[:, None, :]  # (3, 1, J')
    coords = np.empty((3, t + 2 * window, n_j))
    np.multiply(np.take(positions, joints, axis=1).transpose(2, 0, 1), factor, out=coords[:, window : window + t])
    coords[:, :window] = coords[:, window : window + 1]  # clamped ends: edge frames repeat
    coords[:, window + t :] = coords[:, window + t - 1 : window + t]
    mean = sliding_window_view(coords[:2] @ sw, k, axis=1).sum(axis=-1)  # (2, T) window means × scale
    win = sliding_window_view(coords.reshape(3, -1), k * n_j, axis=1)[:, ::n_j]  # (3, T, P) views, unit stride
    if frames is not None:  # only these windows are written (the self-similarity's subsample)
        win, mean = win[:, frames], mean[:, frames]
    np.subtract(win[:2], np.multiply.outer(mean, np.tile(sw, k)), out=xy.transpose(1, 0, 2))
    z[...] = win[2]
    norms = np.einsum("tcp,tcp->t", xy, xy) / scale**2
    norms += np.einsum("tp,tp->t", z, z) / z_scale**2
    return norms


def grid_operands(
    positions_a: np.ndarray,
    positions_b: np.ndarray,
    weights: np.ndarray,
    window: int,
    frames_a: np.ndarray | None = None,
    frames_b: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The two matrix products of :func:`distance_grid`: ``(left, right, left_z, right_z)``.

    ``left @ right.T`` is ``(2nA, nB)``: ``2a`` over ``2b`` (``left = 2·[[x, y], [y, −x]]_A``,
    ``right = [x, y]_B``); ``left_z @ right_z.T`` is ``(nA, nB)``, the height term and both
    windows' norms in one product (``[−2 z, |c|², 1]_A · [z, 1, |c|²]_Bᵀ``), so the cost needs
    only ``√(a² + b²)`` and one subtraction after the products. ``weights: (J,)``, joints of
    weight zero left out; ``frames_a``, ``frames_b``: only these frames' rows (``nA``, ``nB`` of
    them; windows still from the whole clips). Every operand is written once, in place (the scales
    2 and −2 are exact).
    """
    pa, pb = np.asarray(positions_a, dtype=float), np.asarray(positions_b, dtype=float)
    n_a = len(pa) if frames_a is None else len(frames_a)
    n_b = len(pb) if frames_b is None else len(frames_b)
    p = (2 * window + 1) * int(np.count_nonzero(weights > 0))
    left = np.empty((2, n_a, 2, p))
    left_z = np.empty((n_a, p + 2))
    left_z[:, p] = _window_clouds(pa, window, weights, left[0], left_z[:, :p], 2.0, -2.0, frames_a)
    left_z[:, p + 1] = 1.0
    left[1, :, 0] = left[0, :, 1]
    np.negative(left[0, :, 0], out=left[1, :, 1])
    right = np.empty((n_b, 2, p))
    right_z = np.empty((n_b, p + 2))
    right_z[:, p + 1] = _window_clouds(pb, window, weights, right, right_z[:, :p], frames=frames_b)
    right_z[:, p] = 1.0
    return left.reshape(2 * n_a, 2 * p), right.reshape(n_b, 2 * p), left_z, right_z


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


class GridTooLarge(MjmotionError):
    """A distance grid too large to register (:func:`check_grid_size`); ``cells`` and ``factor`` (how many
    times lower both clips' frame rates must be) let a caller word the remedy in its own options."""

    def __init__(self, message: str, cells: int, max_cells: int, factor: int):
        super().__init__(message)
        self.cells, self.max_cells, self.factor = cells, max_cells, factor


def check_grid_size(n_a: int, n_b: int, max_cells: int = MAX_CELLS) -> None:
    """Refuse grids that would not fit in memory, saying what to do instead (``register``'s options)."""
    cells = n_a * n_b
    if cells > max_cells:
        factor = math.ceil(math.sqrt(cells / max_cells))
        raise GridTooLarge(
            f"registering {n_a} × {n_b} frames needs a {cells:,}-cell grid (about {cells * 11 / 1e9:.1f} GB "
            f"with the path search), above the {max_cells:,}-cell limit; register shorter excerpts "
            f"(--frames) or resample both clips at least {factor}× lower (--fps)",
            cells,
            max_cells,
            factor,
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
    Two matrix products (:func:`grid_operands`) carry every sum; they run in blocks of rows whose
    products stay in one reused 2 MB buffer (:data:`BLOCK_BYTES`), so ``√(a² + b²)``, the
    subtraction and the clamp at zero run on each block while it is in cache and no ``2nA × nB``
    temporary is allocated: the only fresh ``nA × nB`` array is the cost itself.
    """
    pa, pb = np.asarray(positions_a, dtype=float), np.asarray(positions_b, dtype=float)
    if pa.ndim != 3 or pb.ndim != 3 or pa.shape[1:] != pb.shape[1:] or pa.shape[2] != 3:
        raise MjmotionError(f"distance_grid needs (T, J, 3) positions with equal J, got {pa.shape} and {pb.shape}")
    if window < 0:
        raise MjmotionError(f"the window half-width must be ≥ 0 frames, got {window}")
    rows = None if frames_a is None else np.asarray(frames_a, dtype=int)
    cols = None if frames_b is None else np.asarray(frames_b, dtype=int)
    check_grid_size(len(pa) if rows is None else len(rows), len(pb) if cols is None else len(cols), max_cells)
    w = np.ones(pa.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    operands = grid_operands(pa, pb, w, window, rows, cols)  # joints of weight zero left out
    return Grid(cost=_blocked_cost(*operands), window=window)


#: Bytes of the reused block of ``2a, 2b`` products in :func:`distance_grid`: a few large blocks (fewer GEMM calls) measured best.
BLOCK_BYTES = 1 << 21


def _blocked_cost(left: np.ndarray, right: np.ndarray, left_z: np.ndarray, right_z: np.ndarray) -> np.ndarray:
    """``max(left_z @ right_zᵀ − √(a² + b²), 0)`` with ``[2a; 2b] = left @ rightᵀ``, block by block of rows.

    ``left: (2nA, P)``, ``right: (nB, P)``, ``left_z: (nA, Q)``, ``right_z: (nB, Q)`` → ``(nA, nB)``.
    Each block's products land in one preallocated buffer and the cost rows (``out=``), and the
    element-wise terms run in place there, on rows still in cache.
    """
    n_a, n_b = len(left_z), len(right_z)
    halves = left.reshape(2, n_a, -1)
    cost = np.empty((n_a, n_b))
    step = max(1, min(n_a, BLOCK_BYTES // (16 * max(n_b, 1))))
    buf = np.empty((2, step, n_b))
    rt, rzt = right.T, right_z.T
    for i0 in range(0, n_a, step):
        i1 = min(i0 + step, n_a)
        ab, out = buf[:, : i1 - i0], cost[i0:i1]
        np.matmul(halves[0, i0:i1], rt, out=ab[0])  # 2a
        np.matmul(halves[1, i0:i1], rt, out=ab[1])  # 2b
        np.matmul(left_z[i0:i1], rzt, out=out)  # Σw|c|² + Σw|c'|² + heights, before the rotation term
        np.multiply(ab, ab, out=ab)  # 2√(a² + b²) in three in-place passes (np.hypot is slower)
        np.add(ab[0], ab[1], out=ab[0])
        np.subtract(out, np.sqrt(ab[0], out=ab[0]), out=out)
        np.copyto(out, 0.0, where=out < 0.0)  # round-off can dip a hair below zero (faster than np.maximum)
    return cost


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
