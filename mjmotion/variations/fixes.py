"""Repairs of a synthesised variant (seed 003 §3.3): feet that slide or float are held to the
source's foot placement with two-bone leg IK, and a second hand that leaves the bat/club is
returned to its source placement relative to the first hand with two-bone arm IK."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import kinematics, limits, mjcf
from .. import rotations as rot
from ..errors import MjmotionError
from ..filters import hann_smooth, lowpass, smooth_cover
from ..ik import analytic
from ..skeleton import Motion, Skeleton
from .paths import ScorePath, _smoothstep

#: Foot height (m) under which the source's foot placement is held (METRICS.md h_c = 0.05 plus margin).
PLANT_HEIGHT = 0.08
#: A held foot's hip-to-ankle distance follows the variant's hip only below this (Hz), as in
#: :data:`mjmotion.cleanup.LEG_CUTOFF_HZ`.
LEG_CUTOFF_HZ = 10.0
#: Below this bend (degrees) a limb's captured bending plane is mostly noise; the IK's plane turns
#: smoothly towards the limb's usual one (as :data:`mjmotion.cleanup.STRAIGHT_KNEE_DEG` does).
STRAIGHT_LIMB_DEG = 15.0
#: Seconds over which a foot or hand correction fades in and out at the ends of a plant.
FADE_S = 0.1
#: A foot whose footprint moves more than this (m) during an abort's return steps instead of sliding …
STEP_M = 0.05
#: … lifting its contact point this high (m) at mid-step …
STEP_LIFT = 0.12
#: … over the whole return, and carrying it between these fractions of the return: lifted before it moves,
#: put down after. Carried over the middle 0.3–0.7 (lifted over 0.1–0.9), a step pushed the aborted golf
#: swings' knees to 2.6–6.5x their captured peak (64_05: 18 pop frames); now 1.7–5.2x (4).
STEP_CARRY = (0.1, 0.9)


def _source_at(source_values: np.ndarray, path: ScorePath) -> np.ndarray:
    """Per path frame, the source's ``values`` at the frames it stands for (linear blend)."""
    w = path.weight.reshape(-1, *([1] * (source_values.ndim - 1)))
    return (1.0 - w) * source_values[path.frame_a] + w * source_values[path.frame_b]


def _source_positions_at(source_positions: np.ndarray, path: ScorePath) -> np.ndarray:
    """Like :func:`_source_at` for world positions ``(T, ..., 3)``: frame_b's are moved by ``path.shift_b``."""
    w = path.weight.reshape(-1, *([1] * (source_positions.ndim - 1)))
    return (1.0 - w) * source_positions[path.frame_a] + w * (source_positions[path.frame_b] + path.shift_b)


def _quat_source_at(source_q: np.ndarray, path: ScorePath) -> np.ndarray:
    w = np.broadcast_to(
        path.weight.reshape(-1, *([1] * (source_q.ndim - 2))),
        source_q[path.frame_a].shape[:-1],
    )
    return rot.slerp(source_q[path.frame_a], source_q[path.frame_b], w)


def _close_gaps(mask: np.ndarray, n: int) -> np.ndarray:
    """``mask (T,)`` with its gaps of at most ``n`` frames between two True runs filled."""
    out = mask.copy()
    idx = np.flatnonzero(mask)
    gap = np.diff(idx) - 1  # False frames between consecutive True ones
    short = (gap > 0) & (gap <= n)
    for a, g in zip(idx[:-1][short], gap[short]):
        out[a + 1 : a + 1 + g] = True
    return out


def _fade(mask: np.ndarray, n_fade: int) -> np.ndarray:
    """``(T,)`` 1 where ``mask`` holds, easing to 0 over ``n_fade`` frames either side."""
    if not mask.any():
        return np.zeros(mask.shape)
    idx = np.flatnonzero(mask)
    t = np.arange(mask.size)
    # distance in frames to the nearest masked frame
    pos = np.searchsorted(idx, t)
    left = np.abs(t - idx[np.clip(pos - 1, 0, idx.size - 1)])
    right = np.abs(idx[np.clip(pos, 0, idx.size - 1)] - t)
    d = np.minimum(left, right)
    u = np.clip(1.0 - d / (n_fade + 1), 0.0, 1.0)
    return np.sin(0.5 * np.pi * u) ** 2


def two_bone_ik(
    skeleton: Skeleton,
    world_pos: np.ndarray,
    world_rot: np.ndarray,
    local_rot: np.ndarray,
    end: int,
    target_pos: np.ndarray,
    target_rot: np.ndarray,
    keep: np.ndarray | None = None,
    keep_fade: int = 1,
    reach: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Analytic IK placing joint ``end`` (ankle, wrist) at ``target_pos`` with world orientation ``target_rot``.

    The middle joint (knee, elbow) bends in its current plane to get the right reach, then the
    upper joint (hip, shoulder) swings the limb onto the target; the end joint's local rotation
    gives it the target orientation. Reach is clamped to the limb's length; with ``reach``, a limb
    stretches no further than ``reach`` × its length (or as captured, if straighter), approaching it
    softly (:func:`mjmotion.cleanup.soft_reach`): held out of reach, a knee snapped straight.

    Where the limb is nearly straight its plane turns smoothly towards its usual one, and a limb
    bent the other way is bent the usual way; ``keep: (T,)`` frames (the source's own poses) use
    their own plane, eased into over ``keep_fade`` frames, so a target at the limb's own end leaves them as they are.

    Args:
        world_pos: ``(T, J, 3)`` and ``world_rot: (T, J, 4)``, forward kinematics of the pose.
        local_rot: ``(T, J, 4)`` the pose's local rotations (a modified copy is returned).
        target_pos: ``(T, 3)``; target_rot: ``(T, 4)`` world.
    Returns:
        ``(local_rot, reach_error)``: updated rotations and ``(T,)`` metres the target stays out of reach
        (or short of it).
    """
    mid = int(skeleton.parents[end])
    top = int(skeleton.parents[mid])
    above = int(skeleton.parents[top])
    h, k, a = world_pos[:, top], world_pos[:, mid], world_pos[:, end]
    l1 = np.linalg.norm(k - h, axis=-1)
    l2 = np.linalg.norm(a - k, axis=-1)
    u, v = k - h, a - k
    n = np.cross(u, v)
    nn = np.linalg.norm(n, axis=-1)
    # the bend axis in the upper bone's frame, borrowed from bent frames where the limb is straight
    q_top = world_rot[:, top]
    n_local = rot.rotate(rot.conjugate(q_top), n / np.maximum(nn, 1e-12)[:, None])
    good = nn > analytic.STRAIGHT_SINE * l1 * l2
    if good.any():
        ref = n_local[good].mean(axis=0)
    else:
        ref = np.array([1.0, 0.0, 0.0])
    ref = ref / max(np.linalg.norm(ref), 1e-12)
    ref_world = rot.rotate(q_top, np.broadcast_to(ref, n.shape))
    n_unit = n / np.maximum(nn, 1e-12)[:, None]
    # A frame whose limb bends the other way (a captured glitch through a straight knee) bends it
    # the usual way: turned round, the knee flipped for one frame (108 rad/s in 64_02 ×1.3, frame 420).
    n_unit = np.where(np.sum(n_unit * ref_world, axis=-1, keepdims=True) < 0, -n_unit, n_unit)
    # Below STRAIGHT_LIMB_DEG of bend the plane is mostly noise: turn smoothly towards the usual one
    # (a plane swivelling from frame to frame through a straight knee spun the hip: 64_05 ×1.3, 21 rad/s).
    bend = np.degrees(np.arcsin(np.clip(nn / np.maximum(l1 * l2, 1e-12), 0.0, 1.0)))
    w_plane = _smoothstep(bend / STRAIGHT_LIMB_DEG)[:, None] * good[:, None]
    n_unit = w_plane * n_unit + (1.0 - w_plane) * ref_world
    if keep is not None and keep.any():
        own = np.where(good[:, None], n / np.maximum(nn, 1e-12)[:, None], ref_world)
        w_own = _fade(keep, keep_fade)[:, None]
        n_unit = w_own * own + (1.0 - w_own) * n_unit
    n_unit /= np.maximum(np.linalg.norm(n_unit, axis=-1, keepdims=True), 1e-12)
    short = np.zeros(len(target_pos))
    if reach is not None:
        from ..cleanup import soft_reach  # (here: the synthesis alone does not load the cleanup)

        target_pos, short = soft_reach(h, k, a, target_pos, reach)
    r_hip, r_knee, reach_error = analytic.two_bone(h, k, a, target_pos, n_unit)
    reach_error = reach_error + short
    q_top_new = rot.multiply(r_hip, q_top)
    q_mid_new = rot.multiply(r_hip, rot.multiply(r_knee, world_rot[:, mid]))
    out = local_rot.copy()
    q_above = world_rot[:, above] if above >= 0 else np.broadcast_to(rot.IDENTITY, q_top.shape)
    out[:, top] = rot.multiply(rot.conjugate(q_above), q_top_new)
    out[:, mid] = rot.multiply(rot.conjugate(q_top_new), q_mid_new)
    out[:, end] = rot.multiply(rot.conjugate(q_mid_new), target_rot)
    return out, reach_error


def _blend_local(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    return rot.slerp(a, b, np.broadcast_to(w[:, None], a.shape[:2]))


def _is_below(skeleton: Skeleton, c: int, j: int) -> bool:
    while c > j:
        c = int(skeleton.parents[c])
    return c == j


@dataclass(frozen=True)
class CleanupReport:
    """What :func:`clean_up` did: the frames it held per foot and the leftover errors (metres)."""

    held_frames: dict[str, int]
    foot_reach_error_m: float
    grip_hands: tuple[str, str] | None
    grip_reach_error_m: float


def hold_source_feet(source: Motion, motion: Motion, path: ScorePath, plant_height: float = PLANT_HEIGHT) -> tuple[Motion, dict[str, int], float]:
    """Feet that slide or float (§3.3) put back on the source's footprints with two-bone leg IK.

    Where the source's foot (its lowest point, METRICS.md) is within ``plant_height`` of the floor at the
    frames a path frame stands for (gaps of up to two fades between such frames included: a foot hovering
    at that height made a plant of every few frames, each with its own shift), the ankle follows the source's ankle (position and world
    orientation, toes as in the source) shifted by the variant's mean horizontal offset over
    that plant; corrections fade in and out over ``FADE_S``. Returns the motion, frames held per
    foot and the largest distance a target stayed out of reach.
    """
    skel = source.skeleton
    feet = skel.feet()
    if not feet:
        return motion, {}, 0.0
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    from ..evaluate import foot_heights_speeds

    track = foot_heights_speeds(compiled, source, src)
    lowest = track.lowest  # (T, F, 3) each foot's lowest point (METRICS.md foot points)
    held: dict[str, int] = {}
    n_fade = max(1, round(FADE_S * motion.fps))
    # (the feet keep their plant's shift at an abort's end, so only the frames before it count)
    copies = copied_frames(source, motion, path)
    copied = copies & (path.weight <= 0)
    plans = []
    for side, (ankle, toe) in feet.items():
        low_src = _close_gaps(track.heights[:, track.sides.index(side)] < plant_height, 2 * n_fade)
        # between two source frames a foot down at either end stays held (released, it would
        # swing to wherever the blended pose puts it)
        low_a, low_b = low_src[path.frame_a], low_src[path.frame_b]
        low = np.where(path.weight <= 0, low_a, np.where(path.weight >= 1, low_b, low_a | low_b))
        if not low.any() or skel.parents[skel.parents[ankle]] < 0:
            continue
        target = _source_positions_at(src.joint_positions[:, ankle], path)
        target_rot = _quat_source_at(src.joint_rotations[:, ankle], path)
        between = (path.weight > 0) & (path.weight < 1)
        if between.any():
            # between two source frames (an abort's return) the foot pivots about the point it
            # stands on at the end, instead of sliding the ankle from one footprint to the other
            fb, fa, w = (
                path.frame_b[between],
                path.frame_a[between],
                path.weight[between, None],
            )
            low_pt = lowest[:, track.sides.index(side)]
            c = rot.rotate(
                rot.conjugate(src.joint_rotations[fb, ankle]),
                low_pt[fb] - src.joint_positions[fb, ankle],
            )
            p_a = src.joint_positions[fa, ankle] + rot.rotate(src.joint_rotations[fa, ankle], c)
            p_b = low_pt[fb] + path.shift_b
            pivot = (1.0 - w) * p_a + w * p_b
            # a foot whose footprint moves must step: lift, carry, put down (not slide); only between two
            # source frames apart (an abort's return), not between neighbours (a path of another length)
            stepping = (np.linalg.norm((p_b - p_a)[:, :2], axis=-1) > STEP_M) & (fb - fa > 1)
            if stepping.any():
                # lift first, then carry and turn the foot in the air, then put it down: over the whole
                # return (STEP_CARRY), a step's knee as slow as the return allows
                u = w[:, 0]
                carry = _smoothstep((u - STEP_CARRY[0]) / (STEP_CARRY[1] - STEP_CARRY[0]))
                lift = STEP_LIFT * np.sin(np.pi * np.clip(u, 0.0, 1.0))
                step = p_a + carry[:, None] * (p_b - p_a)
                step[:, 2] += lift
                pivot = np.where(stepping[:, None], step, pivot)
                q_a, q_b = (
                    src.joint_rotations[fa, ankle],
                    src.joint_rotations[fb, ankle],
                )
                turned = rot.slerp(q_a, q_b, carry)
                target_rot[between] = np.where(stepping[:, None], turned, target_rot[between])
            target[between] = pivot - rot.rotate(target_rot[between], c)
        # one horizontal shift per plant, where the variant's foot touched down; frames between
        # two plants (fading out of one and into the next) turn smoothly from one shift to the next
        # (taking the nearest plant's, the target jumped 15 cm in a frame: 64_05 ×1.3, the hip at 21 rad/s)
        runs = _runs(low)
        starts = np.array([a for a, _ in runs])
        shifts = var.joint_positions[starts, ankle, :2] - target[starts, :2]
        per_frame = np.empty((len(low), 2))
        per_frame[: runs[0][0]] = shifts[0]
        for i, (a, b) in enumerate(runs):
            per_frame[a:b] = shifts[i]
            if i + 1 < len(runs):
                nxt = runs[i + 1][0]
                u = _smoothstep((np.arange(b, nxt) - b + 1) / (nxt - b + 1))[:, None]
                per_frame[b:nxt] = (1.0 - u) * shifts[i] + u * shifts[i + 1]
            else:
                per_frame[b:] = shifts[i]
        # ... and none at the source's own poses, where the target is the variant's own ankle (the
        # shift stepped there in a frame: 64_05 ×0.7's knee at 9 rad/s in its last frame)
        target[:, :2] += per_frame * (1.0 - _fade(copies, n_fade))[:, None]
        # frames that are the source's own poses (before an abort, outside a scaled segment) stay so
        target[copied] = var.joint_positions[copied, ankle]
        target_rot[copied] = var.joint_rotations[copied, ankle]
        plans.append((side, ankle, toe, low, target, target_rot, _fade(low, n_fade)))
    if not plans:
        return motion, {}, 0.0
    # an exaggerated pose can lift the hips beyond the legs' reach: lower/move the root first
    shift = _root_shift_for_reach(skel, var, [(a, tg, w) for _, a, _, _, tg, _, w in plans], motion.fps)
    shift *= 1.0 - _fade(copies, max(1, round(0.5 * ROOT_WINDOW_S * motion.fps)))[:, None]
    if np.any(shift):
        motion = motion.replace(root_positions=motion.root_positions + shift)
        var = kinematics.forward(compiled, motion)
    local = motion.rotations.copy()
    worst = 0.0
    for side, ankle, toe, low, target, target_rot, w in plans:
        if motion.n_frames >= 4:
            # The leg's length follows the variant's hip only below LEG_CUTOFF_HZ (as the footskate
            # cleanup's does): a synthesised pelvis jitters, and a near-straight knee held to a
            # still footprint turns every millimetre of it into a pop.
            hip = var.joint_positions[:, int(skel.parents[skel.parents[ankle]])]
            vec = target - hip
            dist = np.linalg.norm(vec, axis=-1)
            smooth = lowpass(dist, motion.fps, LEG_CUTOFF_HZ)
            ease = w * (1.0 - _fade(copies, n_fade))  # the source's own poses stay exactly so
            target = hip + vec * (1.0 + ease * (smooth - dist) / np.maximum(dist, 1e-9))[:, None]
        solved, err = two_bone_ik(
            skel,
            var.joint_positions,
            var.joint_rotations,
            local,
            ankle,
            target,
            target_rot,
            keep=copies,
            keep_fade=n_fade,
            reach=REACH,
        )
        if toe is not None:
            for j in [toe, *skel.descendants(toe)]:
                solved[:, j] = _quat_source_at(source.rotations[:, j], path)
        chain = [
            int(skel.parents[skel.parents[ankle]]),
            int(skel.parents[ankle]),
            ankle,
        ]
        chain += [j for j in ([toe, *skel.descendants(toe)] if toe is not None else [])]
        local[:, chain] = _blend_local(local[:, chain], solved[:, chain], w)
        held[side] = int(low.sum())
        worst = max(worst, float(np.max(err[low])))
    return motion.replace(rotations=local), held, worst


def copied_frames(source: Motion, motion: Motion, path: ScorePath, tol: float = 1e-9, joints: np.ndarray | None = None) -> np.ndarray:
    """``(T',) bool``: frames of ``motion`` that are exactly a source frame (moved by ``path.shift_b``
    at frame_b); with ``joints``, frames whose local rotations of those joints are the source's
    (wherever the root stands)."""
    out = np.zeros(path.n_frames, dtype=bool)
    if joints is not None:
        for sel, frames in ((path.weight <= 0, path.frame_a), (path.weight >= 1, path.frame_b)):
            dots = np.sum(motion.rotations[sel][:, joints] * source.rotations[frames[sel]][:, joints], axis=-1)
            out[sel] = np.all(np.abs(np.abs(dots) - 1.0) < tol, axis=1)
        return out
    for sel, frames, move in (
        (path.weight <= 0, path.frame_a, 0.0),
        (path.weight >= 1, path.frame_b, path.shift_b),
    ):
        f = frames[sel]
        same_q = np.all(
            np.abs(np.abs(np.sum(motion.rotations[sel] * source.rotations[f], axis=-1)) - 1.0) < tol,
            axis=1,
        )
        same_r = np.all(
            np.abs(motion.root_positions[sel] - (source.root_positions[f] + move)) < 1e-7,
            axis=1,
        )
        out[sel] = same_q & same_r
    return out


#: Fraction of a leg's full length the root shift aims for (a straight knee is a singular pose).
REACH = 0.995
#: Seconds of the Hann window that spreads a root shift over neighbouring frames.
ROOT_WINDOW_S = 0.3


def _root_shift_for_reach(
    skel: Skeleton,
    pose: kinematics.Pose,
    legs: list[tuple[int, np.ndarray, np.ndarray]],
    fps: float,
) -> np.ndarray:
    """``(T, 3)`` root translation bringing every held ankle target within ``REACH`` of its leg.

    Per frame, the largest shortfall (weighted by the hold's fade) along the hip→target line; then
    spread over ``ROOT_WINDOW_S`` and capped as the footskate cleanup's root is
    (:func:`mjmotion.cleanup.spread_root_shift`: at most a tenth of the leg; the kick 10_01 ×2 crouched 0.59 m).
    """
    from ..cleanup import spread_root_shift  # (here: the synthesis alone does not load the cleanup)

    t = pose.joint_positions.shape[0]
    need = np.zeros((t, 3))
    legs_m = []
    for ankle, target, w in legs:
        knee = int(skel.parents[ankle])
        hip = int(skel.parents[knee])
        p = pose.joint_positions
        length = np.linalg.norm(p[:, knee] - p[:, hip], axis=-1) + np.linalg.norm(p[:, ankle] - p[:, knee], axis=-1)
        legs_m.append(float(length[0]))
        vec = target - p[:, hip]
        dist = np.linalg.norm(vec, axis=-1)
        # only targets truly out of reach move the root (a captured straight leg stays as it is)
        short = np.where(dist > length * (1.0 - 1e-9), dist - REACH * length, 0.0)
        n = vec / np.maximum(dist, 1e-12)[:, None] * (w * short)[:, None]
        bigger = np.linalg.norm(n, axis=-1) > np.linalg.norm(need, axis=-1)
        need[bigger] = n[bigger]
    # (a clip shorter than the window spreads over its own length: the shift must still cover the shortfall)
    return spread_root_shift(need, min(round(0.5 * ROOT_WINDOW_S * fps), (t - 1) // 2), float(np.mean(legs_m)))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def grip_joints(skeleton: Skeleton) -> dict[str, int]:
    """``{"left": j, "right": j}``: the joints whose relative placement is the grip.

    The hand joint proper as the hit-point module picks it (``hitpoint.hand_joints``: CMU's
    ``lhand`` below the ``lwrist`` roll bone), so grip errors here and there measure the same thing.
    """
    from ..hitpoint import hand_joints

    return hand_joints(skeleton)


def restore_grip_minimal(source: Motion, motion: Motion, path: ScorePath, first_hand: str = "left") -> tuple[Motion, float]:
    """The second hand back at its source placement relative to the first hand (§3.3), two-bone arm IK.

    For each path frame, the second hand's world pose is the first hand's (in the variant)
    times the source's relative transform at the frames it stands for (hands from
    :func:`grip_joints`). The arm's end joint (the wrist, or the hand itself when it has no wrist
    bone) is solved so that the hand lands there exactly, the collarbone helping when the target
    is beyond the arm's reach; the hand's subtree keeps the source's local rotations. Returns the
    motion and the largest out-of-reach distance (m).
    """
    skel = source.skeleton
    hands = grip_joints(skel)
    if set(hands) != {"left", "right"}:
        raise MjmotionError("restoring the grip needs a left and a right hand in the skeleton")
    if first_hand not in hands:
        raise MjmotionError(f"first hand must be 'left' or 'right', got {first_hand!r}")
    h1, h2 = hands[first_hand], hands["right" if first_hand == "left" else "left"]
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    q1s, q2s = src.joint_rotations[:, h1], src.joint_rotations[:, h2]
    rel_pos = rot.rotate(rot.conjugate(q1s), src.joint_positions[:, h2] - src.joint_positions[:, h1])
    rel_rot = rot.multiply(rot.conjugate(q1s), q2s)
    q1 = var.joint_rotations[:, h1]
    hand_pos = var.joint_positions[:, h1] + rot.rotate(q1, _source_at(rel_pos, path))
    hand_rot = rot.multiply(q1, _quat_source_at(rel_rot, path))
    # the arm's end: the wrist above a hand joint (kept at the source's local rotation), else the hand
    wrist = skel.hands().get("right" if first_hand == "left" else "left", h2)
    end = wrist if wrist != h2 and _is_below(skel, h2, wrist) else h2
    keep = [end, *skel.descendants(end)]
    src_local = {j: _quat_source_at(source.rotations[:, j], path) for j in keep}
    target_rot, target = hand_rot, hand_pos
    if end != h2:
        # from the hand's target pose back to the end joint's, through the source's joints between
        chain = [h2]
        while chain[-1] != end:
            chain.append(int(skel.parents[chain[-1]]))
        for child in chain[:-1]:
            local_c = src_local[child]
            off = skel.offsets[child]
            target_rot = rot.multiply(target_rot, rot.conjugate(local_c))
            target = target - rot.rotate(target_rot, off)
    local = motion.rotations
    # The arms' and spine's own source poses stay exactly so (the feet may have been repaired already).
    legs = {j for ankle, _ in skel.feet().values() for j in (int(skel.parents[ankle]), int(skel.parents[skel.parents[ankle]]))}
    legs |= {d for j in list(legs) for d in skel.descendants(j)}
    own = copied_frames(source, motion, path, joints=np.array([j for j in range(skel.n_joints) if j not in legs and j > 0], dtype=int))
    n_fade = max(1, round(FADE_S * motion.fps))
    for _ in range(4):  # the shoulder moves on a sphere about the collarbone: a few passes close the gap
        turned = _reach_with_shoulder(skel, motion.replace(rotations=local), var, end, target, own)
        if turned is local:
            break
        local = turned
        var = kinematics.forward(compiled, motion.replace(rotations=local))
    local, err = two_bone_ik(skel, var.joint_positions, var.joint_rotations, local, end, target, target_rot, keep=own, keep_fade=n_fade)
    for j in keep[1:]:
        local[:, j] = src_local[j]
    return motion.replace(rotations=local), float(np.max(err))


#: Seconds over which the collarbone's turn (:func:`_reach_with_shoulder`) is spread either side of
#: the frames that need it: a turn switched on for the frames out of reach alone was a step of a few
#: degrees in one frame, the clavicle at up to 13x its captured speed.
SHOULDER_SPREAD_S = 0.1


def _reach_with_shoulder(
    skel: Skeleton, motion: Motion, pose: kinematics.Pose, end: int, target: np.ndarray, keep: np.ndarray | None = None
) -> np.ndarray:
    """Local rotations with the collarbone turned so a too-distant ``target`` comes within the arm's reach.

    Where the wrist target lies beyond 99 % of upper arm + forearm (the elbow keeps a little
    bend), the joint above the shoulder (the clavicle) swings the shoulder toward the target by
    the missing length. The turn grows from zero as the target passes 99 % (no step) and is spread
    smoothly over :data:`SHOULDER_SPREAD_S` either side, never less than each frame needs (a max
    filter, then a Hann window), easing to none at the ``keep: (T,)`` frames (the source's own
    poses). Returns ``motion.rotations`` itself when nothing is out of reach.
    """
    mid = int(skel.parents[end])
    top = int(skel.parents[mid])
    clav = int(skel.parents[top])
    above = int(skel.parents[clav]) if clav >= 0 else -1
    if clav <= 0:
        return motion.rotations
    p = pose.joint_positions
    reach = np.linalg.norm(p[:, mid] - p[:, top], axis=-1) + np.linalg.norm(p[:, end] - p[:, mid], axis=-1)
    to_target = target - p[:, top]
    dist = np.linalg.norm(to_target, axis=-1)
    missing = np.maximum(dist - 0.99 * reach, 0.0)
    if not (missing > 1e-9).any():
        return motion.rotations
    wanted = p[:, top] + to_target * (missing / np.maximum(dist, 1e-12))[:, None]
    turn = rot.log(analytic.shortest_arc(p[:, top] - p[:, clav], wanted - p[:, clav]))  # (T, 3) rotation vectors
    n = max(1, round(SHOULDER_SPREAD_S * motion.fps))
    angle = np.linalg.norm(turn, axis=-1)
    smooth_angle = smooth_cover(angle, n)
    if keep is not None and keep.any():
        # the spread eases to none at the source's own poses (left exactly so, though a golfer's arm
        # may reach past 99 % there), never below what another frame needs
        smooth_angle = np.where(keep, 0.0, np.maximum(smooth_angle * (1.0 - _fade(keep, n)), angle))
    # The turn's direction over twice the span, so every frame the angle reaches has one.
    axis = hann_smooth(turn, 2 * n)
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-12)
    r = rot.exp(axis * smooth_angle[:, None])
    q_clav = rot.multiply(r, pose.joint_rotations[:, clav])
    q_above = pose.joint_rotations[:, above] if above >= 0 else np.broadcast_to(rot.IDENTITY, q_clav.shape)
    out = motion.rotations.copy()
    out[:, clav] = rot.multiply(rot.conjugate(q_above), q_clav)
    return out


#: Ways to repair the feet: the source's footprints (default), the footskate cleanup's plants, both, none.
FEET_METHODS = ("source", "plants", "both", "none")


def clean_up(
    source: Motion,
    motion: Motion,
    path: ScorePath,
    first_hand: str | None = "left",
    feet: str = "source",
) -> tuple[Motion, CleanupReport]:
    """Repair §3.3's artefacts: the feet, then the second hand on the grip.

    ``feet``: ``"source"`` holds each foot on the source's footprint (:func:`hold_source_feet`:
    where and when the source's foot is down, at its height and orientation, so floating and
    sliding both go); ``"plants"`` runs the general footskate cleanup on the variant alone
    (:func:`mjmotion.cleanup.cleanup`, Kovar et al. 2002: plants found in the variant, ankles pinned,
    foot orientation held); ``"both"`` the first then the second; ``"none"``.
    ``first_hand=None`` leaves the hands alone (a one-handed shot, a kick).
    """
    if feet not in FEET_METHODS:
        raise MjmotionError(f"feet cleanup must be one of {', '.join(FEET_METHODS)}, got {feet!r}")
    out, foot_err = motion, 0.0
    held: dict[str, int] = {}
    if feet in ("source", "both"):
        out, held, foot_err = hold_source_feet(source, out, path)
    if feet in ("plants", "both"):
        from ..cleanup import cleanup

        res = cleanup(out)
        out = res.motion
        for plant in res.plants:
            held[f"{plant.side} (plants)"] = held.get(f"{plant.side} (plants)", 0) + plant.stop - plant.start
    grip_err = 0.0
    pair = None
    if first_hand is not None:
        out, grip_err = restore_grip_minimal(source, out, path, first_hand)
        pair = (first_hand, "right" if first_hand == "left" else "left")
    # the repairs' IK (feet, grip) may turn a joint past its range: brought back inside, as the synthesis is
    out = out.replace(rotations=limits.within(out.skeleton, out.rotations))
    return out, CleanupReport(held, foot_err, pair, grip_err)
