"""A root path the ground can carry: the generated pelvis moved until the centre of pressure its
motion needs lies under the feet that stand.

The gaits, kick and punch are drawn kinematically: a pelvis on its path or keyed, arms and legs swinging. The
whole body's motion needs an external wrench (Newton–Euler over every body, :func:`mjmotion.physics.whole_body_wrench`);
the ground can supply it only through the planted soles, with the centre of pressure (CoP) inside
their support polygon, and a body in flight can only fall. Moving the root by ``d(t)`` (every
body alike) changes neither the angular momentum about the centre of mass nor the vertical force,
so the CoP moves linearly, ``p' = p + d − h d''`` with ``h = z_c / (g + a_z)`` (the height of the
centre of mass over its vertical acceleration: the cart-table relation of ZMP walking control,
Kajita et al. 2003). The pass takes the CoP's nearest point inside the support polygon (shrunk by
:data:`MARGIN`) as its target and solves one sparse least-squares problem for ``d``: the CoP on its
target in stance, no horizontal force in flight, ``d`` small and smooth; the clip then solves its
limbs again for the moved hips, so planted feet stay on their footprints.

- :func:`support_points` ``(compiled, pose, boxes) -> (points (T, N, 2), active (T, N))``
- :func:`target_cop` ``(cop, points, active, margin) -> (T, 2)``
- :func:`root_shift` ``(cop, h, target, stance, accel, fps) -> (T, 2)``
- :func:`cop_and_height` ``(compiled, motion, pose) -> (cop (T, 2), h (T,), loaded (T,), accel (T, 2))``
- :func:`balance_pass` ``(motion, stride) -> (T, 2)``: all of it, on a clip of the bundled humanoid
- :func:`rebalance` ``(pb, ankles, limbs, fps, stride)``: the pass applied to a clip being built
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from .. import feet, kinematics, mjcf, physics
from ..skeleton import Motion
from .body import PoseBuilder, compiled_model, lower_pelvis

#: The CoP's target lies this far inside the support polygon (m): the judge low-passes positions
#: before differentiating, which spreads a CoP on the polygon's edge a little outside it.
MARGIN = 0.03
#: A sole corner this close to the floor (m) bears weight.
BEARING = 0.01
#: Least-squares weights: CoP on target (per metre), no horizontal force in flight (per metre of
#: ``h·a``), the shift's size and its second difference (per metre).
W_COP, W_FLIGHT, W_SIZE, W_SMOOTH = 1.0, 1.0, 0.03, 0.3
#: ... and its mean over each stride (per metre): the pelvis sways about its path, it does not leave it.
W_MEAN = 30.0
#: ... and at the clip's first and last END_FRAMES frames (per metre): a clip starts and ends on its path.
W_END, END_FRAMES = 100.0, 3
#: Frames whose vertical force is under this fraction of body weight have no meaningful CoP.
MIN_LOAD = 0.2
#: Directions of the support polygon's edges: the feet's hull is taken as the polygon of its
#: supporting lines in these directions (exact up to 1 - cos(11.25 deg) = 2 % at a sharp corner).
DIRECTIONS = 16


def _model() -> tuple[mjcf.CompiledModel, np.ndarray]:
    """The bundled humanoid compiled, and its foot and toe box geoms' ids ``(G,)``."""
    compiled = compiled_model()
    return compiled, np.array([g for gs in compiled.foot_geoms.values() for g in gs], dtype=int)


def support_points(compiled: mjcf.CompiledModel, pose: kinematics.Pose, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The feet's box corners: ``points (T, N, 2)`` their floor positions (``N`` = 8 per box of
    ``boxes (G,)``) and ``active (T, N)`` those within :data:`BEARING` of the floor (z = 0)."""
    pos, mat = feet.geom_frames(compiled, pose, boxes)
    pts = feet.box_corners(pos, mat, compiled.model.geom_size[boxes]).reshape(len(pos), -1, 3)  # (T, N, 3)
    return pts[..., :2], pts[..., 2] < BEARING


def target_cop(cop: np.ndarray, points: np.ndarray, active: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """``(T, 2)``: per frame with bearing points, the point nearest ``cop`` inside their convex hull
    shrunk by ``margin`` (less where the hull is thinner than 2.5 margins); ``cop`` itself elsewhere.

    ``cop: (T, 2)``; ``points: (T, N, 2)``; ``active: (T, N)``. The hull is the polygon of its
    supporting lines in :data:`DIRECTIONS` directions ``u``: ``u·x ≤ max_i u·p_i − margin``. The
    nearest point of such a polygon is ``cop`` itself, its projection onto one line, or the
    crossing of two lines; all are tried at once for every frame and the nearest inside is kept.
    """
    out = np.asarray(cop, dtype=float).copy()
    rows = np.flatnonzero(active.any(axis=1) & np.all(np.isfinite(out), axis=1))
    if not len(rows):
        return out
    ang = 2.0 * np.pi * np.arange(DIRECTIONS) / DIRECTIONS
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # (K, 2)
    reach = np.where(active[rows][..., None], points[rows] @ u.T, -np.inf).max(axis=1)  # (R, K) support function
    width = (reach + np.roll(reach, DIRECTIONS // 2, axis=1)).min(axis=1)  # (R,) the hull's least width
    shrink = np.minimum(margin, 0.4 * np.maximum(width, 0.0))
    b = shrink[:, None] - reach  # u·x + b ≤ 0 inside
    outside = np.any(out[rows] @ u.T + b > 0.0, axis=1)
    rows, b = rows[outside], b[outside]
    if not len(rows):
        return out
    p = out[rows]  # (R, 2)
    i, j = np.triu_indices(DIRECTIONS, 1)
    keep = np.abs(u[i, 0] * u[j, 1] - u[i, 1] * u[j, 0]) > 1e-9
    i, j = i[keep], j[keep]
    inv = np.linalg.inv(np.stack([u[i], u[j]], axis=1))  # (P, 2, 2)
    crossings = np.einsum("pab,rpb->rpa", inv, -np.stack([b[:, i], b[:, j]], axis=-1))  # (R, P, 2)
    onto = p[:, None, :] - (p @ u.T + b)[..., None] * u  # (R, K, 2)
    cand = np.concatenate([p[:, None, :], onto, crossings], axis=1)  # (R, C, 2)
    inside = np.all(np.einsum("rca,ka->rck", cand, u) + b[:, None, :] <= 1e-9, axis=2)
    dist = np.where(inside, np.linalg.norm(cand - p[:, None, :], axis=2), np.inf)
    best = dist.argmin(axis=1)
    found = np.isfinite(dist[np.arange(len(rows)), best])
    out[rows[found]] = cand[np.flatnonzero(found), best[found]]
    return out


def _second_difference(n: int, fps: float) -> sparse.csr_matrix:
    """``(n, n)`` second derivative by central differences, the end rows copying their neighbour's
    (as :func:`mjmotion.physics.whole_body_wrench` differentiates)."""
    centre = np.clip(np.arange(n), 1, n - 2)
    rows = np.repeat(np.arange(n), 3)
    cols = (centre[:, None] + np.array([-1, 0, 1])).ravel()
    vals = np.tile([1.0, -2.0, 1.0], n)
    return sparse.csr_matrix((vals * fps**2, (rows, cols)), shape=(n, n))


def _moving_mean(n: int, width: int) -> sparse.csr_matrix:
    """``(n, n)`` the mean over the ``width`` frames centred on each frame (fewer at the ends)."""
    half = max(width // 2, 1)
    lo = np.maximum(np.arange(n) - half, 0)
    hi = np.minimum(np.arange(n) + half + 1, n)
    rows = np.repeat(np.arange(n), hi - lo)
    cols = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)])
    vals = np.repeat(1.0 / (hi - lo), hi - lo)
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n, n))


def root_shift(
    cop: np.ndarray, h: np.ndarray, target: np.ndarray, stance: np.ndarray, accel: np.ndarray, fps: float, stride: int | None = None
) -> np.ndarray:
    """``(T, 2)`` root shift ``d`` minimising, per horizontal axis,
    ``W_COP Σ_stance (p + d − h d'' − target)² + W_FLIGHT Σ_flight (h_g (a + d''))² + W_SIZE Σ d²
    + W_SMOOTH Σ (h_g d'')² + W_MEAN Σ (mean of d over the stride around t)² + W_END Σ_ends d²``.

    ``cop, target, accel: (T, 2)``; ``h: (T,)`` s²; ``stance: (T,)`` bool (frames with a CoP);
    ``h_g`` = 0.1 s², a standing centre of mass's height over g, turns accelerations into metres;
    ``stride``: frames of one gait cycle (None: no mean term). The normal equations are banded
    (sparse, solved directly).
    """
    n = len(h)
    if n < 3:
        return np.zeros((n, 2))
    d2 = _second_difference(n, fps)
    hg = 0.1
    s = np.asarray(stance, dtype=bool)
    eye = sparse.identity(n, format="csr")
    blocks, rhs = [], []
    if s.any():
        rows = sparse.csr_matrix(eye[s] - sparse.diags(np.where(s, h, 0.0)).tocsr()[s] @ d2)
        blocks.append(np.sqrt(W_COP) * rows)
        rhs.append(np.sqrt(W_COP) * (target[s] - cop[s]))
    if (~s).any():
        blocks.append(np.sqrt(W_FLIGHT) * hg * d2[~s])
        rhs.append(-np.sqrt(W_FLIGHT) * hg * accel[~s])
    blocks += [np.sqrt(W_SIZE) * eye, np.sqrt(W_SMOOTH) * hg * d2]
    rhs += [np.zeros((n, 2)), np.zeros((n, 2))]
    if stride is not None and stride > 1:
        blocks.append(np.sqrt(W_MEAN) * _moving_mean(n, int(stride)))
        rhs.append(np.zeros((n, 2)))
    ends = np.unique(np.clip(np.r_[0:END_FRAMES, n - END_FRAMES : n], 0, n - 1))
    blocks.append(np.sqrt(W_END) * eye[ends])
    rhs.append(np.zeros((len(ends), 2)))
    a = sparse.vstack(blocks, format="csc")
    b = np.concatenate(rhs, axis=0)
    ata = (a.T @ a).tocsc()
    return np.column_stack([spsolve(ata, a.T @ b[:, k]) for k in range(2)])


def cop_and_height(compiled: mjcf.CompiledModel, motion: Motion, pose: kinematics.Pose) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the motion needs of the ground (unfiltered): the CoP ``(T, 2)`` on z = 0 (NaN without
    load), ``h = z_c / (g + a_z)`` ``(T,)``, the loaded frames ``(T,)`` and the centre of mass's
    horizontal acceleration ``(T, 2)``."""
    force, torque = physics.whole_body_wrench(compiled, pose, motion.fps, None)
    mass = physics.total_mass(compiled)
    cop = physics.centre_of_pressure(force, torque, pose.joint_positions[:, 0], 0.0)
    com = physics.centre_of_mass(compiled, pose)
    loaded = force[:, 2] > MIN_LOAD * mass * physics.GRAVITY
    h = np.where(loaded, com[:, 2] * mass / np.maximum(force[:, 2], 1e-9), 0.0)
    return cop, h, loaded, force[:, :2] / mass


def balance_pass(motion: Motion, stride: int | None = None) -> np.ndarray:
    """``(T, 2)`` the root shift one pass asks of ``motion`` (a clip of the bundled humanoid).

    ``stride``: frames of one gait cycle; the shift's mean over each stride is held near zero, leaving
    the pelvis's sway within each stride and not a steady offset from the feet (a run would ask its
    pelvis 8 cm ahead of its footprints, and a crouch of 16 cm to reach them, to carry in stance
    the angular momentum its swinging legs gain in flight).
    """
    compiled, boxes = _model()
    pose = kinematics.forward(compiled, motion)
    cop, h, loaded, accel = cop_and_height(compiled, motion, pose)
    points, active = support_points(compiled, pose, boxes)
    stance = loaded & active.any(axis=1)
    target = target_cop(np.where(stance[:, None], cop, 0.0), points, active & stance[:, None])
    shift = root_shift(np.nan_to_num(cop), h, target, stance, accel, motion.fps, stride)
    # Exactly none at the first and last frames (a kick and a punch start and end in one pose):
    # the line through the two ends' shifts, a millimetre or less, has no acceleration to remove.
    ramp = np.linspace(0.0, 1.0, len(shift))[:, None]
    return shift - (1.0 - ramp) * shift[0] - ramp * shift[-1]


def rebalance(pb: PoseBuilder, ankles: dict[str, np.ndarray], limbs: Callable[[], None], fps: float, stride: int | None = None) -> None:
    """Apply :func:`balance_pass` to the clip ``pb`` is building: sway its pelvis in the floor plane,
    lower it by one constant as far as a leg no longer reaches its ankle goal ``(T, 3)`` (the height
    curve keeps its accelerations, and a clip's first and last poses stay one pose), and place the
    limbs again (``limbs``)."""
    pb.root[:, :2] += balance_pass(pb.motion(fps, "balance"), stride)
    pb.update()
    lower_pelvis(pb, ankles, fps, constant=True)
    limbs()
