"""Feet as the judge sees them: sole points, heights above the floor, speeds, contact labels.

``docs/METRICS.md`` "Foot contact". A foot is a set of **sole points**: two heel points behind
the ankle, two at the ball of the foot and, where the skeleton has a toe joint, two at the toe
tip riding on the toe (:class:`Soles`). Their placement is *calibrated* from the clip (or the
sources a result is judged against): the sole's normal, in the ankle's (and toe's) frame, is the
mean world "up" seen from that frame over the foot's quiet stance frames (slowest quarter of
ankle speeds within its lowest 40 % of heights), so the sole lies flat on the floor at mid-stance
whatever the rig's rest pose (iClone's rest is no standing pose; CMU ASF's foot rests rolled 25°
from its stance); quiet frames that hold two stances (a golfer's lead foot) give way to the
orientation the foot holds most (:data:`SPLIT_DEG`). The sole sits ``mjcf.ANKLE_HEIGHT`` × stature
below the ankle (at least as deep as the foot's own joints and End Sites; the bundled humanoid's
where it was made to stand, :func:`mjmotion.humanoid.sole_depth`), the heel ``mjcf.HEEL_BACK`` ×
stature behind it. Clips
too short to calibrate use the rest pose, as :func:`mjmotion.mjcf.compile` does for its boxes.

A foot's *height* is its lowest sole point above the floor (:mod:`mjmotion.floor`); its *speed*
is the horizontal speed of that point, the slope of a local quadratic over 0.1 s
(:func:`mjmotion.filters.velocity`, ``Params.speed_window``). :func:`contacts` labels a foot in contact with hysteresis.

Reusable pieces:

- :func:`geom_frames`, :func:`box_corners`, :func:`lowest_points`, :func:`lowest_heights`, :func:`lowest_body_point`
- :func:`calibrate_soles` ``(skeleton, poses) -> Soles``, :func:`sole_points` ``(soles, pose)``
- :func:`sole_boxes`, :func:`judged_model`: a model whose drawn feet are the judge's soles
- :class:`FootTrack`, :func:`foot_track`, :func:`foot_heights_speeds`
- :func:`judged_feet` ``(compiled, motion, pose, sources, floor) -> (FootTrack, Soles, Floor)``, :func:`judged_floor`: the judge's feet and floor
- :func:`level_pose`, :func:`level_motion`: a clip in the levelled frame of a tilted floor (``Floor.level``)
- :func:`low_both`, :func:`contacts`, :func:`flight_frames`
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from . import floor as floors
from . import humanoid, kinematics, mjcf
from . import rotations as rot
from .errors import MjmotionError
from .filters import lowpass, velocity
from .kinematics import Pose
from .mjcf import CompiledModel
from .skeleton import Motion, Skeleton, same_rate
from .thresholds import CUTOFF_HZ, H_C, HYSTERESIS, MIN_FRAMES, SPEED_WINDOW, V_C

# The 8 corner sign patterns of a box, (8, 3).
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
#: Half width of a sole, × stature / 1.75 m (the compiled foot boxes' width).
SOLE_HALF_WIDTH = 0.045
#: Quiet stance frames for the sole calibration: the slowest quarter of ankle speeds among the
#: frames in the lowest 40 % of ankle heights.
QUIET_SPEED_QUANTILE = 0.25
QUIET_HEIGHT_QUANTILE = 0.4
#: Quiet frames whose "up" (seen from the ankle) lies more than this from their mean hold two
#: stances: a golfer's lead foot, flat at address and rolled 30–56° onto its edge at the finish
#: (CMU 64_01, 64_03–05; every other foot of the shared clips stays within 24°). The sole is then
#: calibrated on the orientation the slow foot holds most (:func:`_held_most`).
SPLIT_DEG = 25.0
#: Frames within this of one another hold one orientation (:func:`_held_most`).
HELD_DEG = 10.0
#: Fewest frames a clip needs to calibrate its soles (else the rest pose is used).
MIN_CALIBRATION_FRAMES = 20


# --------------------------------------------------------------------------- geometry


def geom_frames(compiled: CompiledModel, pose: Pose, geom_ids: Sequence[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def lowest_points(compiled: CompiledModel, pose: Pose, geom_ids: Sequence[int] | np.ndarray) -> np.ndarray:
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


def _support_points(compiled: CompiledModel, geom_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each geom as points in its body's frame whose lowest, minus a radius, is the geom's lowest:
    ``points (G, 8, 3)`` (a box's corners; a capsule's two axis ends, a sphere's centre, repeated),
    ``radius (G,)`` and the joint ``(G,)`` of each geom's body."""
    m = compiled.model
    body_to_joint = {int(b): j for j, b in enumerate(compiled.body_ids)}
    try:
        joints = np.array([body_to_joint[int(m.geom_bodyid[g])] for g in geom_ids], dtype=int)
    except KeyError:
        raise MjmotionError("lowest point: a geom is not on a skeleton body") from None
    gids = np.asarray(geom_ids, dtype=int)
    size, kind = m.geom_size[gids], m.geom_type[gids]
    box = kind == mujoco.mjtGeom.mjGEOM_BOX
    cap = kind == mujoco.mjtGeom.mjGEOM_CAPSULE
    sph = kind == mujoco.mjtGeom.mjGEOM_SPHERE
    if not (box | cap | sph).all():
        raise MjmotionError(f"lowest point: unsupported geom types {sorted(set(kind[~(box | cap | sph)].tolist()))}")
    # In the geom's frame: a box's corners; a capsule's two axis ends (repeated); a sphere's centre.
    ends = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])[[0, 1, 0, 1, 0, 1, 0, 1]]
    local = np.where(box[:, None, None], _CORNERS[None] * size[:, None, :], ends[None] * size[:, None, 1:2] * cap[:, None, None])
    radius = np.where(cap | sph, size[:, 0], 0.0)
    pts = m.geom_pos[gids][:, None, :] + np.einsum("gij,gkj->gki", rot.to_matrix(m.geom_quat[gids]), local)
    return pts, radius, joints


def lowest_heights(compiled: CompiledModel, pose: Pose, geom_ids: Sequence[int] | np.ndarray) -> np.ndarray:
    """``(T, G)`` world height of the lowest point of each geom (boxes, capsules, spheres; exact
    for a plane floor) — only heights, from the third row of each body's rotation, so it costs a
    fraction of :func:`lowest_points`."""
    gids = np.asarray(geom_ids, dtype=int)
    pts, radius, joints = _support_points(compiled, gids)
    q = pose.joint_rotations[:, joints]  # (T, G, 4)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    row = np.stack([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)], axis=-1)  # (T, G, 3)
    # (G, T, 3) @ (G, 3, 8): one BLAS product per geom (einsum's loop took 14x longer).
    # The minimum over a geom's points before adding its body's height (rounding is monotonic: the
    # same numbers), over the product's contiguous last axis.
    low = (row.transpose(1, 0, 2) @ pts.transpose(0, 2, 1)).min(axis=2).T  # (T, G)
    return pose.joint_positions[:, joints, 2] + low - radius


def lowest_body_point(compiled: CompiledModel, pose: Pose, sole_z: np.ndarray | None = None) -> np.ndarray:
    """``(T,)`` height (m, world z) of the lowest point of the character.

    Without ``sole_z``: the lowest point of all the character's geoms (bone capsules and the
    compiled foot boxes). With ``sole_z: (T,)`` (the lowest sole point, :class:`FootTrack`): the
    foot boxes are left out and the soles stand in for them — what the judge measures.
    """
    gids = compiled.body_geom_ids
    if sole_z is not None:
        feet = {int(g) for side in compiled.foot_geoms.values() for g in side}
        gids = np.array([g for g in gids if int(g) not in feet], dtype=int)
    low = lowest_heights(compiled, pose, gids).min(axis=1) if len(gids) else np.full(pose.joint_positions.shape[0], np.inf)
    return low if sole_z is None else np.minimum(low, sole_z)


# --------------------------------------------------------------------------- soles


@dataclass(frozen=True, eq=False)
class Soles:
    """Where each foot meets the floor.

    Attributes:
        sides: ``(F,)`` foot names (``"left"``, ``"right"``).
        joints: ``(F, P)`` the joint each sole point rides on (ankle or toe).
        local: ``(F, P, 3)`` each point in its joint's frame, metres.
        normals: ``(F, 3)`` the sole's normal in the ankle's frame.
        calibrated: True when placed from stance frames, False from the rest pose.
    """

    sides: tuple[str, ...]
    joints: np.ndarray
    local: np.ndarray
    normals: np.ndarray
    calibrated: bool


def _rest_up(skeleton: Skeleton) -> np.ndarray:
    """The rest pose's "up" (from the ankles to the head), world = every joint's frame at rest."""
    rest = skeleton.rest_positions()
    feet = skeleton.feet()
    ankles = np.array([rest[a] for a, _ in feet.values()])
    head = next((j for j, n in enumerate(skeleton.names) if "head" in n.lower() and "end" not in n.lower()), None)
    top = rest[head] if head is not None else rest[int(np.argmax(np.linalg.norm(rest - rest[0], axis=1)))]
    up = top - ankles.mean(axis=0)
    n = np.linalg.norm(up)
    return up / n if n > 1e-9 else np.array([0.0, 0.0, 1.0])


def _quiet_frames(poses: Sequence[tuple[Pose, float]], ankles: Sequence[int]) -> dict[int, list[tuple[Pose, np.ndarray]]]:
    """Per ankle, the ``(pose, quiet (T,) bool)`` of every pose long enough to calibrate from:
    its quiet stance frames (low and slow; every ankle's track filtered in one call per pose)."""
    out: dict[int, list[tuple[Pose, np.ndarray]]] = {a: [] for a in ankles}
    for pose, fps in poses:
        p = pose.joint_positions[:, list(ankles)]  # (T, A, 3)
        if len(p) < MIN_CALIBRATION_FRAMES:
            continue
        v = np.linalg.norm(np.gradient(lowpass(p[..., :2], fps, CUTOFF_HZ), axis=0), axis=-1)  # (T, A)
        for i, a in enumerate(ankles):
            low = p[:, i, 2] <= np.quantile(p[:, i, 2], QUIET_HEIGHT_QUANTILE)
            quiet = low & (v[:, i] <= np.quantile(v[low, i], QUIET_SPEED_QUANTILE))
            ups = _ups(pose, a)
            mean = ups[quiet].mean(axis=0)
            if (ups[quiet] @ mean).min() < np.cos(np.radians(SPLIT_DEG)) * np.linalg.norm(mean):
                quiet = _held_most(ups, v[:, i] <= np.quantile(v[:, i], QUIET_SPEED_QUANTILE))
            out[a].append((pose, quiet))
    return out


def _ups(pose: Pose, joint: int, frames: np.ndarray | slice = slice(None)) -> np.ndarray:
    """``(N, 3)`` the world's up seen from ``joint``'s frame in ``frames`` (every frame by default)."""
    r = pose.joint_rotations[frames, joint]
    return rot.rotate(rot.conjugate(r), np.broadcast_to([0.0, 0.0, 1.0], r.shape[:-1] + (3,)))


def _held_most(ups: np.ndarray, slow: np.ndarray) -> np.ndarray:
    """``(T,) bool``: the ``slow`` frames whose ``ups (T, 3)`` lie within :data:`HELD_DEG` of the one
    most of them are near: the orientation the slow foot holds longest (seeds thinned to 400)."""
    cand = np.flatnonzero(slow)
    near = np.cos(np.radians(HELD_DEG))
    seeds = cand[:: max(1, len(cand) // 400)]
    best = seeds[int(np.argmax((ups[seeds] @ ups[cand].T >= near).sum(axis=1)))]
    held = np.zeros(len(ups), dtype=bool)
    held[cand[ups[cand] @ ups[best] >= near]] = True
    return held


def _quiet_up(quiet: Sequence[tuple[Pose, np.ndarray]], joint: int) -> np.ndarray | None:
    """Mean world up seen from ``joint``'s frame over the ``quiet`` frames of its foot's ankle
    (:func:`_quiet_frames`), or None."""
    ups = [_ups(pose, joint, frames) for pose, frames in quiet]
    if not ups:
        return None
    u = np.concatenate(ups).mean(axis=0)
    n = np.linalg.norm(u)
    return u / n if n > 1e-6 else None


def _tip(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The point of ``points (N, 3)`` farthest from the origin across ``normal`` (the foot's tip)."""
    across = points - np.outer(points @ normal, normal)
    return points[int(np.argmax(np.linalg.norm(across, axis=1)))]


def _onto_sole(p: np.ndarray, normal: np.ndarray, depth: float) -> np.ndarray:
    """``p (3,)`` moved along ``normal`` onto the plane ``depth`` below the origin."""
    return p - (np.dot(p, normal) + depth) * normal


def calibrate_soles(skeleton: Skeleton, poses: Sequence[tuple[Pose, float]] = ()) -> Soles:
    """Sole points of each foot, placed from the quiet stance frames of ``poses``
    (``(Pose, fps)`` of clips of this skeleton); from the rest pose when none is long enough."""
    feet = skeleton.feet()
    if not feet:
        raise MjmotionError(f"the skeleton rooted at {skeleton.names[0]!r} has no feet found by name (need e.g. lfoot/LeftFoot/CC_Base_L_Foot)")
    rest = skeleton.rest_positions()
    ends = skeleton.rest_end_positions()
    height = float(np.clip(skeleton.stature(), 0.3, 3.0))
    half_w = SOLE_HALF_WIDTH * height / 1.75
    up_rest = _rest_up(skeleton)
    bundled = humanoid.bundled_scale(skeleton)
    sides = tuple(s for s in ("left", "right") if s in feet)
    joints, local, normals = [], [], []
    calibrated = True
    quiet = _quiet_frames(poses, [feet[side][0] for side in sides])
    for side in sides:
        ankle, toe = feet[side]
        n_a = _quiet_up(quiet[ankle], ankle)
        if n_a is None:
            n_a, calibrated = up_rest, False
        below = skeleton.descendants(ankle)
        pts = np.array(
            [rest[c] - rest[ankle] for c in below] + [ends[e] - rest[ankle] for e in range(len(ends)) if skeleton.end_parents[e] in [*below, ankle]]
        )
        if len(pts) == 0:
            pts = np.array([[0.0, 0.0, -0.05 * height]])
        tip = _tip(pts, n_a)
        fwd = tip - np.dot(tip, n_a) * n_a
        fwd = fwd / max(np.linalg.norm(fwd), 1e-9)
        lat = np.cross(n_a, fwd)
        # The sole: ANKLE_HEIGHT below the ankle, never above one of the foot's own joints or End Sites;
        # the bundled humanoid's where it was made to stand.
        depth = humanoid.sole_depth(bundled) if bundled is not None else max(mjcf.ANKLE_HEIGHT * height, float(-(pts @ n_a).min()))
        heel = _onto_sole(-mjcf.HEEL_BACK * height * fwd, n_a, depth)
        ball = _onto_sole(rest[toe] - rest[ankle] if toe is not None else tip, n_a, depth)
        j_pts = [ankle] * 4
        p_pts = [heel + half_w * lat, heel - half_w * lat, ball + half_w * lat, ball - half_w * lat]
        if toe is not None:
            n_t = _quiet_up(quiet[ankle], toe) if calibrated else None
            n_t = n_a if n_t is None else n_t
            t_pts = [rest[c] - rest[toe] for c in skeleton.descendants(toe)]
            t_pts += [ends[e] - rest[toe] for e in range(len(ends)) if skeleton.end_parents[e] in [*skeleton.descendants(toe), toe]]
            b_t = ball - (rest[toe] - rest[ankle])  # the ball point from the toe joint
            if t_pts:
                t_tip = _tip(np.asarray(t_pts), n_t)
                t_tip = t_tip - np.dot(t_tip - b_t, n_t) * n_t  # onto the toe's sole, through the ball
                lat_t = np.cross(n_t, t_tip - b_t)
                lat_t = lat_t / max(np.linalg.norm(lat_t), 1e-9) * half_w
                j_pts += [toe, toe]
                p_pts += [t_tip + lat_t, t_tip - lat_t]
        joints.append(j_pts)
        local.append(p_pts)
        normals.append(n_a)
    p_max = max(len(j) for j in joints)
    # Pad with repeats so feet stack (a repeated point adds nothing).
    joints = [j + [j[0]] * (p_max - len(j)) for j in joints]
    local = [p + [p[0]] * (p_max - len(p)) for p in local]
    return Soles(sides, np.array(joints, dtype=int), np.array(local, dtype=float), np.array(normals), calibrated)


def sole_points(soles: Soles, pose: Pose) -> np.ndarray:
    """``(T, F, P, 3)`` world sole points of ``pose``."""
    j = soles.joints  # (F, P)
    r = pose.joint_rotations[:, j]  # (T, F, P, 4)
    return pose.joint_positions[:, j] + rot.rotate(r, np.broadcast_to(soles.local, r.shape[:-1] + (3,)))


def _lateral(normal: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """A unit vector on the plane with ``normal``, across ``forward`` where it has a direction on it."""
    for d in (forward, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        y = np.cross(normal, d)
        if float(np.linalg.norm(y)) > 1e-9:
            return y / float(np.linalg.norm(y))
    raise ValueError("a sole plane without a normal")  # (sole_boxes passes unit normals only)


def _box(a: np.ndarray, b: np.ndarray, side: np.ndarray, normal: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The box whose underside is the sole patch ``a ± side`` to ``b ± side`` (midpoints of its back
    and front edges and their half-width vector, on a sole plane with ``normal``), as ``(pos, quat,
    half_sizes)`` in their frame. Its width runs along ``side`` (the sole's own lateral), its length
    along the rest of ``b - a``: a ball set off the heel's line shifts the box sideways, not its tilt."""
    width = float(np.linalg.norm(side))
    y = side / width if width > 1e-6 else _lateral(normal, b - a)  # (a foot of zero-length bones has no patch)
    x = np.cross(y, normal)
    x = x / max(float(np.linalg.norm(x)), 1e-12)
    x = x if x @ (b - a) >= 0 else -x
    length = float(x @ (b - a))
    quat = mjcf.mat_quat(np.column_stack([x, np.cross(normal, x), normal]))
    # At least 1 cm long and wide: MuJoCo refuses a box of zero size (or zero mass) in a body that moves.
    half = np.array([max(0.5 * length, 0.01), max(width, 0.01), max(0.5 * thickness, 0.005)])
    return 0.5 * (a + b) + half[2] * normal, quat, half  # the underside on the sole, however thin the box


def sole_boxes(skeleton: Skeleton, soles: Soles) -> mjcf.FootBoxes:
    """Foot boxes whose undersides are ``soles``' sole planes (:data:`mjmotion.mjcf.FootBoxes`, for
    :func:`mjmotion.mjcf.compile`): heel to ball on the ankle, ball to toe tip on the toe joint where
    the foot has one. A model compiled with them draws the feet where the judge measures them, so a
    foot the judge finds on the floor touches the floor drawn at the judge's floor (the rest-pose
    boxes of ``compile`` sit up to a few centimetres above or below those soles)."""
    height = float(np.clip(skeleton.stature(), 0.3, 3.0))
    rest = skeleton.rest_positions()
    feet_ = skeleton.feet()
    out: mjcf.FootBoxes = {}
    for f, side in enumerate(soles.sides):
        ankle, toe = feet_[side]
        n, pts, joints = soles.normals[f], soles.local[f], soles.joints[f]
        if not (np.all(np.isfinite(n)) and abs(float(np.linalg.norm(n)) - 1.0) < 1e-6):
            continue  # no sole plane (a foot of zero-length bones): the foot keeps its capsules alone
        heel, ball = pts[0:2].mean(axis=0), pts[2:4].mean(axis=0)
        # As thick as the rest-pose boxes (mjcf._foot_boxes): up to the ankle, at most 9 cm for 1.75 m.
        thick = min(-float(heel @ n), 0.09 * height / 1.75)
        out.setdefault(ankle, {})[f"foot/{side}"] = _box(heel, ball, 0.5 * (pts[0] - pts[1]), n, thick)
        if toe is not None and len(joints) >= 6 and joints[4] == toe:
            base = ball - (rest[toe] - rest[ankle])  # the ball, from the toe joint
            tip = pts[4:6].mean(axis=0)
            n_t = np.cross(tip - base, pts[4] - pts[5])
            size = float(np.linalg.norm(n_t))
            n_t = (n_t if n_t @ n >= 0 else -n_t) / size if size > 1e-9 else n  # (a zero-length toe: the foot's plane)
            out.setdefault(toe, {})[f"toe/{side}"] = _box(base, tip, 0.5 * (pts[4] - pts[5]), n_t, min(-float(base @ n_t), 0.04 * height / 1.75))
    return out


def judged_model(motion: Motion, props: Sequence[mjcf.Prop] = (), ball: mjcf.Ball | None = None) -> CompiledModel:
    """``mjcf.compile(motion.skeleton, props, ball)`` with the feet drawn on the soles the judge calibrates
    on ``motion`` itself (:func:`calibrate_soles`, :func:`sole_boxes`): what ``render``, the studio and
    ``compile`` use. A skeleton without feet gets the plain model."""
    plain = mjcf.compile(motion.skeleton, tuple(props), ball)
    if not motion.skeleton.feet() or motion.n_frames < 1:
        return plain
    soles = calibrate_soles(motion.skeleton, [(kinematics.forward(plain, motion), motion.fps)])
    return mjcf.compile(motion.skeleton, tuple(props), ball, foot_boxes=sole_boxes(motion.skeleton, soles))


# --------------------------------------------------------------------------- tracks


@dataclass(frozen=True, eq=False)
class FootTrack:
    """The feet of a clip (``docs/METRICS.md`` "Foot contact").

    Attributes:
        sides: ``(F,)`` foot names (``"left"``, ``"right"``).
        fps: frames per second.
        points: ``(T, F, P, 3)`` world sole points, metres.
        heights: ``(T, F)`` lowest sole point above the floor, metres.
        lowest: ``(T, F, 3)`` the lowest sole point (world).
        speeds: ``(T, F)`` horizontal speed of the lowest point (that material point's velocity,
            smoothed: :func:`mjmotion.filters.velocity`), m/s.
        floor: the floor height the heights are measured from (m, world z).
        soles: the sole points' placement, when the track came from a skeleton.
        climb: ``(T, F)`` vertical speed of the lowest point (m/s, signed), or None.
        speed_window: the window (s) the speeds were smoothed over (None: central differences).
    """

    sides: tuple[str, ...]
    fps: float
    points: np.ndarray
    heights: np.ndarray
    lowest: np.ndarray
    speeds: np.ndarray
    floor: float = 0.0
    soles: Soles | None = None
    climb: np.ndarray | None = None
    speed_window: float | None = SPEED_WINDOW

    @property
    def n_frames(self) -> int:
        return int(self.heights.shape[0])

    def at_floor(self, floor: float) -> FootTrack:
        """The same track measured from another floor height."""
        return replace(self, heights=self.heights + self.floor - float(floor), floor=float(floor))

    @functools.cached_property
    def lowest_steps(self) -> np.ndarray:
        """``(2·half+1, T, F, 2)``: where each frame's lowest sole point is, horizontally, ``d``
        frames later (``d = −half … half``, ``half`` that of the speed window), relative to frame t;
        0 where ``t + d`` is outside the clip. What :func:`planted_speeds` regresses on, whatever
        the contact labels, gathered once per track (the judge asks for several labellings)."""
        t_count, n_feet = self.heights.shape
        half = _speed_frames(self) // 2
        k = np.argmin(self.points[..., 2], axis=2)  # (T, F) the lowest point
        xy = self.points[..., :2]  # (T, F, P, 2)
        t = np.arange(t_count)
        src = t[None, :] + np.arange(-half, half + 1)[:, None]  # (D, T)
        inside = (src >= 0) & (src < t_count)
        at = xy[np.clip(src, 0, t_count - 1)[:, :, None], np.arange(n_feet)[None, None, :], k[None]]  # (D, T, F, 2)
        at -= xy[t[:, None], np.arange(n_feet)[None, :], k][None]
        at[~inside] = 0.0
        return at

    def detected_floor(self) -> float:
        """This clip's own stance floor (:func:`mjmotion.floor.detect`; a foot moving up or down is not still)."""
        still = self.speeds if self.climb is None else np.hypot(self.speeds, self.climb)
        return floors.detect(self.heights + self.floor, still)


def foot_track(sides: tuple[str, ...], points: np.ndarray, fps: float, floor: float = 0.0, speed_window: float | None = None) -> FootTrack:
    """A :class:`FootTrack` from foot points ``(T, F, P, 3)``, heights above ``floor``; velocities
    from :func:`mjmotion.filters.velocity` over ``speed_window`` seconds (None: raw central differences)."""
    if points.shape[0] < 2:
        raise MjmotionError("a clip needs at least 2 frames for foot speeds")
    z = points[..., 2]
    k = np.argmin(z, axis=2)  # (T, F) lowest point index
    heights = np.take_along_axis(z, k[..., None], axis=2)[..., 0] - float(floor)
    lowest = np.take_along_axis(points, k[..., None, None], axis=2)[:, :, 0]
    vel = velocity(points, fps, speed_window)  # (T, F, P, 3), per second
    v_low = np.take_along_axis(vel, k[..., None, None], axis=2)[:, :, 0]
    speeds = rot.norm(v_low[..., :2])
    return FootTrack(sides, float(fps), points, heights, lowest, speeds, float(floor), climb=v_low[..., 2], speed_window=speed_window)


def foot_heights_speeds(
    compiled: CompiledModel | None,
    motion: Motion,
    pose: Pose | None = None,
    floor: float | None = None,
    soles: Soles | None = None,
    speed_window: float | None = SPEED_WINDOW,
) -> FootTrack:
    """The :class:`FootTrack` of ``motion``.

    ``compiled`` defaults to its skeleton's model, ``pose`` to its forward kinematics, ``soles``
    to :func:`calibrate_soles` on this clip, ``floor`` to the clip's own stance floor.
    """
    if pose is None:
        compiled = compiled if compiled is not None else mjcf.compile(motion.skeleton)
        pose = kinematics.forward(compiled, motion)
    soles = soles if soles is not None else calibrate_soles(motion.skeleton, [(pose, motion.fps)])
    tr = foot_track(soles.sides, sole_points(soles, pose), motion.fps, 0.0, speed_window)
    tr = replace(tr, soles=soles)
    return tr.at_floor(tr.detected_floor() if floor is None else floor)


def level_pose(level: floors.Level, pose: Pose) -> Pose:
    """``pose`` in the levelled frame of ``level`` (every joint and site turned about its pivot)."""
    if level.flat:
        return pose
    mat = rot.to_matrix(np.asarray(level.quat))
    return replace(
        pose,
        joint_positions=level.positions(pose.joint_positions),
        joint_rotations=level.rotations(pose.joint_rotations),
        site_positions=level.positions(pose.site_positions) if pose.site_positions.size else pose.site_positions,
        site_rotations=np.einsum("ij,...jk->...ik", mat, pose.site_rotations) if pose.site_rotations.size else pose.site_rotations,
    )


def level_motion(level: floors.Level, motion: Motion) -> Motion:
    """``motion`` in the levelled frame of ``level``: its root turned about the pivot (the same
    world poses as :func:`level_pose` of its kinematics; the local joint rotations are unchanged)."""
    if level.flat:
        return motion
    q = motion.rotations.copy()
    q[:, 0] = level.rotations(q[:, 0])
    return motion.replace(root_positions=level.positions(motion.root_positions), rotations=q)


def _stance(track: FootTrack) -> tuple[np.ndarray, np.ndarray]:
    still = track.speeds if track.climb is None else np.hypot(track.speeds, track.climb)
    return floors.stance_points(track.heights + track.floor, still, track.lowest[..., :2])


def min_source_frames(fps: float) -> int:
    """Frames a source given by a user (``--source``) needs as the reference of every joint's speed: one
    period of the judge's low-pass (``CUTOFF_HZ``) between its first and last frame (21 at 120 fps,
    whether the file's frame time rounds 1/120 up or down). A 3-frame source read a golf swing's thumb
    at 377x its "peak"."""
    return max(MIN_FRAMES, math.floor(float(fps) / CUTOFF_HZ + 1e-6) + 1)


def source_too_short(source: Motion, speed_reference: bool = True) -> str | None:
    """Why ``source`` is too short to judge against (``"N frames; …"``), or None: shorter than the judge
    takes a clip (:data:`~mjmotion.thresholds.MIN_FRAMES`), or, as a ``speed_reference``, than
    :func:`min_source_frames`."""
    n, s = source.n_frames, "s" * (source.n_frames != 1)
    if n < MIN_FRAMES:
        return f"{n} frame{s}; the judge needs at least {MIN_FRAMES} frames of a source (speeds are differences between frames)"
    need = min_source_frames(source.fps)
    if not speed_reference or n >= need:
        return None
    return (
        f"{n} frame{s}; a source is the reference for every joint's speed and needs at least {need} frames at "
        f"{source.fps:g} fps (1/{CUTOFF_HZ:g} s, one period of the judge's low-pass)"
    )


def check_sources(motion: Motion, sources: Sequence[Motion]) -> None:
    """Refuse a source the judge cannot measure ``motion`` against: another skeleton, another
    frame rate, the result itself, or fewer frames than the judge takes a clip (``evaluate``,
    ``cleanup`` and ``render`` share the rule; the commands hold a ``--source`` to
    :func:`min_source_frames`, :func:`source_too_short`)."""
    if isinstance(sources, Motion) or not all(isinstance(s, Motion) for s in sources):
        raise MjmotionError("sources: expected a list of Motions (the clips this one was made from), e.g. sources=[walk, run]")
    for i, s in enumerate(sources):
        label = f"source {i + 1} ({s.name or 'unnamed'})"
        if (short := source_too_short(s, speed_reference=False)) is not None:
            raise MjmotionError(f"{label}: {short}")
        if not motion.skeleton.same_topology(s.skeleton):
            raise MjmotionError(f"{label}: another skeleton than {motion.name or 'the result'}'s; a source must share the result's skeleton")
        if not same_rate(s.fps, motion.fps):
            raise MjmotionError(f"{label}: {s.fps:g} fps, the result {motion.fps:g} fps; resample one (mjmotion convert --fps)")
        if s is motion:
            raise MjmotionError(f"{label} is the result itself; judge a result against the clip(s) it was made from")


def judged_feet(
    compiled: CompiledModel,
    motion: Motion,
    pose: Pose,
    sources: Sequence[tuple[Motion, Pose]] = (),
    floor: float | None = None,
    speed_window: float | None = SPEED_WINDOW,
) -> tuple[FootTrack, Soles, floors.Floor]:
    """The feet, their soles and the floor the judge measures ``motion`` (its ``pose``) with, as ``evaluate``,
    ``cleanup`` and ``render`` share them: soles calibrated on the ``sources`` (``(motion, pose)``
    of the clips it was made from; none: on the clip itself), and the floor of
    :func:`mjmotion.floor.resolve` — ``floor`` if given, else the sources' mean stance floor, else
    the clip's own. Returns the track measured from that floor, the soles, and the floor.

    Unless ``floor`` is given, a tilted stance floor (the sources', else the clip's:
    :func:`mjmotion.floor.fit_tilt`) is levelled first: the track and soles are then those of the
    levelled clip, and ``Floor.level`` says how to level its pose and motion
    (:func:`level_pose`, :func:`level_motion`) for anything else measured against that floor."""

    def tracks(p: Pose, src: Sequence[tuple[Motion, Pose]]) -> tuple[Soles, FootTrack, list[FootTrack]]:
        soles = calibrate_soles(motion.skeleton, [(sp, s.fps) for s, sp in src] or [(p, motion.fps)])
        own = foot_heights_speeds(compiled, motion, p, floor=0.0, soles=soles, speed_window=speed_window)
        return soles, own, [foot_heights_speeds(compiled, s, sp, floor=0.0, soles=soles, speed_window=speed_window) for s, sp in src]

    soles, own, src_tracks = tracks(pose, sources)
    level = floors.FLAT
    if floor is None:
        pts = [_stance(t) for t in (src_tracks or [own])]
        level = floors.fit_tilt(np.concatenate([xy for xy, _ in pts]), np.concatenate([z for _, z in pts]))
        if not level.flat:
            soles, own, src_tracks = tracks(level_pose(level, pose), [(level_motion(level, s), level_pose(level, sp)) for s, sp in sources])
    fl = floors.resolve(floor, [t.detected_floor() for t in src_tracks], own.detected_floor(), level)
    return own.at_floor(fl.height), soles, fl


def judged_floor(motion: Motion, sources: Sequence[Motion] = (), floor: float | None = None) -> floors.Floor:
    """The floor :func:`judged_feet` gives ``motion`` judged against ``sources`` (same skeleton), with its levelling."""
    check_sources(motion, sources)
    compiled = mjcf.compile(motion.skeleton)
    src = [(s, kinematics.forward(compiled, s)) for s in sources]
    return judged_feet(compiled, motion, kinematics.forward(compiled, motion), src, floor)[2]


def _track(x: Motion | FootTrack) -> FootTrack:
    return x if isinstance(x, FootTrack) else foot_heights_speeds(None, x)


# --------------------------------------------------------------------------- contacts


def low_both(track: FootTrack, h_c: float = H_C) -> np.ndarray:
    """``(T, F)``: foot height below ``h_c`` at t and at t-1 (frame 0 uses itself as t-1)."""
    low = track.heights < h_c
    prev = np.concatenate([low[:1], low[:-1]], axis=0)
    return low & prev


def contacts(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C, hysteresis: float = HYSTERESIS) -> np.ndarray:
    """``(T, F)`` contact labels with hysteresis.

    A foot *enters* contact at a frame where its height is below ``(1 - hysteresis)·h_c`` there
    and at the frame before and its speed below ``(1 - hysteresis)·v_c``; it stays in contact
    until a frame where its height reaches ``h_c`` or its speed ``v_c``. Every contact frame is
    therefore below ``h_c`` and slower than ``v_c``; ``hysteresis=0`` is the plain threshold.
    """
    tr = _track(track)
    k = 1.0 - hysteresis
    enter = low_both(tr, k * h_c) & (tr.speeds < k * v_c)
    leave = (tr.heights >= h_c) | (tr.speeds >= v_c)
    event = np.where(enter, 1, np.where(leave, -1, 0))  # (T, F)
    t = np.arange(event.shape[0])[:, None]
    last = np.maximum.accumulate(np.where(event != 0, t, -1), axis=0)  # last frame with an event
    state = np.take_along_axis(event, np.maximum(last, 0), axis=0)
    return np.asarray((last >= 0) & (state == 1))


def planted_speeds(track: FootTrack, contact: np.ndarray) -> np.ndarray:
    """``(T, F)`` horizontal speed (m/s) of each foot's lowest sole point over its contact frames,
    measured from the plant's own frames (NaN where ``contact: (T, F)`` is False).

    The velocity of that material point is the slope of the least-squares line through its
    positions over the ``track.speed_window`` seconds around the frame (:func:`mjmotion.filters.velocity`'s
    window) *clipped to the contact run the frame belongs to*, so a swing's speed never leaks
    into the plant beside it: a foot that lands and stands still reads 0 from its first contact
    frame (a window reaching into the swing reads a landing at 1 m/s as ~200 mm/s). Inside a
    run, away from its ends, this is :attr:`FootTrack.speeds` (a centred quadratic's slope is the
    line's). A run of one frame keeps :attr:`FootTrack.speeds`.
    """
    con = np.asarray(contact, dtype=bool)
    t_count, n_feet = con.shape
    if con.shape != track.heights.shape:
        raise MjmotionError(f"planted_speeds: contact labels {con.shape} and the track's {track.heights.shape} must match")
    half = _speed_frames(track) // 2
    # Run ids: frames of one contact run share an id, every other frame gets -1.
    starts = con & ~np.concatenate([np.zeros((1, n_feet), dtype=bool), con[:-1]], axis=0)
    run = np.where(con, np.cumsum(starts, axis=0), -1)  # (T, F)
    # Only the lowest point's velocity is read: the regression runs on that material point alone,
    # its positions at the frames around t taken at t's lowest-point index (P times less work).
    steps = track.lowest_steps  # (D, T, F, 2)
    n = np.zeros((t_count, n_feet))
    s1, s2 = np.zeros_like(n), np.zeros_like(n)
    sy, sdy = np.zeros((t_count, n_feet, 2)), np.zeros((t_count, n_feet, 2))  # Σy, Σd·y (relative to frame t)
    for d in range(-half, half + 1):
        lo, hi = max(0, -d), min(t_count, t_count - d)
        if lo >= hi:
            continue
        w = np.zeros((t_count, n_feet))
        w[lo:hi] = con[lo:hi] & (run[lo + d : hi + d] == run[lo:hi])
        dy = steps[d + half]
        n += w
        s1 += w * d
        s2 += w * d * d
        sy += w[..., None] * dy
        sdy += w[..., None] * d * dy
    den = n * s2 - s1 * s1
    with np.errstate(invalid="ignore", divide="ignore"):
        v_low = (n[..., None] * sdy - s1[..., None] * sy) / den[..., None] * track.fps  # (T, F, 2)
    speed = rot.norm(v_low)
    short = con & (den <= 0)
    speed[short] = track.speeds[short]
    return np.where(con, speed, np.nan)


def _speed_frames(track: FootTrack) -> int:
    """The odd number of frames of ``track``'s speed window (:func:`mjmotion.filters.velocity`'s; 3 without one)."""
    return max(5, int(round(track.speed_window * track.fps)) | 1) if track.speed_window is not None else 3


def flight_frames(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C, hysteresis: float = HYSTERESIS) -> np.ndarray:
    """``(T,)`` frames where no foot is in contact."""
    return np.asarray(~contacts(track, h_c, v_c, hysteresis).any(axis=1))
