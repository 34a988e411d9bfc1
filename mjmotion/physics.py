"""The physics judge with MuJoCo: inverse-dynamics residuals, effector–ball contact, ball launch.

Residuals (``docs/METRICS.md`` "Physics residual"): ``qpos`` from the motion, low-pass filtered
(:func:`mjmotion.filters.lowpass`, ``Params.cutoff_hz``), ``qvel``/``qacc`` by central finite
differences on the configuration manifold (quaternion joints differentiated in their local frame,
as ``mj_differentiatePos`` does), ``mj_inverse`` with contacts and joint limits disabled. The free
root's generalised force ``qfrc_inverse[:6]`` is the external wrench the character needs: force
(world) and torque about the root origin. Whether the ground can supply it is a small
optimisation per frame, solved for all frames at once (:func:`ground_reaction_residual`).

- :func:`finite_differences` ``(model, q, fps) -> (qvel, qacc)``; :func:`smooth_qpos`
- :func:`inverse_wrench` ``(compiled, motion) -> (force (T,3), torque_world (T,3))``
- :func:`ground_reaction_residual` ``(force, torque, origin, points, active, mass, mu, lever)``
- :func:`residuals` ``(compiled, motion, track, params) -> Residuals``
- :func:`centre_of_pressure` ``(force, torque, origin) -> (T, 2)`` on the floor plane
- :func:`hit_metrics` ``(motion, ball, hit_frame, props)``: hit_error_m, contact, impact_speed, launch
- :func:`simulate_launch` ``(...) -> Launch``: the ball-launch simulation (effector driven
  kinematically by a mocap body welded to a heavy dynamic body, ball free)
- :func:`launch_predictability` ``(...)``: seed 003 §2.3.2 / Figure 2.6, launch direction over
  a grid of hit points and its Spearman rank correlation with the hit point (the grid of adapted
  shots themselves is an operation: :mod:`mjmotion.launchgrid`).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from . import feet, kinematics, mjcf, nnls
from . import rotations as rot
from .errors import MjmotionError
from .feet import FootTrack
from .filters import dilate, erode, lowpass, lowpass_quaternions
from .mjcf import Ball, CompiledModel, Prop
from .skeleton import Motion, Skeleton
from .thresholds import Params

GRAVITY = 9.81


# --------------------------------------------------------------------------- inverse dynamics


def _joint_layout(model: mujoco.MjModel) -> list[tuple[int, int, int]]:
    """``(type, qpos_adr, dof_adr)`` of every joint."""
    return [(int(model.jnt_type[j]), int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])) for j in range(model.njnt)]


def _layout_indices(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Index arrays of the joints' coordinates: quaternions ``(Q, 4)`` of ``qpos`` with their
    angular ``qvel`` dofs ``(Q, 3)``, and linear ``qpos`` coordinates ``(L,)`` with their dofs ``(L,)``."""
    quat_q, quat_v, lin_q, lin_v = [], [], [], []
    for t, a, d in _joint_layout(model):
        if t == mujoco.mjtJoint.mjJNT_FREE:
            lin_q += [a, a + 1, a + 2]
            lin_v += [d, d + 1, d + 2]
            quat_q.append(range(a + 3, a + 7))
            quat_v.append(range(d + 3, d + 6))
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            quat_q.append(range(a, a + 4))
            quat_v.append(range(d, d + 3))
        else:
            lin_q.append(a)
            lin_v.append(d)
    as_2d = lambda rows, k: np.array([list(r) for r in rows], dtype=int).reshape(-1, k)
    return as_2d(quat_q, 4), as_2d(quat_v, 3), np.array(lin_q, dtype=int), np.array(lin_v, dtype=int)


def difference(model: mujoco.MjModel, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """``(..., nv)`` velocity taking ``q0`` to ``q1`` in unit time (``mj_differentiatePos``, batched
    over frames and joints).

    Free joints: world linear part, local angular part; ball joints: local rotation vector.
    """
    quat_q, quat_v, lin_q, lin_v = _layout_indices(model)
    out = np.zeros(q0.shape[:-1] + (model.nv,))
    out[..., lin_v] = q1[..., lin_q] - q0[..., lin_q]
    if len(quat_q):
        out[..., quat_v] = rot.log(rot.multiply(rot.conjugate(q0[..., quat_q]), q1[..., quat_q]))
    return out


def finite_differences(model: mujoco.MjModel, q: np.ndarray, fps: float, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Central differences ``qvel, qacc: (T, nv)`` from ``q: (T, nq)`` at ``fps``, stencil ``step`` frames.

    ``v±[t] = ±diff(q[t], q[t±k])·fps/k``, ``qvel[t] = (v+ + v−)/2``,
    ``qacc[t] = (v+ − v−)·fps/k``; the ``k`` frames at each end copy their nearest interior value.
    A stencil of several frames keeps marker noise (amplified by (fps/k)² in ``qacc``) below g.
    """
    k = int(step)
    n = q.shape[0]
    if k < 1 or n < 2 * k + 1:
        raise MjmotionError(f"inverse dynamics needs at least {2 * max(k, 1) + 1} frames (finite-difference stencil {k})")
    h = k / fps
    v = difference(model, q[:-k], q[k:]) / h  # half-step velocities from t to t + k
    vf, vb = v[k:], v[:-k]  # forward and backward of t in [k, n-k)
    qvel = np.empty((n, model.nv))
    qacc = np.empty((n, model.nv))
    qvel[k:-k] = 0.5 * (vf + vb)
    qacc[k:-k] = (vf - vb) / h
    qvel[:k], qvel[n - k :] = qvel[k], qvel[n - k - 1]
    qacc[:k], qacc[n - k :] = qacc[k], qacc[n - k - 1]
    return qvel, qacc


def _no_contact_model(model: mujoco.MjModel) -> mujoco.MjModel:
    m = copy.copy(model)
    # Contacts and joint limits off: the residual is the wrench the motion needs, not constraint forces.
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    return m


def fd_frames(fps: float, fd_step: float, n_frames: int | None = None) -> int:
    """Frames in a finite-difference stencil of ``fd_step`` seconds (at least 1; short clips get
    the widest stencil that fits in ``n_frames``)."""
    k = max(1, round(fd_step * fps))
    return k if n_frames is None else max(1, min(k, (n_frames - 1) // 2))


def smooth_qpos(model: mujoco.MjModel, q: np.ndarray, fps: float, cutoff_hz: float | None) -> np.ndarray:
    """``q: (T, nq)`` low-pass filtered joint by joint: positions directly, quaternions with
    continuous signs and renormalised (:func:`mjmotion.filters.lowpass_quaternions`)."""
    if cutoff_hz is None:
        return q
    out = q.copy()
    quats = []
    for t, a, _ in _joint_layout(model):
        if t == mujoco.mjtJoint.mjJNT_FREE:
            out[:, a : a + 3] = lowpass(q[:, a : a + 3], fps, cutoff_hz)
            quats.append(a + 3)
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            quats.append(a)
        else:
            out[:, a] = lowpass(q[:, a], fps, cutoff_hz)
    if quats:
        idx = np.array(quats)[:, None] + np.arange(4)  # (Q, 4)
        out[:, idx] = lowpass_quaternions(q[:, idx], fps, cutoff_hz)
    return out


def inverse_wrench(compiled: CompiledModel, motion: Motion, fd_step: float = 0.0, cutoff_hz: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """External wrench the motion needs, from ``mj_inverse`` with contacts and limits disabled.

    ``cutoff_hz``: low-pass filter ``qpos`` first (None: as captured); ``fd_step``:
    finite-difference stencil in seconds (rounded to whole frames, at least one).

    Returns ``force: (T, 3)`` newtons (world) and ``torque: (T, 3)`` N·m about the root origin,
    world frame.
    """
    m = _no_contact_model(compiled.model)
    q = smooth_qpos(m, kinematics.qpos(compiled, motion), motion.fps, cutoff_hz)
    qvel, qacc = finite_differences(m, q, motion.fps, fd_frames(motion.fps, fd_step, motion.n_frames))
    d = mujoco.MjData(m)
    frc = np.empty((q.shape[0], 6))
    for t in range(q.shape[0]):
        d.qpos[:] = q[t]
        d.qvel[:] = qvel[t]
        d.qacc[:] = qacc[t]
        mujoco.mj_inverse(m, d)
        frc[t] = d.qfrc_inverse[:6]
    # Free joint: the rotational dofs are in the root's frame; rotate the torque to the world.
    torque = rot.rotate(q[:, 3:7], frc[:, 3:6])
    return frc[:, :3], torque


def _character_bodies(compiled: CompiledModel) -> np.ndarray:
    """Ids of the character's bodies (skeleton and props; not the world or the ball), parents first."""
    m = compiled.model
    root = int(compiled.body_ids[0])
    return np.array([b for b in range(1, m.nbody) if int(m.body_rootid[b]) == root], dtype=int)


def body_frames(compiled: CompiledModel, pose: kinematics.Pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World frames of the character's bodies: ``ids (B,)``, positions ``(T, B, 3)`` and
    quaternions ``(T, B, 4)``. Skeleton bodies from ``pose``; bodies without joints (props) from
    their parent's frame and their fixed offset."""
    m = compiled.model
    ids = _character_bodies(compiled)
    t_count = pose.joint_positions.shape[0]
    joint_of = {int(b): j for j, b in enumerate(compiled.body_ids)}
    pos = np.empty((t_count, len(ids), 3))
    quat = np.empty((t_count, len(ids), 4))
    col = {int(b): i for i, b in enumerate(ids)}
    cols = np.array([i for i, b in enumerate(ids) if int(b) in joint_of], dtype=int)
    pos[:, cols] = pose.joint_positions[:, [joint_of[int(ids[i])] for i in cols]]
    quat[:, cols] = pose.joint_rotations[:, [joint_of[int(ids[i])] for i in cols]]
    for i, b in enumerate(ids):
        if int(b) not in joint_of:  # a prop: its parent's frame and its fixed offset
            k = col[int(m.body_parentid[b])]
            quat[:, i] = rot.multiply(quat[:, k], np.broadcast_to(m.body_quat[b], (t_count, 4)))
            pos[:, i] = pos[:, k] + rot.rotate(quat[:, k], np.broadcast_to(m.body_pos[b], (t_count, 3)))
    return ids, pos, quat


def _central(x: np.ndarray, fps: float, order: int) -> np.ndarray:
    """First (``order=1``) or second central difference over frames, the end frames copying their neighbour."""
    out = np.empty_like(x)
    if order == 1:
        out[1:-1] = (x[2:] - x[:-2]) * (0.5 * fps)
    else:
        out[1:-1] = (x[2:] - 2.0 * x[1:-1] + x[:-2]) * fps**2
    out[0], out[-1] = out[1], out[-2]
    return out


def whole_body_wrench(compiled: CompiledModel, pose: kinematics.Pose, fps: float, cutoff_hz: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The external wrench a motion needs, from Newton–Euler over all bodies at once.

    Force ``Σ m_b (a_b − g)`` and torque about the root joint ``Σ (c_b − o) × m_b (a_b − g) + Σ dH_b/dt``
    (``c_b`` a body's centre of mass, ``H_b = I_b ω_b`` its spin angular momentum, world frame):
    the free root's rows of ``mj_inverse`` (:func:`inverse_wrench`) without its per-frame
    mass matrix, vectorised over frames. Body centres and orientations are low-pass filtered at
    ``cutoff_hz`` before the central differences. Returns ``force, torque: (T, 3)`` (N, N·m, world).
    """
    m = compiled.model
    if pose.joint_positions.shape[0] < 3:
        raise MjmotionError("inverse dynamics needs at least 3 frames (finite-difference stencil 1)")
    ids, pos, quat = body_frames(compiled, pose)
    # Zero-length bones carry a token 0.1 g (mjcf): leave them out of the sums.
    heavy = m.body_mass[ids] > 1e-3
    ids, pos, quat = ids[heavy], pos[:, heavy], quat[:, heavy]
    mass = m.body_mass[ids]  # (B,)
    com = pos + rot.rotate(quat, np.broadcast_to(m.body_ipos[ids], pos.shape))
    frame = rot.multiply(quat, np.broadcast_to(m.body_iquat[ids], quat.shape))  # principal axes, world
    frame = rot.make_continuous(frame)
    if cutoff_hz is not None and len(com) >= 4:
        # One filter call for centres and orientations (lowpass_quaternions' steps, its columns
        # beside the centres'); continuous quaternions stay continuous through it.
        both = lowpass(np.concatenate([com, frame], axis=-1), fps, cutoff_hz)
        com, frame = both[..., :3], rot.normalize(both[..., 3:])
    acc = _central(com, fps, 2) - np.array([0.0, 0.0, -GRAVITY])
    omega = np.zeros_like(com)
    # World angular velocity of each body: log(q_{t+1} q_{t-1}⁻¹) / (2 dt), ends copied.
    omega[1:-1] = rot.log(rot.multiply(frame[2:], rot.conjugate(frame[:-2]))) * (0.5 * fps)
    omega[0], omega[-1] = omega[1], omega[-2]
    local = rot.rotate(rot.conjugate(frame), omega) * m.body_inertia[ids]  # I ω in principal axes
    spin = rot.rotate(frame, local)  # (T, B, 3)
    force = np.einsum("b,tbi->ti", mass, acc)
    origin = pose.joint_positions[:, 0]
    torque = np.einsum("b,tbi->ti", mass, rot.cross(com - origin[:, None, :], acc)) + _central(spin, fps, 1).sum(axis=1)
    return force, torque


def centre_of_mass(compiled: CompiledModel, pose: kinematics.Pose) -> np.ndarray:
    """``(T, 3)`` the character's centre of mass (world, m), as captured (not filtered)."""
    m = compiled.model
    ids, pos, quat = body_frames(compiled, pose)
    mass = m.body_mass[ids]
    com = pos + rot.rotate(quat, np.broadcast_to(m.body_ipos[ids], pos.shape))
    return np.einsum("b,tbi->ti", mass, com) / mass.sum()


#: Flights at least this long (s) are judged by their centre of mass's ballistic fit.
MIN_FLIGHT = 0.05


def flights(airborne: np.ndarray, fps: float, min_flight: float = MIN_FLIGHT) -> list[tuple[int, int]]:
    """``[(start, stop), …]`` frame ranges of the airborne stretches (``airborne: (T,)``) at least
    ``min_flight`` seconds (and 5 frames) long: those :func:`ballistic_residual` fits."""
    shortest = max(5, round(min_flight * fps))
    edges = np.diff(np.concatenate([[False], np.asarray(airborne, dtype=bool), [False]]).astype(np.int8))
    return [(int(a), int(b)) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)) if b - a >= shortest]


def ballistic_residual(com: np.ndarray, airborne: np.ndarray, fps: float, min_flight: float = MIN_FLIGHT) -> np.ndarray:
    """``(T,)`` per frame of each airborne stretch (``airborne: (T,)``, no supporting point) at
    least ``min_flight`` seconds long: how far the stretch's mean acceleration is from free fall,
    as a fraction of g — the least-squares quadratic through the centre of mass ``com: (T, 3)``
    over the stretch, its acceleration ``a``, and ``|a − g|/g``. NaN elsewhere.

    In flight only gravity acts, so the centre of mass follows a parabola. Fitted to positions
    over the whole stretch, the test needs no differentiation and no low-pass filter: a 6 Hz
    filter spreads the 2–3 g of a running stance over the 0.1–0.2 s flight beside it (0.3–1.5 g
    read there as missing force), and a higher cutoff amplifies marker noise instead.
    """
    return _off_free_fall(len(com), ballistic_fits(com, airborne, fps, min_flight))


def _off_free_fall(n_frames: int, fits: list[tuple[int, int, np.ndarray]]) -> np.ndarray:
    """``(T,)`` ``|a − g|/g`` of each fit of :func:`ballistic_fits` over its frames, NaN elsewhere."""
    out = np.full(n_frames, np.nan)
    for a, b, acc in fits:
        out[a:b] = np.linalg.norm(acc - [0.0, 0.0, -GRAVITY]) / GRAVITY
    return out


def ballistic_fits(com: np.ndarray, airborne: np.ndarray, fps: float, min_flight: float = MIN_FLIGHT) -> list[tuple[int, int, np.ndarray]]:
    """``[(start, stop, acceleration), …]``: each airborne stretch :func:`flights` keeps and the
    acceleration ``(3,)`` (m/s²) of the least-squares quadratic through ``com: (T, 3)`` over it
    (free fall: ``(0, 0, −g)``)."""
    out = []
    for a, b in flights(airborne, fps, min_flight):
        t = (np.arange(a, b) - 0.5 * (a + b - 1)) / fps
        basis = np.stack([np.ones_like(t), t, 0.5 * t * t], axis=1)
        coef = np.linalg.lstsq(basis, com[a:b], rcond=None)[0]  # (3, 3): position, velocity, acceleration
        out.append((a, b, coef[2]))
    return out


def total_mass(compiled: CompiledModel) -> float:
    """Mass (kg) of the character's bodies (props included, ball excluded)."""
    m = compiled.model
    ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, mjcf.BALL)
    return float(sum(m.body_mass[b] for b in range(1, m.nbody) if b != ball))


def centre_of_pressure(force: np.ndarray, torque: np.ndarray, origin: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """``(T, 2)`` point on the plane z = ``floor`` where the wrench has no horizontal torque.

    ``force``, ``torque`` (about ``origin``), ``origin``: ``(T, 3)``; NaN where the normal force is 0.
    """
    h = origin[:, 2] - floor
    fz = np.where(np.abs(force[:, 2]) > 1e-9, force[:, 2], np.nan)
    px = origin[:, 0] - (torque[:, 1] + h * force[:, 0]) / fz
    py = origin[:, 1] + (torque[:, 0] - h * force[:, 1]) / fz
    return np.stack([px, py], axis=1)


#: Friction pyramid edges: unit force directions inside the cone of friction ``mu`` (4 edges).
_EDGES = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


def parallel_support_bound(
    force: np.ndarray,
    torque: np.ndarray,
    origin: np.ndarray,
    points: np.ndarray,
    active: np.ndarray,
    weight: float,
    mu: float = 1.0,
    lever: float = 1.0,
) -> np.ndarray:
    """An upper bound of :func:`ground_reaction_residual` from a direct construction, ``(T,)``
    (``inf`` where it does not apply).

    Where the needed force lies in the friction pyramid (``|F_x| + |F_y| ≤ mu F_z``), forces
    parallel to ``F`` at active points, with non-negative shares summing to one, supply the force
    exactly and the torque ``(c − o) × F`` of their centre ``c``; the needed torque they leave
    over bounds the optimum from above. The centres tried lie on each segment between two active
    points (a point alone included): the leftover is affine along a segment, so the centre leaving
    the least of it is closed form; the least over segments is kept. What is left is the torque about
    the force's own line (the "free moment", vertical for a vertical force) and the force times the
    centre of pressure's distance from the nearest segment, inside the support or a little outside
    it. Vectorised over frames and segments.
    """
    t_count, n_pts = active.shape
    out = np.full(t_count, np.inf)
    ok = (np.abs(force[:, 0]) + np.abs(force[:, 1]) <= mu * force[:, 2]) & (force[:, 2] > 0) & active.any(axis=1)
    if not ok.any():
        return out
    idx = np.flatnonzero(ok)
    pts, act = points[idx], active[idx]
    f, tq, o = force[idx], torque[idx], origin[idx]
    # All the force at point n leaves base[n] of the torque; at c = p_i + s (p_j − p_i) it leaves
    # base[i] + s (base[j] − base[i]) (the cross product is linear in c).
    base = rot.cross(pts - o[:, None, :], f[:, None, :]) - tq[:, None, :]  # (U, N, 3)
    i, j = np.triu_indices(n_pts)  # (K,) segments, i == j a single point
    start, along = base[:, i], base[:, j] - base[:, i]  # (U, K, 3)
    dd = rot.dot(along, along)
    s = np.clip(-rot.dot(start, along) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
    left = rot.norm(start + s[..., None] * along)  # (U, K)
    out[idx] = np.where(act[:, i] & act[:, j], left, np.inf).min(axis=1) / lever / weight
    return out


def ground_reaction_residual(
    force: np.ndarray,
    torque: np.ndarray,
    origin: np.ndarray,
    points: np.ndarray,
    active: np.ndarray,
    weight: float,
    mu: float = 1.0,
    lever: float = 1.0,
    tol: float | None = None,
) -> np.ndarray:
    """How much of the needed wrench the ground cannot supply, per frame, as a fraction of ``weight``.

    Per frame t: contact forces ``f_i`` at the ``active`` points ``points[t, i]``, each inside a
    friction pyramid of coefficient ``mu`` (a non-negative combination of its 4 edge directions),
    should produce the needed wrench — ``force[t]`` and ``torque[t]`` about ``origin[t]``. The
    forces minimising ``‖(r_F, r_τ / lever)‖`` (``r`` the wrench left over; ``lever`` turns a
    torque into a force, e.g. half the stature) solve a non-negative least-squares problem
    (Lawson–Hanson, :func:`mjmotion.nnls.solve` on every frame at once: exact, at most 6 forces
    active); the residual is that norm over ``weight``, ``(T,)``. A frame with no active point
    returns the whole wrench (flight: gravity alone must explain the motion).

    With ``tol``, frames that :func:`parallel_support_bound` already proves within ``tol`` keep
    that upper bound instead of the exact optimum (the pass/fail decision at ``tol`` is exact
    either way; most supported frames of captured motion are decided so, without a solve).

    ``force, torque, origin: (T, 3)``; ``points: (T, N, 3)``; ``active: (T, N)`` bool.
    """
    t_count, n_pts = active.shape
    d = np.concatenate([mu * _EDGES, np.ones((4, 1))], axis=1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)  # (4, 3)
    w = np.concatenate([force, torque / lever], axis=1) / weight  # (T, 6)
    out = rot.norm(w)
    solve = active.any(axis=1)
    if tol is not None:
        bound = parallel_support_bound(force, torque, origin, points, active, weight, mu, lever)
        done = solve & (bound <= tol)
        out[done] = bound[done]
        solve &= ~done
    rows = np.flatnonzero(solve)
    if len(rows):
        # Generators of the frames to solve, built at once: (R, N, 4, 6) force and torque/lever columns.
        arm = points[rows] - origin[rows, None, :]
        tq = rot.cross(arm[:, :, None, :], d[None, None, :, :]) / lever
        gen = np.concatenate([np.broadcast_to(d, tq.shape), tq], axis=-1) / weight
        a = gen.reshape(len(rows), n_pts * 4, 6).transpose(0, 2, 1)  # (R, 6, 4N)
        allowed = np.repeat(active[rows], 4, axis=1)  # each point's 4 edges
        out[rows] = nnls.solve(a, w[rows], allowed).residual
    return out


@dataclass(frozen=True, eq=False)
class Residuals:
    """Inverse-dynamics checks of a clip (``docs/METRICS.md`` "Physics residual").

    Attributes:
        root_force_ratio: ``(T,)`` |external force| / (m g).
        flight: ``(T,)`` bool, no foot in contact.
        residual: ``(T,)`` ground-reaction residual (:func:`ground_reaction_residual`), fraction of m g.
        penetrating: ``(T,)`` bool, the body deeper below the floor than ``Params.penetration_tol``.
        support: ``(T,)`` bool, some sole point can push on the floor (else the residual is the whole wrench).
        ballistic: ``(T,)`` bool, frames of an airborne stretch judged by its ballistic fit
            (:func:`ballistic_residual`; their residual is the fit's, their tolerance ``Params.flight_tol``).
        violation: ``(T,)`` bool frames failing: ``residual > Params.residual_tol`` or penetrating.
        flight_residual: mean ``root_force_ratio`` over flight frames whose finite-difference
            neighbourhood is all in flight (NaN without such frames).
        physics_violation_ratio: fraction of violating frames.
        mass: kg.
        flight_accelerations: ``(K, 3)`` m/s², the centre of mass's fitted acceleration over each
            of the ``K`` airborne stretches judged by their ballistic fit (:func:`ballistic_fits`).
    """

    root_force_ratio: np.ndarray
    flight: np.ndarray
    residual: np.ndarray
    penetrating: np.ndarray
    support: np.ndarray
    violation: np.ndarray
    flight_residual: float
    physics_violation_ratio: float
    mass: float
    ballistic: np.ndarray | None = None
    flight_accelerations: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


#: Heel to toe tip of a foot, × stature: 0.124-0.136 on the shared rigs with toe joints (the
#: median over their stance frames of the horizontal distance from the heel to the toe-tip sole points).
TOE_REACH = 0.13


def _with_toes(skeleton: Skeleton, track: FootTrack, support: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The supporting points of the ground-reaction test, ``(T, N, 3)`` and ``(T, N)``: every sole
    point, and for a foot without a toe joint (cgspeed daz's end at the ball) two more on the floor
    plane ahead of its ball points, reaching :data:`TOE_REACH` × stature from the heel and pushing
    whenever the ball does: the toes the skeleton does not model, which carry a push-off's centre
    of pressure beyond the ball. They support only: no height or footskate is measured on them."""
    t_count = track.points.shape[0]
    points, active = [track.points.reshape(t_count, -1, 3)], [support.reshape(t_count, -1)]
    feet_ = skeleton.feet()
    reach = TOE_REACH * max(float(skeleton.stature()), 0.3)
    for f, side in enumerate(track.sides):
        if feet_.get(side, (None, 0))[1] is not None or track.points.shape[2] < 4:
            continue
        heel, ball = track.points[:, f, 0:2], track.points[:, f, 2:4]  # (T, 2, 3): the sole's corners
        along = ball[..., :2] - heel[..., :2]
        length = rot.norm(along, keepdims=True)
        toes = ball.copy()
        toes[..., :2] += along / np.maximum(length, 1e-9) * np.maximum(reach - length, 0.0)
        points.append(toes)
        active.append(support[:, f, 2:4])
    return np.concatenate(points, axis=1), np.concatenate(active, axis=1)


def residuals(
    compiled: CompiledModel,
    motion: Motion,
    track: FootTrack | None = None,
    params: Params | None = None,
    ground: np.ndarray | None = None,
    pose: kinematics.Pose | None = None,
) -> Residuals:
    """``docs/METRICS.md`` physics residual of ``motion``.

    ``track``: its :class:`~mjmotion.feet.FootTrack` (default: calibrated on the clip, floor
    detected); ``params``: :class:`~mjmotion.thresholds.Params`; ``ground: (T,)`` the lowest
    body point above the floor (default: from ``track``); ``pose``: the motion's forward kinematics.
    The needed wrench is :func:`whole_body_wrench` (the root rows of ``mj_inverse``, vectorised).
    """
    params = params if params is not None else Params()
    pose = pose if pose is not None else kinematics.forward(compiled, motion)
    if track is None or ground is None:
        track = track if track is not None else feet.foot_heights_speeds(compiled, motion, pose, speed_window=params.speed_window)
        if ground is None:
            ground = feet.lowest_body_point(compiled, pose, track.heights.min(axis=1) + track.floor) - track.floor
    force, torque = whole_body_wrench(compiled, pose, motion.fps, params.cutoff_hz)
    mass = total_mass(compiled)
    weight = mass * GRAVITY
    ratio = rot.norm(force) / weight
    con = feet.contacts(track, params.h_c, params.v_c, params.hysteresis)  # (T, F)
    flight = np.asarray(~con.any(axis=1))
    # Support: sole points touching the floor (within support_height), and those of feet in
    # contact within h_c. A foot sliding on the floor still pushes (a retargeted run's stance
    # foot often slides faster than v_c).
    h = track.points[..., 2] - track.floor  # (T, F, P)
    support = (h < params.support_height) | ((h < params.h_c) & con[:, :, None])
    airborne = ~support.any(axis=(1, 2))
    if params.cutoff_hz:
        # The filtered wrench at t averages the wrenches of the frames within half a cutoff period
        # (83 ms at 6 Hz): what supported any of them may supply it (a stance's push spreads into
        # the take-off and landing frames beside it).
        k = round(0.5 / params.cutoff_hz * motion.fps)
        if k:
            support = dilate(support, 2 * k + 1, axis=0)
    lever = 0.5 * max(float(motion.skeleton.stature()), 0.3)
    points, active = _with_toes(motion.skeleton, track, support)
    residual = ground_reaction_residual(
        force,
        torque,
        pose.joint_positions[:, 0],
        points,
        active,
        weight,
        params.mu,
        lever,
        params.residual_tol,
    )
    # Flights long enough to fit are judged by their ballistic fit, not the filtered wrench.
    # (A walk has no such flight: its centre of mass is not needed.)
    fits = ballistic_fits(centre_of_mass(compiled, pose), airborne, motion.fps) if flights(airborne, motion.fps) else []
    ballistic = _off_free_fall(len(airborne), fits)
    fitted = ~np.isnan(ballistic)
    residual = np.where(fitted, ballistic, residual)
    penetrating = ground < -params.penetration_tol
    violation = (residual > np.where(fitted, params.flight_tol, params.residual_tol)) | penetrating
    # flight_residual uses flight frames away from take-off and landing (there the filter and the
    # difference stencil still see the ground's push) and from the clip's ends: 2 frames and 50 ms.
    k = 2 + round(0.05 * motion.fps)
    clean = erode(flight, 2 * k + 1)
    return Residuals(
        root_force_ratio=ratio,
        flight=flight,
        residual=residual,
        penetrating=penetrating,
        support=support.any(axis=(1, 2)),
        violation=violation,
        flight_residual=float(ratio[clean].mean()) if clean.any() else float("nan"),
        physics_violation_ratio=float(violation.mean()),
        mass=mass,
        ballistic=fitted,
        flight_accelerations=np.array([acc for _, _, acc in fits]).reshape(-1, 3),
    )


# --------------------------------------------------------------------------- hitting


@dataclass(frozen=True)
class Launch:
    """The ball after the impact simulation.

    Attributes:
        velocity: ``(3,)`` m/s, world, just after the effector lets go of the ball.
        speed: m/s.
        azimuth_deg: heading in the floor plane, degrees from +x towards +y.
        elevation_deg: angle above the floor plane, degrees.
        contacted: whether the effector touched the ball at all.
        restitution: the coefficient the contact parameters were set for.
    """

    velocity: tuple[float, float, float]
    speed: float
    azimuth_deg: float
    elevation_deg: float
    contacted: bool
    restitution: float


def damping_ratio(restitution: float) -> float:
    """Damping ratio ζ of a linear spring-damper contact with coefficient of restitution ``e``."""
    e = float(np.clip(restitution, 1e-6, 1.0 - 1e-9))
    return float(-np.log(e) / np.sqrt(np.pi**2 + np.log(e) ** 2))


def simulate_launch(
    geom_type: int,
    geom_size: Sequence[float],
    poses_pos: np.ndarray,
    poses_quat: np.ndarray,
    fps: float,
    hit_index: int,
    ball_position: Sequence[float] | np.ndarray,
    ball_radius: float = 0.036,
    ball_mass: float = 0.16,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    restitution: float = 0.5,
    effector_mass: float = 5.0,
    substeps: int = 1000,
) -> Launch:
    """Hit a free ball with an effector driven kinematically through the frames around impact.

    A mocap body follows the animated effector pose (positions interpolated linearly, rotations
    by slerp, ``substeps`` physics steps per animation frame); a heavy dynamic body carrying the
    effector geom is welded to it, so the contact sees the effector's real velocity. The ball is
    free, frictionless (condim 1: no spin, as in seed 003 §2.3.2), gravity off during the short
    window, arriving at ``ball_position`` at frame ``hit_index`` with ``ball_velocity``. Contact
    stiffness/damping are set for coefficient of restitution ``restitution`` (cricket ≈ 0.5).

    Args:
        geom_type, geom_size: the effector geom (``mjtGeom``, MuJoCo ``size``).
        poses_pos: ``(n, 3)`` effector geom world positions per frame; ``poses_quat``: ``(n, 4)`` wxyz.
        fps: animation frame rate.
        hit_index: index (into the poses) of the hit frame.
    """
    n = len(poses_pos)
    if n < 2 or not (0 <= hit_index < n):
        raise MjmotionError("simulate_launch: need at least 2 effector poses and a hit index inside them")
    dt = 1.0 / (fps * substeps)
    zeta = damping_ratio(restitution)
    spec = mujoco.MjSpec()
    spec.option.timestep = dt
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.worldbody.add_body(name="target", mocap=True, pos=poses_pos[0].tolist(), quat=poses_quat[0].tolist())
    eff = spec.worldbody.add_body(name="effector", pos=poses_pos[0].tolist(), quat=poses_quat[0].tolist())
    eff.add_freejoint()
    size = list(geom_size) + [0.0] * (3 - len(geom_size))
    eff.add_geom(type=geom_type, size=size[:3], mass=effector_mass, condim=1, solref=[max(4 * dt, 2e-4), zeta], solimp=[0.99, 0.99, 0.001, 0.5, 2.0])
    ball_v = np.asarray(ball_velocity, dtype=float)
    t_hit = hit_index / fps
    ball0 = np.asarray(ball_position, dtype=float) - ball_v * t_hit
    bb = spec.worldbody.add_body(name="ball", pos=ball0.tolist())
    bb.add_freejoint(name="ball")
    bb.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[ball_radius, 0, 0],
        mass=ball_mass,
        condim=1,
        solref=[max(4 * dt, 2e-4), zeta],
        solimp=[0.99, 0.99, 0.001, 0.5, 2.0],
    )
    weld = spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, name1="target", name2="effector", objtype=mujoco.mjtObj.mjOBJ_BODY)
    weld.solref = [max(4 * dt, 2e-4), 1.0]
    m = spec.compile()
    d = mujoco.MjData(m)
    # Effector trajectory at every substep.
    s = np.arange((n - 1) * substeps + 1) / substeps
    i0 = np.minimum(np.floor(s).astype(int), n - 2)
    w = (s - i0)[:, None]
    pos = (1 - w) * poses_pos[i0] + w * poses_pos[i0 + 1]
    quat = rot.slerp(poses_quat[i0], poses_quat[i0 + 1], w[:, 0])
    vel0 = (poses_pos[1] - poses_pos[0]) * fps
    omega0 = rot.log(rot.multiply(rot.conjugate(poses_quat[0]), poses_quat[1])) * fps
    d.qpos[0:3], d.qpos[3:7] = poses_pos[0], poses_quat[0]
    d.qvel[0:3], d.qvel[3:6] = vel0, omega0
    bdof = int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "ball")])
    d.qvel[bdof : bdof + 3] = ball_v
    contacted = False
    for k in range(len(s)):
        d.mocap_pos[0], d.mocap_quat[0] = pos[k], quat[k]
        mujoco.mj_step(m, d)
        if d.ncon:
            contacted = True
    # Let a contact still in progress at the window's end finish (the effector coasts).
    for _ in range(20 * substeps):
        if d.ncon == 0:
            break
        mujoco.mj_step(m, d)
    v = np.array(d.qvel[bdof : bdof + 3])
    speed = float(np.linalg.norm(v))
    az = float(np.degrees(np.arctan2(v[1], v[0])))
    el = float(np.degrees(np.arctan2(v[2], np.hypot(v[0], v[1]))))
    return Launch(tuple(float(x) for x in v), speed, az, el, contacted, float(restitution))  # type: ignore[arg-type]


def _effector(compiled: CompiledModel, props: Sequence[Prop], ball_pos: np.ndarray, q_hit: np.ndarray) -> tuple[int, int | None]:
    """(geom id, sweet-spot site id or None): the first prop, else the foot/toe/hand geom nearest the ball."""
    m = compiled.model
    if props:
        gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, props[0].name)
        return int(gid), compiled.site_id(props[0].site)
    d = mujoco.MjData(m)
    d.qpos[:] = q_hit
    mujoco.mj_kinematics(m, d)
    cands = compiled.body_geom_ids
    dist = np.linalg.norm(d.geom_xpos[cands] - ball_pos, axis=1)
    return int(cands[int(np.argmin(dist))]), None


def hit_metrics(
    motion: Motion,
    ball: Ball,
    hit_frame: int,
    props: Sequence[Prop] = (),
    launch: bool = True,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    restitution: float = 0.5,
    window: int = 3,
) -> dict[str, Any]:
    """METRICS.md hitting metrics at ``hit_frame``: ``hit_error_m``, ``contact``, ``impact_speed``
    and (``launch``) the simulated launch. The effector is ``props[0]``'s geom and sweet spot, else
    the character geom nearest the ball (its centre standing in for the sweet spot)."""
    if not (0 <= hit_frame < motion.n_frames):
        raise MjmotionError(f"--frame {hit_frame}: outside the clip's 0..{motion.n_frames - 1}")
    compiled = mjcf.compile(motion.skeleton, tuple(props), ball)
    m = compiled.model
    q = kinematics.qpos(compiled, motion)
    bpos = np.asarray(ball.position, dtype=float)
    geom, site = _effector(compiled, props, bpos, q[hit_frame])
    d = mujoco.MjData(m)
    ball_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, mjcf.BALL)
    lo, hi = max(0, hit_frame - window), min(motion.n_frames, hit_frame + window + 1)
    frames = np.arange(lo, hi)
    gpos = np.empty((len(frames), 3))
    gquat = np.empty((len(frames), 4))
    spot = np.empty((len(frames), 3))
    contact = False
    for i, f in enumerate(frames):
        d.qpos[:] = q[f]
        mujoco.mj_forward(m, d)
        gpos[i] = d.geom_xpos[geom]
        gquat[i] = rot.from_matrix(d.geom_xmat[geom].reshape(3, 3))
        spot[i] = d.site_xpos[site] if site is not None else d.geom_xpos[geom]
        if abs(f - hit_frame) <= 1:
            pairs = {(int(c.geom1), int(c.geom2)) for c in d.contact[: d.ncon]}
            contact |= (geom, ball_geom) in pairs or (ball_geom, geom) in pairs
    h = hit_frame - lo
    hit_error = float(np.linalg.norm(spot[h] - bpos) - ball.radius)
    a, b = max(h - 1, 0), min(h + 1, len(frames) - 1)
    impact_speed = float(np.linalg.norm(spot[b] - spot[a]) * motion.fps / max(b - a, 1))
    out: dict[str, Any] = {
        "hit_frame": int(hit_frame),
        "effector_geom": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom{geom}",
        "hit_error_m": hit_error,
        "contact": bool(contact),
        "impact_speed": impact_speed,
    }
    if launch:
        gquat = rot.make_continuous(gquat)
        ln = simulate_launch(
            int(m.geom_type[geom]),
            m.geom_size[geom].tolist(),
            gpos,
            gquat,
            motion.fps,
            h,
            bpos,
            ball.radius,
            ball.mass,
            ball_velocity,
            restitution,
        )
        out.update(
            launch_azimuth_deg=ln.azimuth_deg,
            launch_elevation_deg=ln.elevation_deg,
            launch_speed=ln.speed,
            launch_contacted=ln.contacted,
            restitution=restitution,
        )
    return out


# --------------------------------------------------------------------------- seed 003 §2.3.2


@dataclass(frozen=True, eq=False)
class Predictability:
    """How predictably the launch direction follows the hit point (seed 003 §2.3.2, Figure 2.6).

    Attributes:
        hit_points: ``(N, 3)`` ball positions at impact, metres.
        launches: one :class:`Launch` per hit point.
        lateral: ``(N,)`` hit-point offset across the mean launch direction (m, + to its left).
        vertical: ``(N,)`` hit-point height relative to the mean (m).
        rho_azimuth: Spearman rank correlation of ``lateral`` with launch azimuth (NaN if either is constant).
        rho_elevation: Spearman rank correlation of ``vertical`` with launch elevation.
        slope_deg_per_m: least-squares change of azimuth per metre of ``lateral`` (how strongly).
    """

    hit_points: np.ndarray
    launches: tuple[Launch, ...]
    lateral: np.ndarray
    vertical: np.ndarray
    rho_azimuth: float
    rho_elevation: float
    slope_deg_per_m: float

    def rows(self) -> list[dict[str, float]]:
        return [
            {"lateral_m": float(a), "vertical_m": float(v), "azimuth_deg": ln.azimuth_deg, "elevation_deg": ln.elevation_deg, "speed": ln.speed}
            for a, v, ln in zip(self.lateral, self.vertical, self.launches)
        ]


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    from scipy.stats import spearmanr

    if len(x) < 3 or np.ptp(x) < 1e-12 or np.ptp(y) < 1e-9:
        return float("nan")
    return float(spearmanr(x, y).statistic)


def launch_predictability(
    geom_type: int,
    geom_size: Sequence[float],
    poses: Sequence[tuple[np.ndarray, np.ndarray]],
    fps: float,
    hit_index: int,
    hit_points: np.ndarray,
    ball_radius: float = 0.036,
    ball_mass: float = 0.16,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    restitution: float = 0.5,
) -> Predictability:
    """Launch the ball from every hit point and rank-correlate direction with position.

    ``poses[i]``: the effector geom's ``(positions (n, 3), quats (n, 4))`` around impact in the
    shot adapted to ``hit_points[i]``. Azimuths are unwrapped around their circular mean.
    """
    hp = np.asarray(hit_points, dtype=float)
    if len(poses) != len(hp):
        raise MjmotionError(f"launch_predictability: {len(poses)} effector paths for {len(hp)} hit points")
    launches = tuple(
        simulate_launch(geom_type, geom_size, p, q, fps, hit_index, x, ball_radius, ball_mass, ball_velocity, restitution)
        for (p, q), x in zip(poses, hp)
    )
    az = np.radians([ln.azimuth_deg for ln in launches])
    mean = float(np.arctan2(np.sin(az).mean(), np.cos(az).mean()))
    left = np.array([-np.sin(mean), np.cos(mean)])
    centred = hp - hp.mean(axis=0)
    lateral = centred[:, :2] @ left
    az_unwrapped = np.degrees(np.angle(np.exp(1j * (az - mean)))) + np.degrees(mean)
    el = np.array([ln.elevation_deg for ln in launches])
    return Predictability(
        hit_points=hp,
        launches=launches,
        lateral=lateral,
        vertical=centred[:, 2],
        rho_azimuth=_spearman(lateral, az_unwrapped),
        rho_elevation=_spearman(centred[:, 2], el),
        slope_deg_per_m=float(np.polyfit(lateral, az_unwrapped, 1)[0]) if np.ptp(lateral) > 1e-12 else float("nan"),
    )
