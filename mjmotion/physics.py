"""Physics checks with MuJoCo: inverse-dynamics residuals, effector–ball contact, ball launch.

Residuals (METRICS.md "Physics residual"): ``qpos`` from the motion, ``qvel``/``qacc`` by central
finite differences on the configuration manifold (quaternion joints differentiated in their local
frame, as ``mj_differentiatePos`` does), ``mj_inverse`` with contacts disabled. The free root's
generalised force ``qfrc_inverse[:6]`` is the external wrench the character needs: force (world)
and torque about the root origin (root frame).

- :func:`finite_differences` ``(compiled, q, fps) -> (qvel, qacc)``
- :func:`inverse_wrench` ``(compiled, motion) -> (force (T,3), torque_world (T,3))``
- :func:`residuals` ``(compiled, motion, track, params) -> Residuals`` (root_force_ratio per
  frame, flight_residual, ground-reaction feasibility, physics_violation_ratio)
- :func:`centre_of_pressure` ``(force, torque, origin) -> (T, 2)`` on the floor plane
- :func:`hit_metrics` ``(motion, ball, hit_frame, props)``: hit_error_m, contact, impact_speed, launch
- :func:`simulate_launch` ``(...) -> Launch``: the ball-launch simulation (effector driven
  kinematically by a mocap body welded to a heavy dynamic body, ball free)
- :func:`launch_predictability` ``(...)``: seed 003 §2.3.2 / Figure 2.6, launch direction over
  a grid of hit points and its Spearman rank correlation with the hit point.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from . import kinematics, mjcf
from . import rotations as rot
from .errors import MjmotionError
from .mjcf import Ball, CompiledModel, Prop
from .skeleton import Motion

GRAVITY = 9.81


# --------------------------------------------------------------------------- inverse dynamics


def _joint_layout(model: mujoco.MjModel) -> list[tuple[int, int, int]]:
    """``(type, qpos_adr, dof_adr)`` of every joint."""
    return [(int(model.jnt_type[j]), int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])) for j in range(model.njnt)]


def difference(model: mujoco.MjModel, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """``(..., nv)`` velocity taking ``q0`` to ``q1`` in unit time (``mj_differentiatePos``, batched).

    Free joints: world linear part, local angular part; ball joints: local rotation vector.
    """
    out = np.zeros(q0.shape[:-1] + (model.nv,))
    for t, a, d in _joint_layout(model):
        if t == mujoco.mjtJoint.mjJNT_FREE:
            out[..., d : d + 3] = q1[..., a : a + 3] - q0[..., a : a + 3]
            out[..., d + 3 : d + 6] = rot.log(rot.multiply(rot.conjugate(q0[..., a + 3 : a + 7]), q1[..., a + 3 : a + 7]))
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            out[..., d : d + 3] = rot.log(rot.multiply(rot.conjugate(q0[..., a : a + 4]), q1[..., a : a + 4]))
        else:
            out[..., d] = q1[..., a] - q0[..., a]
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
    vf = difference(model, q[k:-k], q[2 * k :]) / h  # forward half-step velocities, t in [k, n-k)
    vb = difference(model, q[: n - 2 * k], q[k:-k]) / h
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


def inverse_wrench(compiled: CompiledModel, motion: Motion, fd_step: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """External wrench the motion needs, from ``mj_inverse`` with contacts disabled.

    ``fd_step``: finite-difference stencil in seconds (rounded to whole frames, at least one).

    Returns ``force: (T, 3)`` newtons (world) and ``torque: (T, 3)`` N·m about the root origin,
    world frame.
    """
    m = _no_contact_model(compiled.model)
    q = kinematics.qpos(compiled, motion)
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
    torque = rot.rotate(motion.rotations[:, 0], frc[:, 3:6])
    return frc[:, :3], torque


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


def distance_to_hull(p: np.ndarray, pts: np.ndarray) -> float:
    """Distance (m) from the 2D point ``p`` to the convex hull of ``pts: (n, 2)`` (0 inside)."""
    from scipy.spatial import ConvexHull, QhullError

    edges: np.ndarray
    try:
        hull = ConvexHull(pts)
        if np.all(hull.equations[:, :2] @ p + hull.equations[:, 2] <= 1e-12):
            return 0.0
        v = pts[hull.vertices]
        edges = np.stack([v, np.roll(v, -1, axis=0)], axis=1)
    except (QhullError, ValueError):
        # Fewer than 3 points or all on a line: the hull is a segment (or a point).
        i, j = np.triu_indices(len(pts), k=0)
        edges = np.stack([pts[i], pts[j]], axis=1)
    a, b = edges[:, 0], edges[:, 1]
    ab = b - a
    s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + s[:, None] * ab - p, axis=1)))


@dataclass(frozen=True, eq=False)
class Residuals:
    """Inverse-dynamics checks of a clip.

    Attributes:
        root_force_ratio: ``(T,)`` |external force| / (m g).
        flight: ``(T,)`` bool, no foot in contact.
        normal_ok, cone_ok, cop_ok: ``(T,)`` bool ground-reaction checks (True in flight frames).
        cop: ``(T, 2)`` centre of pressure on the floor, metres.
        violation: ``(T,)`` bool frames failing a check.
        flight_residual: mean ``root_force_ratio`` over flight frames whose finite-difference
            stencil is all in flight (NaN without such frames).
        physics_violation_ratio: fraction of violating frames.
        mass: kg.
    """

    root_force_ratio: np.ndarray
    flight: np.ndarray
    normal_ok: np.ndarray
    cone_ok: np.ndarray
    cop_ok: np.ndarray
    cop: np.ndarray
    violation: np.ndarray
    flight_residual: float
    physics_violation_ratio: float
    mass: float


def residuals(compiled: CompiledModel, motion: Motion, track: Any = None, params: Any = None) -> Residuals:
    """METRICS.md physics residual of ``motion`` (``track``: its :class:`~mjmotion.evaluate.FootTrack`;
    ``params``: :class:`~mjmotion.evaluate.Params`)."""
    from . import evaluate as ev

    params = params if params is not None else ev.Params()
    track = track if track is not None else ev.foot_heights_speeds(compiled, motion)
    force, torque = inverse_wrench(compiled, motion, params.fd_step)
    mass = total_mass(compiled)
    ratio = np.linalg.norm(force, axis=1) / (mass * GRAVITY)
    con = ev.contacts(track, params.h_c, params.v_c)  # (T, F)
    flight = ~con.any(axis=1)
    normal_ok = flight | (force[:, 2] >= 0.0)
    cone_ok = flight | (np.linalg.norm(force[:, :2], axis=1) <= params.mu * np.maximum(force[:, 2], 0.0))
    cop = centre_of_pressure(force, torque, motion.root_positions)
    cop_ok = np.ones(motion.n_frames, dtype=bool)
    low_pts = track.points[..., 2] < params.h_c  # (T, F, P)
    for t in np.flatnonzero(~flight):
        mask = low_pts[t] & con[t][:, None]
        pts = track.points[t][mask][:, :2]
        if not np.all(np.isfinite(cop[t])) or len(pts) == 0:
            cop_ok[t] = False
            continue
        cop_ok[t] = distance_to_hull(cop[t], pts) <= params.cop_margin
    violation = np.where(flight, ratio > params.flight_force_ratio, ~(normal_ok & cone_ok & cop_ok))
    # flight_residual uses flight frames whose whole difference stencil is airborne: a stencil
    # straddling take-off or landing measures the ground push, not the flight (one more frame each
    # side: a contact label looks one frame back).
    k = fd_frames(motion.fps, params.fd_step, motion.n_frames)
    from scipy.ndimage import minimum_filter1d

    clean = minimum_filter1d(flight.astype(np.uint8), size=2 * k + 3, mode="nearest").astype(bool)
    return Residuals(
        root_force_ratio=ratio,
        flight=flight,
        normal_ok=normal_ok,
        cone_ok=cone_ok,
        cop_ok=cop_ok,
        cop=cop,
        violation=violation,
        flight_residual=float(ratio[clean].mean()) if clean.any() else float("nan"),
        physics_violation_ratio=float(violation.mean()),
        mass=mass,
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
    ball_position: Sequence[float],
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


def arm_chain(skeleton: Any, joint: int, min_bone: float = 0.08) -> tuple[int, int, int]:
    """``(shoulder, elbow, wrist)`` above ``joint``: the first two long bones up the chain
    (bones shorter than ``min_bone`` × stature, like a hand or a clavicle stub, are skipped)."""
    short = min_bone * skeleton.stature()

    def up_to_long(j: int) -> int:
        while j > 0 and np.linalg.norm(skeleton.offsets[j]) < short:
            j = int(skeleton.parents[j])
        return j

    wrist = up_to_long(joint)
    elbow = up_to_long(int(skeleton.parents[wrist]))
    shoulder = int(skeleton.parents[elbow])
    if wrist <= 0 or elbow <= 0 or shoulder < 0:
        raise MjmotionError(f"{skeleton.names[joint]!r}: no shoulder-elbow-wrist chain above it")
    return shoulder, elbow, wrist


def reach_hit_point(
    motion: Motion,
    prop: Prop,
    hit_frame: int,
    target: Sequence[float],
    falloff: float = 0.25,
    wrist: str = "locked",
    pose: kinematics.Pose | None = None,
) -> Motion:
    """The shot adapted so ``prop``'s sweet spot meets ``target`` at ``hit_frame`` (seed 003 §2.2).

    The arm (shoulder, elbow, wrist) is solved with analytic two-bone IK, the offset blended in and
    out with a smoothstep over ``falloff`` seconds each side of the hit. ``wrist="locked"`` keeps
    the wrist's local rotation from the source (seed 003 §2.3.3: the club turns with the forearm);
    ``wrist="world"`` keeps the club's world orientation (the wrist absorbs the change).
    ``pose``: ``motion``'s forward kinematics with ``prop`` (computed when not given; a grid of
    targets on one shot passes it once).
    """
    from .cleanup import two_bone_ik

    if wrist not in ("locked", "world"):
        raise MjmotionError(f"wrist={wrist!r}: expected 'locked' or 'world'")
    skel = motion.skeleton
    sh, el, wr = arm_chain(skel, skel.index(prop.joint))
    n = max(1, round(falloff * motion.fps))
    t = np.arange(motion.n_frames)
    x = np.clip(1.0 - np.abs(t - hit_frame) / (n + 1), 0.0, 1.0)
    weight = x * x * (3 - 2 * x)
    act = weight > 0
    pose = pose if pose is not None else kinematics.forward(mjcf.compile(skel, (prop,)), motion)
    delta = np.asarray(target, dtype=float) - pose.site(prop.site)[hit_frame]
    jp, jr = pose.joint_positions, pose.joint_rotations
    if wrist == "locked":
        # Forearm and club are one rigid link from the elbow to the sweet spot: solve that chain.
        end = pose.site(prop.site)[act]
    else:
        end = jp[act, wr]
    r_sh, r_el, _ = two_bone_ik(jp[act, sh], jp[act, el], end, end + weight[act, None] * delta)
    w_sh = rot.multiply(r_sh, jr[act, sh])
    w_el = rot.multiply(r_sh, rot.multiply(r_el, jr[act, el]))
    rots = motion.rotations.copy()
    rots[act, sh] = rot.multiply(rot.conjugate(jr[act, int(skel.parents[sh])]), w_sh)
    rots[act, el] = rot.multiply(rot.conjugate(w_sh), w_el)
    if wrist == "world":
        rots[act, wr] = rot.multiply(rot.conjugate(w_el), jr[act, wr])
    return motion.replace(rotations=rot.normalize(rots))


def effector_path(compiled: CompiledModel, motion: Motion, geom: int, hit_frame: int, window: int = 3) -> tuple[np.ndarray, np.ndarray, int]:
    """World poses ``(pos (n, 3), quat (n, 4))`` of ``geom`` over ``hit_frame ± window`` and the hit's index."""
    m = compiled.model
    q = kinematics.qpos(compiled, motion)
    lo, hi = max(0, hit_frame - window), min(motion.n_frames, hit_frame + window + 1)
    d = mujoco.MjData(m)
    pos = np.empty((hi - lo, 3))
    mats = np.empty((hi - lo, 3, 3))
    for i, f in enumerate(range(lo, hi)):
        d.qpos[:] = q[f]
        mujoco.mj_kinematics(m, d)
        pos[i] = d.geom_xpos[geom]
        mats[i] = d.geom_xmat[geom].reshape(3, 3)
    return pos, rot.make_continuous(rot.from_matrix(mats)), hit_frame - lo


def grid_offsets(motion: Motion, prop: Prop, hit_frame: int, n: int = 3, step: float = 0.05) -> np.ndarray:
    """``(n², 3)`` offsets on an ``n × n`` grid (spacing ``step`` m) across the sweet spot's path at
    the hit: one axis horizontal and perpendicular to its velocity, the other vertical."""
    compiled = mjcf.compile(motion.skeleton, (prop,))
    spot = kinematics.forward(compiled, motion).site(prop.site)
    v = np.gradient(spot, axis=0)[hit_frame]
    lat = np.cross([0.0, 0.0, 1.0], v)
    lat = lat / np.linalg.norm(lat) if np.linalg.norm(lat) > 1e-12 else np.array([0.0, 1.0, 0.0])
    ticks = (np.arange(n) - (n - 1) / 2) * step
    return np.array([a * lat + b * np.array([0.0, 0.0, 1.0]) for b in ticks for a in ticks])


def hit_grid(
    motion: Motion,
    prop: Prop,
    hit_frame: int,
    offsets: np.ndarray,
    wrist: str = "locked",
    ball_radius: float = 0.0214,
    ball_mass: float = 0.046,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    restitution: float = 0.8,
    falloff: float = 0.25,
) -> Predictability:
    """Seed 003 Figure 2.6: adapt the shot to hit points at the source hit point + ``offsets (N, 3)``
    (:func:`reach_hit_point`), launch the ball from each (club and golf ball by default) and
    rank-correlate launch direction with the hit point."""
    compiled = mjcf.compile(motion.skeleton, (prop,))
    geom = mujoco.mj_name2id(compiled.model, mujoco.mjtObj.mjOBJ_GEOM, prop.name)
    # One model and one FK of the source shot serve every grid point.
    pose = kinematics.forward(compiled, motion)
    base = pose.site(prop.site)[hit_frame]
    points = base + np.asarray(offsets, dtype=float)
    paths = []
    h = 0
    for p in points:
        adapted = reach_hit_point(motion, prop, hit_frame, p, falloff, wrist, pose)
        pos, quat, h = effector_path(compiled, adapted, geom, hit_frame)
        paths.append((pos, quat))
    size = compiled.model.geom_size[geom].tolist()
    # The ball sits one radius off the club's axis, in front of the face along the club's motion.
    return launch_predictability(
        int(compiled.model.geom_type[geom]), size, paths, motion.fps, h, points, ball_radius, ball_mass, ball_velocity, restitution
    )
