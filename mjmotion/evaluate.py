"""Physics-checked numbers for a clip: contacts, footskate, ground, limits, smoothness, hitting.

Every definition follows ``docs/METRICS.md``; every threshold is a parameter with the documented
default, and a :class:`Report` carries the values it used. The world is MuJoCo's: Z up, metres,
floor at z = 0.

Reusable building blocks (other modules import these):

- :func:`foot_heights_speeds` ``(compiled, motion) -> FootTrack``: per foot (``"left"``,
  ``"right"``) the foot points (ankle joint, toe joint, the 8 corners of each foot/toe box geom),
  the foot *height* (lowest point above the floor) and the horizontal speed (m/s) of the lowest
  point, all ``(T, F)``.
- :func:`low_both` ``(track, h_c) -> (T, F) bool``: below ``h_c`` at t and t-1 (height alone).
- :func:`contacts` ``(track, h_c=0.05, v_c=0.5) -> (T, F) bool``: METRICS "in contact".
- :func:`skate_mm_per_s` ``(motion | track, h_c=0.05)``: mean horizontal speed (mm/s) of the
  lowest foot point over height-contact frames (pooled over both feet).
- :func:`skating_ratio` ``(motion | track, h_c=0.05, v=0.5, window=5)`` (GMD).
- :func:`skate_sensitivity` ``(motion | track, h_cs=(0.03, 0.05, 0.08))``: the ``h_c`` table.
- :func:`lowest_body_point` ``(compiled, pose) -> (T,)`` z of the lowest point of the body geoms;
  :func:`ground_metrics` ``-> GroundMetrics`` (penetrate_mm, float_mm, phys_err_mm, floor offset).
- :func:`planted_skate_mm_per_s` ``(motion | track, h_c, v_c)``: the same over full contact
  frames (height and speed): the plant sliding that :mod:`mjmotion.cleanup` removes.
- :func:`max_joint_speed_ratio` ``(result, sources)``, :func:`root_jump_m` ``(result, sources)``,
  :func:`limit_violation_ratio` ``(compiled, motion)``, :func:`grip_error_m` ``(result, source,
  first_hand, second_hand)``, :func:`leading_transient` ``(motion)`` (T-pose frames to skip).

Note on ``skate_mm_per_s``: METRICS counts every frame a foot is within ``h_c`` of the floor
(height alone). With the foot's sole box as one of its points, a walking swing foot passes
within 5 cm of the floor for most of its swing, so real walks give ~1 m/s there;
``planted_skate_mm_per_s`` (contact frames) gives the "tens of mm/s" METRICS expects of plants.
- :func:`evaluate` ``(motion, props=(), ball=None, hit_frame=None) -> Report`` runs everything
  (physics residuals from :mod:`mjmotion.physics`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import mujoco
import numpy as np

from . import kinematics, mjcf
from . import rotations as rot
from .errors import MjmotionError, require_number
from .kinematics import Pose
from .mjcf import CompiledModel
from .skeleton import Motion
from .trim import leading_transient  # noqa: F401  (moved to mjmotion.trim; this alias until the lead merges)

#: METRICS.md defaults.
H_C = 0.05  # contact height, m
V_C = 0.5  # contact horizontal speed, m/s (GMD: 2.5 cm/frame at 20 fps)
SKATE_WINDOW = 5  # frames, GMD's averaging window for skating_ratio
FLOAT_TOL = 0.005  # m, PhysDiff's float tolerance
H_C_SENSITIVITY = (0.03, 0.05, 0.08)
#: Central-difference stencil (s) for qvel/qacc; 1/30 s keeps 120 fps marker noise below g.
FD_STEP = 1.0 / 30.0

# The 8 corner sign patterns of a box, (8, 3).
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


# --------------------------------------------------------------------------- geometry


def geom_frames(compiled: CompiledModel, pose: Pose, geom_ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """World pose of character geoms from the joints' world poses.

    Returns ``pos: (T, G, 3)`` metres and ``mat: (T, G, 3, 3)`` (columns are the geom's axes).
    Only geoms on skeleton bodies (not the ball or world geoms).
    """
    m = compiled.model
    gids = np.asarray(geom_ids, dtype=int)
    body_to_joint = {int(b): j for j, b in enumerate(compiled.body_ids)}
    try:
        joints = np.array([body_to_joint[int(m.geom_bodyid[g])] for g in gids], dtype=int)
    except KeyError:
        raise MjmotionError("geom_frames: a geom is not on a skeleton body") from None
    bq = pose.joint_rotations[:, joints]  # (T, G, 4)
    bp = pose.joint_positions[:, joints]
    pos = bp + rot.rotate(bq, np.broadcast_to(m.geom_pos[gids], bq.shape[:-1] + (3,)))
    wq = rot.multiply(bq, np.broadcast_to(m.geom_quat[gids], bq.shape))
    return pos, rot.to_matrix(wq)


def box_corners(pos: np.ndarray, mat: np.ndarray, half: np.ndarray) -> np.ndarray:
    """``(T, G, 8, 3)`` world corners of boxes with centres ``pos (T, G, 3)``, axes ``mat (T, G, 3, 3)``
    and half-sizes ``half (G, 3)``."""
    local = _CORNERS[None, :, :] * half[:, None, :]  # (G, 8, 3)
    return pos[:, :, None, :] + np.einsum("tgij,gkj->tgki", mat, local)


def lowest_points(compiled: CompiledModel, pose: Pose, geom_ids: Sequence[int]) -> np.ndarray:
    """``(T, G, 3)`` lowest world point of each geom (boxes, capsules, spheres; exact for a plane floor)."""
    m = compiled.model
    gids = np.asarray(geom_ids, dtype=int)
    pos, mat = geom_frames(compiled, pose, gids)
    size = m.geom_size[gids]
    gtype = m.geom_type[gids]
    out = np.empty_like(pos)
    down = np.array([0.0, 0.0, -1.0])
    box = gtype == mujoco.mjtGeom.mjGEOM_BOX
    if box.any():
        # The corner whose signs point each axis downwards: c - Σ sign(R[2,i]) h_i R[:, i].
        r = mat[:, box]
        s = -np.sign(r[:, :, 2, :])  # (T, B, 3)
        s[s == 0] = 1.0
        out[:, box] = pos[:, box] + np.einsum("tbij,tbj->tbi", r, s * size[box])
    cap = gtype == mujoco.mjtGeom.mjGEOM_CAPSULE
    if cap.any():
        axis = mat[:, cap][..., 2] * size[cap, 1][None, :, None]
        ends = np.stack([pos[:, cap] + axis, pos[:, cap] - axis], axis=2)  # (T, C, 2, 3)
        k = np.argmin(ends[..., 2], axis=2)
        low = np.take_along_axis(ends, k[:, :, None, None], axis=2)[:, :, 0]
        out[:, cap] = low + down * size[cap, 0][None, :, None]
    sph = gtype == mujoco.mjtGeom.mjGEOM_SPHERE
    if sph.any():
        out[:, sph] = pos[:, sph] + down * size[sph, 0][None, :, None]
    other = ~(box | cap | sph)
    if other.any():
        raise MjmotionError(f"lowest_points: unsupported geom types {sorted(set(gtype[other].tolist()))}")
    return out


def lowest_body_point(compiled: CompiledModel, pose: Pose) -> np.ndarray:
    """``(T,)`` height (m) of the lowest point of the character's geoms (capsules and foot boxes)."""
    return lowest_points(compiled, pose, compiled.body_geom_ids)[..., 2].min(axis=1)


# --------------------------------------------------------------------------- feet and contacts


@dataclass(frozen=True, eq=False)
class FootTrack:
    """The feet of a clip, as METRICS.md defines them.

    Attributes:
        sides: ``(F,)`` foot names (``"left"``, ``"right"``).
        fps: frames per second.
        points: ``(T, F, P, 3)`` world foot points (ankle, toe, box corners), metres.
        heights: ``(T, F)`` lowest foot point above the floor, metres.
        lowest: ``(T, F, 3)`` the lowest foot point.
        speeds: ``(T, F)`` horizontal speed of the lowest foot point (that material point's
            central-difference velocity), m/s.
    """

    sides: tuple[str, ...]
    fps: float
    points: np.ndarray
    heights: np.ndarray
    lowest: np.ndarray
    speeds: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.heights.shape[0])


def foot_points(compiled: CompiledModel, pose: Pose) -> tuple[tuple[str, ...], np.ndarray]:
    """Foot sides and ``(T, F, P, 3)`` points: ankle joint, toe joint (if any), 8 corners per foot geom."""
    skel = compiled.skeleton
    feet = skel.feet()
    if not feet:
        raise MjmotionError(f"{skel.names[0]}…: no feet found by name (need e.g. lfoot/LeftFoot/CC_Base_L_Foot)")
    m = compiled.model
    sides = tuple(s for s in ("left", "right") if s in feet)
    per_side = []
    for s in sides:
        ankle, toe = feet[s]
        pts = [pose.joint_positions[:, [ankle]]]
        if toe is not None:
            pts.append(pose.joint_positions[:, [toe]])
        gids = np.asarray(compiled.foot_geoms.get(s, ()), dtype=int)
        if gids.size:
            pos, mat = geom_frames(compiled, pose, gids)
            corners = box_corners(pos, mat, m.geom_size[gids])
            pts.append(corners.reshape(corners.shape[0], -1, 3))
        per_side.append(np.concatenate(pts, axis=1))
    p = max(x.shape[1] for x in per_side)
    # Pad with repeats of the ankle so feet stack (a missing toe or geom adds no new point).
    stacked = [np.concatenate([x, np.repeat(x[:, :1], p - x.shape[1], axis=1)], axis=1) for x in per_side]
    return sides, np.stack(stacked, axis=1)


def foot_track(sides: tuple[str, ...], points: np.ndarray, fps: float) -> FootTrack:
    """A :class:`FootTrack` from foot points ``(T, F, P, 3)`` (useful for synthetic tests)."""
    if points.shape[0] < 2:
        raise MjmotionError("a clip needs at least 2 frames for foot speeds")
    z = points[..., 2]
    k = np.argmin(z, axis=2)  # (T, F) lowest point index
    heights = np.take_along_axis(z, k[..., None], axis=2)[..., 0]
    lowest = np.take_along_axis(points, k[..., None, None], axis=2)[:, :, 0]
    vel = np.gradient(points[..., :2], 1.0 / fps, axis=0)  # (T, F, P, 2), per second
    v_low = np.take_along_axis(vel, k[..., None, None], axis=2)[:, :, 0]
    return FootTrack(sides, float(fps), points, heights, lowest, np.linalg.norm(v_low, axis=-1))


def foot_heights_speeds(compiled: CompiledModel | None, motion: Motion, pose: Pose | None = None) -> FootTrack:
    """The :class:`FootTrack` of ``motion`` (``compiled`` defaults to its skeleton's model)."""
    compiled = compiled if compiled is not None else mjcf.compile(motion.skeleton)
    pose = pose if pose is not None else kinematics.forward(compiled, motion)
    sides, pts = foot_points(compiled, pose)
    return foot_track(sides, pts, motion.fps)


def _track(x: Motion | FootTrack) -> FootTrack:
    return x if isinstance(x, FootTrack) else foot_heights_speeds(None, x)


def low_both(track: FootTrack, h_c: float = H_C) -> np.ndarray:
    """``(T, F)``: foot height below ``h_c`` at t and at t-1 (frame 0 uses itself as t-1)."""
    low = track.heights < h_c
    prev = np.concatenate([low[:1], low[:-1]], axis=0)
    return low & prev


def contacts(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C) -> np.ndarray:
    """``(T, F)`` contact labels: low at t and t-1 and horizontal speed below ``v_c`` (m/s)."""
    tr = _track(track)
    return low_both(tr, h_c) & (tr.speeds < v_c)


def skate_mm_per_s(track: FootTrack | Motion, h_c: float = H_C, v_c: float | None = None) -> float:
    """Mean horizontal speed (mm/s) of the lowest foot point over height-contact frames.

    Pooled over feet and frames; NaN when no foot is ever low (nothing to measure). With
    ``v_c`` (m/s) only frames that are also slower than ``v_c`` count (full METRICS contact):
    :func:`planted_skate_mm_per_s`. ``v_c=None`` is METRICS' definition (height alone), which on
    real walks also counts the swing foot passing within ``h_c`` of the floor.
    """
    tr = _track(track)
    low = low_both(tr, h_c) if v_c is None else contacts(tr, h_c, v_c)
    if not low.any():
        return float("nan")
    return float(1000.0 * tr.speeds[low].mean())


def planted_skate_mm_per_s(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C) -> float:
    """Mean horizontal speed (mm/s) of the lowest foot point over contact frames (height and speed)."""
    return skate_mm_per_s(track, h_c, v_c)


def skating_ratio(track: FootTrack | Motion, h_c: float = H_C, v: float = V_C, window: int = SKATE_WINDOW) -> float:
    """GMD's skating ratio: fraction of frames where some foot is low (t, t-1) while its horizontal
    speed averaged over a centred ``window``-frame window exceeds ``v`` m/s."""
    from scipy.ndimage import uniform_filter1d

    tr = _track(track)
    avg = uniform_filter1d(tr.speeds, size=window, axis=0, mode="nearest")
    skating = low_both(tr, h_c) & (avg > v)
    return float(skating.any(axis=1).mean())


def skate_sensitivity(track: FootTrack | Motion, h_cs: Sequence[float] = H_C_SENSITIVITY, v_c: float = V_C) -> list[dict[str, float]]:
    """Rows ``{h_c, skate_mm_per_s, skating_ratio, contact_fraction}`` for each ``h_c`` (UnderPressure)."""
    tr = _track(track)
    return [
        {
            "h_c": float(h),
            "skate_mm_per_s": skate_mm_per_s(tr, h),
            "skating_ratio": skating_ratio(tr, h, v_c),
            "contact_fraction": float(contacts(tr, h, v_c).mean()),
        }
        for h in h_cs
    ]


def flight_frames(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C) -> np.ndarray:
    """``(T,)`` frames where no foot is in contact."""
    return ~contacts(track, h_c, v_c).any(axis=1)


# --------------------------------------------------------------------------- ground


@dataclass(frozen=True)
class GroundMetrics:
    """PhysDiff ground metrics (per frame, averaged over frames) and the detected floor offset.

    ``floor_offset_m`` is the median lowest body-geom height over stance frames (the lower foot
    slower than ``v_c``): where this clip's floor really is. Reported, never applied.
    """

    penetrate_mm: float
    float_mm: float
    skate_mm_per_frame: float
    phys_err_mm: float
    fps: float
    floor_offset_m: float
    max_penetrate_mm: float


def ground_metrics(
    lowest_z: np.ndarray,
    track: FootTrack,
    h_c: float = H_C,
    v_c: float = V_C,
    float_tol: float = FLOAT_TOL,
) -> GroundMetrics:
    """Ground metrics from the per-frame lowest body point ``lowest_z: (T,)`` and the feet.

    Skate displacement per frame: horizontal displacement (mm) of the height-contact feet between
    frames (speed / fps), averaged over the feet in contact, 0 when none; then over all frames.
    """
    pen = np.maximum(0.0, -lowest_z)
    flo = np.maximum(0.0, lowest_z - float_tol)
    low = low_both(track, h_c)
    disp = track.speeds / track.fps * 1000.0
    n = low.sum(axis=1)
    per_frame = np.where(n > 0, (disp * low).sum(axis=1) / np.maximum(n, 1), 0.0)
    # Stance frames judged by speed alone (the lower foot is still), so a clip whose floor is off
    # by more than h_c still finds it.
    lower = np.argmin(track.heights, axis=1)
    stance = np.take_along_axis(track.speeds, lower[:, None], axis=1)[:, 0] < v_c
    offset = float(np.median(lowest_z[stance])) if stance.any() else float(np.percentile(lowest_z, 5))
    p, f, s = float(pen.mean() * 1000), float(flo.mean() * 1000), float(per_frame.mean())
    return GroundMetrics(p, f, s, p + f + s, float(track.fps), offset, float(pen.max() * 1000))


# --------------------------------------------------------------------------- smoothness and limits


def joint_angular_speeds(motion: Motion) -> np.ndarray:
    """``(T-1, J)`` angular speed (rad/s) of every joint's local rotation between frames."""
    q = motion.rotations
    d = rot.multiply(rot.conjugate(q[:-1]), q[1:])
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0])) * motion.fps


def _as_list(sources: Motion | Sequence[Motion]) -> list[Motion]:
    return [sources] if isinstance(sources, Motion) else list(sources)


def max_joint_speed_ratio(result: Motion, sources: Motion | Sequence[Motion]) -> float:
    """Max joint angular speed of ``result`` over the max in ``sources`` (1 = no faster than its sources)."""
    src = max(float(joint_angular_speeds(s).max()) for s in _as_list(sources))
    return float(joint_angular_speeds(result).max() / max(src, 1e-12))


def root_jump_m(result: Motion, sources: Motion | Sequence[Motion]) -> float:
    """Largest frame-to-frame root displacement (m) of ``result`` minus the largest in ``sources``."""

    def jump(m: Motion) -> float:
        return float(np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1).max()) if m.n_frames > 1 else 0.0

    return jump(result) - max(jump(s) for s in _as_list(sources))


def grip_error_m(result: Motion, source: Motion, first_hand: str | int, second_hand: str | int) -> float:
    """Two-handed props: max over frames of the distance between the second hand and where the
    source holds it relative to the first hand (position in the first hand's frame), metres.

    ``result`` and ``source`` are paired frame by frame (the shorter length is used).
    """
    skel = source.skeleton
    a = first_hand if isinstance(first_hand, int) else skel.index(first_hand)
    b = second_hand if isinstance(second_hand, int) else skel.index(second_hand)
    n = min(result.n_frames, source.n_frames)
    c = mjcf.compile(skel)
    ps = kinematics.forward(c, source[:n])
    pr = kinematics.forward(c if result.skeleton is skel else mjcf.compile(result.skeleton), result[:n])
    rel = rot.rotate(rot.conjugate(ps.joint_rotations[:, a]), ps.joint_positions[:, b] - ps.joint_positions[:, a])
    want = pr.joint_positions[:, a] + rot.rotate(pr.joint_rotations[:, a], rel)
    return float(np.linalg.norm(pr.joint_positions[:, b] - want, axis=1).max())


def limit_violation_ratio(compiled: CompiledModel, motion: Motion) -> tuple[float, int]:
    """Fraction of frames where a joint leaves its declared range, and the number of limited joints.

    Ball joints: rotation angle beyond ``range[1]``; slide/hinge: outside ``[range[0], range[1]]``.
    A model that declares no limits gives ``(0.0, 0)``.
    """
    m = compiled.model
    q = kinematics.qpos(compiled, motion)
    bad = np.zeros(motion.n_frames, dtype=bool)
    n = 0
    for j in range(m.njnt):
        if not m.jnt_limited[j]:
            continue
        n += 1
        a = int(m.jnt_qposadr[j])
        lo, hi = m.jnt_range[j]
        t = m.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_BALL:
            w = np.clip(np.abs(q[:, a]), 0.0, 1.0)
            bad |= 2.0 * np.arccos(w) > hi
        elif t in (mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE):
            bad |= (q[:, a] < lo) | (q[:, a] > hi)
    return float(bad.mean()), n


# --------------------------------------------------------------------------- the report


@dataclass(frozen=True)
class Params:
    """The thresholds a report used (METRICS.md defaults)."""

    h_c: float = H_C
    v_c: float = V_C
    skate_window: int = SKATE_WINDOW
    float_tol: float = FLOAT_TOL
    mu: float = 1.0
    cop_margin: float = 0.02
    flight_force_ratio: float = 0.2
    fd_step: float = FD_STEP
    h_c_sensitivity: tuple[float, ...] = H_C_SENSITIVITY

    def __post_init__(self) -> None:
        positive = ("h_c", "v_c", "float_tol", "mu", "fd_step")
        for name in (*positive, "cop_margin", "flight_force_ratio"):
            require_number(f"Params.{name} =", getattr(self, name), strict=name in positive)
        if isinstance(self.skate_window, bool) or not isinstance(self.skate_window, numbers.Integral) or self.skate_window < 1:
            raise MjmotionError(f"Params.skate_window = {self.skate_window!r}: expected a whole number of frames ≥ 1")
        if not all(isinstance(h, numbers.Real) and math.isfinite(h) and h > 0 for h in self.h_c_sensitivity):
            raise MjmotionError(f"Params.h_c_sensitivity = {self.h_c_sensitivity!r}: expected finite contact heights > 0")


@dataclass(frozen=True)
class Report:
    """Every metric of one clip (see METRICS.md); ``None`` where it does not apply."""

    name: str
    n_frames: int
    fps: float
    params: Params
    skate_mm_per_s: float
    planted_skate_mm_per_s: float
    skating_ratio: float
    contact_fraction: float
    flight_fraction: float
    sensitivity: tuple[dict[str, float], ...]
    penetrate_mm: float
    float_mm: float
    phys_err_mm: float
    max_penetrate_mm: float
    floor_offset_m: float
    root_force_ratio_mean: float
    flight_residual: float
    physics_violation_ratio: float
    limit_violation_ratio: float
    limited_joints: int
    max_joint_speed_rad_s: float
    max_root_step_m: float
    hit: dict[str, Any] | None = field(default=None)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["sensitivity"] = [dict(r) for r in self.sensitivity]
        return d

    def row(self) -> dict[str, Any]:
        """The flat, table-friendly summary (one value per column)."""
        r: dict[str, Any] = {
            "clip": self.name,
            "frames": self.n_frames,
            "fps": round(self.fps, 2),
            "skate_mm_s": self.skate_mm_per_s,
            "planted_mm_s": self.planted_skate_mm_per_s,
            "skating_ratio": self.skating_ratio,
            "contact_frac": self.contact_fraction,
            "flight": self.flight_fraction,
            "penetrate_mm": self.penetrate_mm,
            "float_mm": self.float_mm,
            "phys_err_mm": self.phys_err_mm,
            "floor_m": self.floor_offset_m,
            "flight_resid": self.flight_residual,
            "phys_viol": self.physics_violation_ratio,
            "limit_viol": self.limit_violation_ratio,
        }
        for s in self.sensitivity:
            r[f"skate@{s['h_c']:.2f}"] = s["skate_mm_per_s"]
        if self.hit:
            for k in ("hit_error_m", "contact", "impact_speed", "launch_azimuth_deg", "launch_elevation_deg", "launch_speed"):
                if k in self.hit:
                    r[k] = self.hit[k]
        return r


def evaluate(
    motion: Motion,
    props: Sequence[mjcf.Prop] = (),
    ball: mjcf.Ball | None = None,
    hit_frame: int | None = None,
    params: Params = Params(),
    launch: bool = True,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
) -> Report:
    """All metrics of ``motion``. With ``ball`` and ``hit_frame``: the hitting metrics too
    (effector: the first prop's sweet spot, else the foot or hand geom nearest the ball)."""
    from . import physics

    compiled = mjcf.compile(motion.skeleton, tuple(props))
    pose = kinematics.forward(compiled, motion)
    track = foot_heights_speeds(compiled, motion, pose)
    lz = lowest_body_point(compiled, pose)
    g = ground_metrics(lz, track, params.h_c, params.v_c, params.float_tol)
    res = physics.residuals(compiled, motion, track, params)  # res.flight: no foot in contact (h_c, v_c)
    lim, nlim = limit_violation_ratio(compiled, motion)
    speeds = joint_angular_speeds(motion) if motion.n_frames > 1 else np.zeros((1, 1))
    steps = np.linalg.norm(np.diff(motion.root_positions, axis=0), axis=1) if motion.n_frames > 1 else np.zeros(1)
    hit = None
    if ball is not None:
        if hit_frame is None:
            raise MjmotionError("a ball needs a hit frame (--frame H)")
        hit = physics.hit_metrics(motion, ball, hit_frame, props=tuple(props), launch=launch, ball_velocity=ball_velocity)
    return Report(
        name=motion.name,
        n_frames=motion.n_frames,
        fps=float(motion.fps),
        params=params,
        skate_mm_per_s=skate_mm_per_s(track, params.h_c),
        planted_skate_mm_per_s=planted_skate_mm_per_s(track, params.h_c, params.v_c),
        skating_ratio=skating_ratio(track, params.h_c, params.v_c, params.skate_window),
        contact_fraction=float((~res.flight).mean()),
        flight_fraction=float(res.flight.mean()),
        sensitivity=tuple(skate_sensitivity(track, params.h_c_sensitivity, params.v_c)),
        penetrate_mm=g.penetrate_mm,
        float_mm=g.float_mm,
        phys_err_mm=g.phys_err_mm,
        max_penetrate_mm=g.max_penetrate_mm,
        floor_offset_m=g.floor_offset_m,
        root_force_ratio_mean=float(np.mean(res.root_force_ratio)),
        flight_residual=res.flight_residual,
        physics_violation_ratio=res.physics_violation_ratio,
        limit_violation_ratio=lim,
        limited_joints=nlim,
        max_joint_speed_rad_s=float(speeds.max()),
        max_root_step_m=float(steps.max()),
        hit=hit,
    )
