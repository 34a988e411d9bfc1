"""Hit-point adaptation (seed 003 §2): move a swing so its effector meets a ball somewhere else.

The pipeline, one pure function :func:`adapt` over a source :class:`Motion`:

1. **Effector** (§2.1.1): a point fixed to a joint — a club's sweet spot (the club fitted to both
   hands by :func:`fit_club`), a point on a foot, a fist, or any named site of the compiled model.
2. **Hit frame**, the moment of contact: given, or the downswing frame where the effector reaches
   the source's ball (given), or, for a ball on the ground or a tee, the effector's lowest pass in
   the downswing (:func:`detect_hit_frame`); the source hit point is the effector there.
3. **Offset in effector space** (§2.2.4) and **importance blend** (§2.2.5): the goal at frame ``t``
   is the FK effector plus ``blend(t)`` times the offset carried by the effector's frame, with
   ``blend = clamp(1 − d/falloff, 0, 1)``, ``d`` the FK distance from the effector to the FK hit
   point. Golf addresses the ball (``d ≈ 0`` at the first frames), so the blend is also tapered
   to 0 over ``edge`` seconds at both ends: the first and last frames stay the source exactly.
4. **IK** per frame from that frame's FK pose (§2.2.3) on a chain from the lower spine (never the
   root, §2.2.2) to the effector, with freedoms and limits from :mod:`mjmotion.ik.chains` and
   stiffness learned from the source's PCA style space (:func:`style_weights`, §1.10):
   ``nlp`` (CasADi/IPOPT, the main solver), ``nlp-shot`` (one problem over the whole shot with both
   hands), ``dls`` or ``ccd`` (the seed's baselines).
5. **Second hand** (§2.2.2): a club held in both hands: the other hand goes back, frame by frame,
   to its source position and orientation relative to the first hand (6-D IK on its arm).
6. **Report**: goal and grip errors, style error (``style.style_rmse``, METRICS.md "Style"), timing.
   ``hit_error_m`` here is the distance from the effector to the target point (the club's sweet
   spot is where the ball's centre should be), not METRICS.md's ball-surface distance.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from . import kinematics, limits, mjcf
from . import rotations as rot
from .errors import MjmotionError, is_real, is_whole
from .ik.chains import DEFAULT_MARGIN, Chain, Effector, _coords, build_chain, factor_rates, joint_role, rotation_angle
from .ik.reach import envelope, nearest_reachable, paced_walk
from .ik.twohand import FrameSolution, TwoHandIK
from .skeleton import Motion, Skeleton
from .style import PoseSpace

SOLVERS = ("nlp", "nlp-shot", "dls", "ccd")
EFFECTORS = ("club", "left_foot", "right_foot", "left_fist", "right_fist")
#: Default falloff distance (metres) of the importance blend (§2.2.5; the seed's 70–110 cm for a bat).
DEFAULT_FALLOFF = 0.6
#: Seconds over which the blend is tapered to zero at the first and last frames.
DEFAULT_EDGE = 0.5
#: A goal counts as reached within this distance (metres).
REACH_TOLERANCE = 1e-3
#: How far (metres) below the floor (or below the source) the effector's lowest point may dip.
CLEARANCE_SLACK = 1e-3
#: A target stopped short stops this fraction of the way further back than the edge of the reach.
SHORT_ROOM = 0.1
#: Fastest change per second of the fraction of a frame's goal offset kept where a best effort
#: shortens goals (10: from none to all of it over 0.1 s).
FRACTION_RATE = 10.0
#: No lead-chain joint turns faster than this many times its own peak speed in the source: where
#: the importance blend would make one, its deviation ramps in and out at that pace instead
#: (:func:`mjmotion.ik.reach.rate_limit`; the hit frame stays exact).
JOINT_SPEED_BOUND = 2.0
#: Radians the default cone limits (the judge's joint ranges) are kept inside by: BVH's six-decimal
#: Euler angles move a rotation by up to ~3e-8 rad, which would read a joint on its range as beyond it.
CONE_CLEARANCE = 1e-6
#: A paced frame keeps the second hand on the branch of the frame before within this grip error (m).
PACED_GRIP = 2e-3
#: Butt of the club above the lead hand's palm along the shaft (metres).
BUTT_EXTENSION = 0.03
#: Frames faster than this fraction of the downswing's peak effector speed are the swing through the ball.
FAST = 0.5
#: A hand whose local rotation changes more than this in one frame (radians) is a data glitch.
MAX_HAND_JUMP = np.deg2rad(90.0)


# --- the club ---------------------------------------------------------------------------------
def hand_joints(skeleton: Skeleton) -> dict[str, int]:
    """``{"left": j, "right": j}``: the hand joint proper of each arm.

    ``Skeleton.hands`` finds CMU's ``lwrist`` first, which is the forearm's roll bone; the hand is
    its child ``lhand``, so a child named like a hand is preferred.
    """
    out = {}
    for side, j in skeleton.hands().items():
        kids = [c for c in skeleton.children(j) if "hand" in skeleton.names[c].lower()]
        out[side] = kids[0] if kids else j
    return out


def _palm(skeleton: Skeleton, j: int) -> np.ndarray:
    """Offset ``(3,)`` in hand joint ``j``'s frame of its palm: halfway along the hand bone."""
    return 0.5 * _first_tip(skeleton, j)


def address_frames(points: np.ndarray, still: float = 0.03) -> int:
    """Number of frames at the start during which ``points: (T, 3)`` stay within ``still`` metres of frame 0."""
    moved = np.linalg.norm(points - points[0], axis=1) > still
    return int(np.argmax(moved)) if moved.any() else len(points)


def floor_height(motion: Motion, pose: kinematics.Pose | None = None) -> float:
    """Height (metres) of the lowest foot joint over the clip: the floor a fitted club rests on and
    the effector is kept above. (CMU subject 64's is 2–4 cm below the file's zero; SOURCES.md.)

    Not the judge's floor (:func:`mjmotion.feet.judged_floor`, the stance soles'): joints sit above
    the sole, by under 1 cm on the CMU golfers, 4 cm on the CMU kicks and 5–6 cm on iClone's rigs.
    """
    feet = motion.skeleton.feet()
    if not feet:
        return 0.0
    pose = pose or kinematics.forward(mjcf.compile(motion.skeleton), motion)
    js = [j for a, t in feet.values() for j in (a, t) if j is not None]
    return float(pose.joint_positions[:, js, 2].min())


def fit_club(motion: Motion, kind: str = "club") -> mjcf.Prop:
    """A club fitted to a two-handed swing: handle through both hands at address, standard length.

    The club is held by the upper hand at address (the left for a right-handed golfer), unless its
    rotation jumps by more than ``MAX_HAND_JUMP`` in one frame and the other's does not (then by
    the lower hand). At each address frame (the clip's first still frames) the shaft passes through
    the upper palm with its butt ``BUTT_EXTENSION`` above it, heads toward the lower palm in plan
    view, and is inclined so
    the head at the standard length (``mjcf.PROP_PRESETS``) rests on the floor
    (:func:`floor_height`): the hands are only 5–10 cm apart, too close to fix the inclination
    alone. The club is attached to the holding hand's joint with the transform averaged over the
    address frames and kept fixed for the clip.
    """
    skel = motion.skeleton
    hands = hand_joints(skel)
    if "left" not in hands or "right" not in hands:
        raise MjmotionError(f"{motion.name or 'the clip'}: fitting a club needs both hands, found {sorted(hands) or 'none'} by name")
    if kind not in mjcf.PROP_PRESETS:
        raise MjmotionError(f"unknown prop {kind!r}; expected one of {', '.join(mjcf.PROP_PRESETS)}")
    preset = mjcf.PROP_PRESETS[kind]
    compiled = mjcf.compile(skel)
    pose = kinematics.forward(compiled, motion)
    rots = rot.to_matrix(pose.joint_rotations)
    palms = {s: pose.joint_positions[:, j] + np.einsum("tab,b->ta", rots[:, j], _palm(skel, j)) for s, j in hands.items()}
    n = max(address_frames(palms["left"]), 1)
    upper, lower = ("left", "right") if palms["left"][:n, 2].mean() >= palms["right"][:n, 2].mean() else ("right", "left")
    lead = upper
    jumps = {s: float(np.max(rot.angle_between(motion.rotations[:-1, j], motion.rotations[1:, j]), initial=0.0)) for s, j in hands.items()}
    if jumps[upper] > MAX_HAND_JUMP and jumps[lower] <= MAX_HAND_JUMP:
        # A flipped hand in the data (64_03's lhand turns 179° at frame 101) would throw the club:
        # the club is held by the other hand, its shaft still runs from above the upper hand down past the lower.
        lead = lower
    j = hands[lead]
    floor = floor_height(motion, pose)
    p1 = palms[upper][:n]
    plan = palms[lower][:n, :2] - p1[:, :2]
    plan /= np.maximum(np.linalg.norm(plan, axis=1, keepdims=True), 1e-9)
    dz = np.clip((floor - p1[:, 2]) / (preset["length"] - BUTT_EXTENSION), -1.0, 1.0)
    shaft = np.column_stack([plan * np.sqrt(1.0 - dz**2)[:, None], dz])
    grip = p1 - BUTT_EXTENSION * shaft
    r = rots[:n, j]
    local_grip = np.einsum("tba,tb->ta", r, grip - pose.joint_positions[:n, j]).mean(axis=0)
    local_dir = np.einsum("tba,tb->ta", r, shaft).mean(axis=0)
    quat = mjcf._quat_z_to(local_dir / np.linalg.norm(local_dir))
    return mjcf.Prop(name=kind, joint=skel.names[j], pos=tuple(local_grip), quat=tuple(quat), **preset)  # type: ignore[arg-type]


# --- effectors ---------------------------------------------------------------------------------
def _first_tip(skeleton: Skeleton, j: int) -> np.ndarray:
    """Offset ``(3,)`` in joint ``j``'s frame of the end of its bone: its first child or End Site."""
    tips = [skeleton.offsets[c] for c in skeleton.children(j)]
    tips += [skeleton.end_offsets[e] for e in np.flatnonzero(skeleton.end_parents == j)]
    tips = [t for t in tips if np.linalg.norm(t) > 1e-6]
    return np.asarray(tips[0]) if tips else np.zeros(3)


def resolve_effector(motion: Motion, name: str, prop: mjcf.Prop | None = None) -> tuple[Effector, mjcf.Prop | None]:
    """The :class:`Effector` called ``name`` (see ``EFFECTORS``, or a site of the compiled model).

    ``club``: the sweet spot of ``prop`` (default :func:`fit_club`), in the holding joint's frame.
    ``left_foot``/``right_foot``: the instep, halfway from the ankle to the toe joint.
    ``left_fist``/``right_fist``: the end of the hand bone (knuckles).
    """
    skel = motion.skeleton
    if name == "club":
        prop = prop or fit_club(motion)
        off = np.asarray(prop.pos) + rot.rotate(np.asarray(prop.quat), np.array([0.0, 0.0, prop.sweet_spot]))
        return Effector("club", skel.index(prop.joint), tuple(off)), prop
    if name in ("left_foot", "right_foot"):
        side = name.split("_")[0]
        feet = skel.feet()
        if side not in feet:
            raise MjmotionError(f"--effector {name}: no {side} foot found by name in the skeleton")
        ankle, toe = feet[side]
        off = 0.5 * (skel.offsets[toe] if toe is not None else _first_tip(skel, ankle))
        return Effector(name, ankle, tuple(off)), None
    if name in ("left_fist", "right_fist"):
        side = name.split("_")[0]
        hands = hand_joints(skel)
        if side not in hands:
            raise MjmotionError(f"--effector {name}: no {side} hand found by name in the skeleton")
        return Effector(name, hands[side], tuple(_first_tip(skel, hands[side]))), None
    compiled = mjcf.compile(skel, (prop,) if prop else ())
    try:
        sid = compiled.site_id(name)
    except MjmotionError as e:
        raise MjmotionError(f"--effector {name}: expected {', '.join(EFFECTORS)} or a site of the model; {e}") from None
    body = int(compiled.model.site_bodyid[sid])
    joints = np.flatnonzero(compiled.body_ids == body)
    if len(joints) == 0:
        raise MjmotionError(f"--effector {name}: the site is not on a skeleton joint")
    return Effector(name, int(joints[0]), tuple(compiled.model.site_pos[sid])), prop


# --- stiffness learned from the style space ---------------------------------------------------
def style_weights(motion: Motion, chain: Chain, variance: float = 0.7, floor: float = 0.05, space: PoseSpace | None = None) -> np.ndarray:
    """Meredith & Maddock weights ``(n_dof,)`` learned from the clip's PCA style space (§1.10, §2.5.4).

    A coordinate's stiffness is how far a small turn of it moves the pose in the source's top-``k``
    principal components (the space ``style_rmse`` measures), averaged over the clip's frames:
    ``kᵢ = meanₜ |Lₖᵀ (∂x/∂δᵢ ⊘ D)|²`` with ``x`` the pose parameters, ``D`` their deviations and
    ``Lₖ`` the loadings. Weights are ``1 / (kᵢ + floor · max k)``, normalised to a maximum of 1.
    A joint whose rotation never changes in the source is invisible to the PCA; it gets the
    largest stiffness instead of none (it should not start moving now). ``space``: the clip's
    ``PoseSpace.fit(motion)`` when the caller already has it (both chains of a shot share one).
    """
    space = space or PoseSpace.fit(motion)
    k = space.components_for(variance)
    lk = space.loadings[:, :k]
    row = -np.ones(space.kept.size, dtype=int)
    row[space.kept] = np.arange(int(space.kept.sum()))
    stiff = []
    still = []
    for cj in chain.joints:
        cols = 3 + 4 * cj.joint + np.arange(4)  # pose_parameters: root translation, then quaternions
        kept = space.kept[cols]
        rows = lk[row[cols[kept]]]  # (n_kept, k)
        q = rot.make_continuous(motion.rotations[:, cj.joint])
        if cj.dof:
            # coordinate i turns the joint about its factor axis at the frame's own angles (ik.chains)
            rates = factor_rates(np.broadcast_to(cj.basis.T, (len(q), 3, 3)), _coords(cj.basis, cj.q_ref, q))
        for i in range(cj.dof):
            dq = rot.multiply(q, np.concatenate([np.zeros((len(q), 1)), 0.5 * rates[:, i]], axis=1))[:, kept]
            z = (dq / space.deviations[cols[kept]]) @ rows
            stiff.append(float(np.mean(np.sum(z**2, axis=1))))
            still.append(not kept.any())
    s = np.asarray(stiff)
    if s.size == 0:
        return s
    s = np.where(still, s.max(), s)
    w = 1.0 / (s + floor * s.max() + 1e-12)
    return w / w.max()


# --- hit frame and blend -----------------------------------------------------------------------
def _downswing(effector: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """``(window, speed)``: the frames of the swing through the ball, ``effector: (T, 3)`` metres.

    The anchor is the frame of peak effector speed where the effector is in the lower half of its
    height range and not rising steeply (vertical speed at most a quarter of the speed): a club
    driven by the lead hand keeps accelerating as it rises into the follow-through, after the ball
    has gone. The window is the run of frames around it faster than ``FAST`` × the anchor's speed.
    Speeds are central differences smoothed over ~25 ms.
    """
    vel = np.gradient(effector, axis=0) * fps
    width = max(1, min(round(0.025 * fps), (len(effector) - 1) // 2))  # no longer than the clip (np.convolve 'same')
    kernel = np.ones(2 * width + 1) / (2 * width + 1)
    vel = np.column_stack([np.convolve(vel[:, i], kernel, mode="same") for i in range(3)])
    speed = np.linalg.norm(vel, axis=1)
    z = effector[:, 2]
    down = (vel[:, 2] <= 0.25 * speed) & (z <= 0.5 * (z.min() + z.max()))
    down[[0, -1]] = False
    if not down.any():
        down[1:-1] = True
    anchor = int(np.argmax(np.where(down, speed, -1.0)))
    fast = speed >= FAST * speed[anchor]
    a = anchor
    while a > 1 and fast[a - 1]:
        a -= 1
    b = anchor
    while b < len(z) - 2 and fast[b + 1]:
        b += 1
    return np.arange(a, b + 1), speed


def detect_hit_frame(effector: np.ndarray, fps: float, ball: np.ndarray | None = None) -> int:
    """The moment of contact, ``effector: (T, 3)`` metres: the frame of the downswing where the
    effector reaches the ball.

    ``ball`` ``(3,)``: the source's ball position (metres); the hit is the downswing frame nearest
    to it. Without it the ball is on the ground or a tee, and the hit is the effector's lowest pass
    in the downswing (``_downswing``: the fast frames around the swing's peak speed, so the address,
    where a club rests just as low, is not taken for the impact).
    """
    if len(effector) < 3:
        return 0
    window, _ = _downswing(effector, fps)
    if ball is not None:
        d = np.linalg.norm(effector[window] - np.asarray(ball, dtype=float), axis=1)
        return int(window[int(np.argmin(d))])
    return int(window[int(np.argmin(effector[window, 2]))])


def blend_weights(effector: np.ndarray, hit: int, falloff: float, fps: float, edge: float = DEFAULT_EDGE) -> np.ndarray:
    """Importance blend ``(T,)`` in [0, 1] (§2.2.5), tapered to 0 at the clip's ends.

    ``blend = clamp(1 − |e_t − e_hit| / falloff, 0, 1)``, times a raised-cosine taper over the first
    and last ``edge`` seconds, each shortened to end at the hit frame when the hit is closer to
    that end: the blend is 1 at the hit unless the hit is the first or last frame itself.
    """
    if not falloff > 0:
        raise MjmotionError(f"--falloff must be a positive distance in metres, got {falloff}")
    d = np.linalg.norm(effector - effector[hit], axis=1)
    b = np.clip(1.0 - d / falloff, 0.0, 1.0)
    return b * end_taper(len(effector), hit, fps, edge)


def end_taper(n_frames: int, hit: int, fps: float, edge: float = DEFAULT_EDGE) -> np.ndarray:
    """``(T,)`` raised-cosine taper from 0 at the first and last frames to 1 after ``edge`` seconds
    (each side shortened to end at the hit frame when the hit is closer to that end)."""
    n = max(1, round(edge * fps))
    n_start, n_end = max(1, min(n, hit)), max(1, min(n, n_frames - 1 - hit))
    i = np.arange(n_frames)
    ramp = np.minimum(np.minimum(i / n_start, (n_frames - 1 - i) / n_end), 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * ramp))


# --- the problem -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class HitProblem:
    """Everything fixed before solving: model, chains, FK of the source, goals.

    Attributes:
        source: the source clip.
        compiled: its MuJoCo model with the prop (if any).
        effector: the moved point; ``lead``: its chain; ``second``: the second hand's chain or ``None``.
        qpos: ``(T, nq)`` the source's FK poses.
        effector_fk: ``(T, 3)`` the source effector; ``hit``: the hit frame; ``target``: ``(3,)``.
        blend: ``(T,)``; ``goals``: ``(T, 3)`` effector goals.
        second_relative: ``(T, 4, 4)`` source pose of the second hand in the lead chain tip's frame.
        falloff: metres; ``prop``: the club (``None`` for other effectors).
        space: ``PoseSpace.fit(source)`` when the style weights needed it (reused for ``style_rmse``).
        hit_rule: how the hit frame was found: ``given``, ``nearest the ball`` or ``lowest pass``.
        floor: metres, the floor the subject stands on (:func:`floor_height`; not always z = 0).
        points, radius: ``(P, 3)`` points in the effector joint's frame (a club: both ends of its
            shaft) and a radius, whose lowest height is kept off the floor (:attr:`clearance`).
        clearance: ``(T,)`` metres, the lowest the effector may go per frame: the floor, or the
            source's own lowest point where it is already below the floor.
        requested: ``(3,)`` the target asked for, when :attr:`target` had to stop short of it.
        source_lowest: ``(T,)`` metres, the height of the effector's lowest point in the source.
        tip_rotations: ``(T, 3, 3)`` world rotation of the effector's joint in the source (the
            frame the offset is carried in; :func:`aim` uses it).
    """

    source: Motion
    compiled: mjcf.CompiledModel
    effector: Effector
    lead: Chain
    second: Chain | None
    qpos: np.ndarray
    effector_fk: np.ndarray
    hit: int
    target: np.ndarray
    blend: np.ndarray
    goals: np.ndarray
    second_relative: np.ndarray | None
    falloff: float
    prop: mjcf.Prop | None = None
    space: PoseSpace | None = None
    hit_rule: str = "given"
    floor: float = 0.0
    points: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))
    radius: float = 0.0
    clearance: np.ndarray | None = None
    requested: np.ndarray | None = None
    source_lowest: np.ndarray | None = None
    tip_rotations: np.ndarray | None = None


def _frames(pose: kinematics.Pose, j: int) -> np.ndarray:
    """``(T, 4, 4)`` world transforms of joint ``j``."""
    t = pose.joint_positions.shape[0]
    out = np.zeros((t, 4, 4))
    out[:, :3, :3] = rot.to_matrix(pose.joint_rotations[:, j])
    out[:, :3, 3] = pose.joint_positions[:, j]
    out[:, 3, 3] = 1.0
    return out


def _chain_start(skeleton: Skeleton, tip: int) -> int:
    """The root's child on the path to ``tip`` (the lower spine for a hand, the hip for a foot)."""
    path = skeleton.chain(0, tip)
    if len(path) < 2:
        raise MjmotionError(f"{skeleton.names[tip]!r} is the root; it cannot be an IK chain's tip")
    return path[1]


def _lca(skeleton: Skeleton, a: int, b: int) -> int:
    pa = skeleton.chain(0, a)
    pb = skeleton.chain(0, b)
    common = 0
    for x, y in zip(pa, pb):
        if x != y:
            break
        common = x
    return common


def check_chain_options(skel: Skeleton, tip: int, wrist: str, lock: tuple[str, ...] | list[str], start: int | None = None, dash: str = "") -> None:
    """Refuse a ``lock`` or a ``wrist`` freedom that the chain from ``start`` (default: where :func:`setup`
    starts it) to the effector's joint ``tip`` has no joint for: either would leave the result as if it
    were not given (a foot's chain has no wrist; an arm joint is not in a leg's chain). ``dash``: ``--``
    to name them as options."""
    chain = skel.chain(_chain_start(skel, tip) if start is None else start, tip)
    names = [skel.names[j] for j in chain]
    span = f"the chain {names[0]} → {names[-1]} ({', '.join(names)})"
    for name in lock:
        skel.index(name)
        if name not in names:
            raise MjmotionError(f"{dash}lock {name}: not a joint of {span}; locking it would change nothing")
    if wrist != "locked" and not any(joint_role(skel, j) == "wrist" for j in chain):
        raise MjmotionError(f"{dash}wrist {wrist}: {span} has no wrist joint; leave it out")


def setup(
    motion: Motion,
    target: np.ndarray | None = None,
    offset: np.ndarray | None = None,
    frame: int | None = None,
    effector: str = "club",
    falloff: float = DEFAULT_FALLOFF,
    wrist: str = "locked",
    lock: tuple[str, ...] | list[str] = (),
    margin: float = DEFAULT_MARGIN,
    weights: str = "style",
    edge: float = DEFAULT_EDGE,
    chain_start: str | None = None,
    prop: mjcf.Prop | None = None,
    source_ball: np.ndarray | None = None,
    joint_limits: np.ndarray | None = None,
) -> HitProblem:
    """Build the :class:`HitProblem` (see :func:`adapt` for the arguments)."""
    if (target is None) == (offset is None):
        raise MjmotionError("give exactly one of a target position or an offset")
    # (a NaN or negative margin returned "unreachable" having moved nothing; a NaN edge or frame was a raw
    # ValueError; a fractional frame was cut to a whole one)
    for label, value, low in (("margin", margin, 0.0), ("edge", edge, 0.0), ("falloff", falloff, 0.0)):
        if not (is_real(value) and value >= low):
            raise MjmotionError(f"{label}={value!r}: expected a finite number ≥ {low:g}")
    if frame is not None and not is_whole(frame):
        raise MjmotionError(f"frame={frame!r}: expected a whole frame number (or None: the moment of contact)")
    for label, vec in (("target", target), ("offset", offset), ("the source's ball", source_ball)):
        if vec is not None:
            mjcf.check_vector(label, vec, 3, "metres")
    skel = motion.skeleton
    eff, prop = resolve_effector(motion, effector, prop)
    compiled = mjcf.compile(skel, (prop,) if prop is not None else ())
    qpos = kinematics.qpos(compiled, motion)
    pose = kinematics.forward(compiled, qpos)
    tip_frames = _frames(pose, eff.joint)
    e_fk = np.einsum("tab,b->ta", tip_frames[:, :3, :3], np.asarray(eff.offset)) + tip_frames[:, :3, 3]
    if source_ball is not None:
        source_ball = np.asarray(source_ball, dtype=float)
    if frame is not None:
        hit, rule = int(frame), "given"
    else:
        hit = detect_hit_frame(e_fk, motion.fps, source_ball)
        rule = "lowest pass" if source_ball is None else "nearest the ball"
    if not 0 < hit < motion.n_frames - 1:
        # end_taper keeps the clip's first and last frames: a hit there cannot move (it read "unreachable, 0 m short")
        said = f"frame {frame}" if rule == "given" else f"the hit frame found ({rule}), {hit},"
        inner = (
            f"the clip's frames 1..{motion.n_frames - 2}"
            if motion.n_frames > 2
            else f"a clip of {motion.n_frames} frame{'s' if motion.n_frames > 1 else ''}"
        )
        raise MjmotionError(f"{said} is not inside {inner}; the edit keeps the first and last frames as captured")
    # (target and offset were checked above, before any work)
    tgt = np.asarray(target, dtype=float) if target is not None else e_fk[hit] + np.asarray(offset, dtype=float)
    blend = blend_weights(e_fk, hit, falloff, motion.fps, edge)
    tip_rot = tip_frames[:, :3, :3].copy()
    goals = _goals(e_fk, tip_rot, blend, hit, tgt)
    start = skel.index(chain_start) if chain_start else _chain_start(skel, eff.joint)
    chain_weights = "clip" if weights == "style" else weights
    max_angles = judge_cones(motion) if joint_limits is None else np.asarray(joint_limits, dtype=float)
    check_chain_options(skel, eff.joint, wrist, lock, start)
    lead = build_chain(motion, start, eff.joint, eff, wrist=wrist, lock=lock, margin=margin, weights=chain_weights, max_angles=max_angles)
    # One PCA of the source for both chains' weights (the second fits it itself if the lead has none).
    space = PoseSpace.fit(motion) if weights == "style" and lead.n_dof else None
    if space is not None:
        lead = lead.with_weights(style_weights(motion, lead, space=space))
    second = None
    rel = None
    if effector == "club":
        hands = hand_joints(skel)
        other = [j for j in hands.values() if j != eff.joint]
        if other:
            h2 = other[0]
            anc = _lca(skel, eff.joint, h2)
            s2 = skel.chain(anc, h2)[1]
            # The second arm only follows the first hand; its limits get twice the margin. Its wrist
            # swings (§2.1.2); it twists too where the arm has no forearm roll bone to do it.
            roll = any(joint_role(skel, j) == "twist" for j in skel.chain(s2, h2))
            second = build_chain(
                motion, s2, h2, None, wrist="swing" if roll else "ball", margin=2 * margin, weights=chain_weights, max_angles=max_angles
            )
            if weights == "style" and second.n_dof:
                second = second.with_weights(style_weights(motion, second, space=space))
            rel = np.linalg.inv(tip_frames) @ _frames(pose, h2)
    floor = floor_height(motion, pose)
    if prop is not None:
        # the club's shaft, grip to head, and its radius
        axis = rot.rotate(np.asarray(prop.quat), np.array([0.0, 0.0, 1.0]))
        points, radius = np.array([prop.pos, np.asarray(prop.pos) + prop.length * axis]), float(prop.radius)
    else:
        points, radius = np.asarray(eff.offset, dtype=float)[None], 0.0
    lowest = np.min(tip_frames[:, 2, 3][:, None] + tip_frames[:, 2, :3] @ points.T, axis=1)
    clearance = np.minimum(floor, lowest - radius) - CLEARANCE_SLACK
    return HitProblem(
        motion, compiled, eff, lead, second, qpos, e_fk, hit, tgt, blend, goals, rel, falloff, prop, space, rule, floor, points, radius, clearance,
        source_lowest=lowest - radius, tip_rotations=tip_rot,
    )  # fmt: skip


def _check_target(tgt: np.ndarray, what: str = "target") -> np.ndarray:
    if tgt.shape != (3,) or not np.all(np.isfinite(tgt)):
        raise MjmotionError(f"the {what} must be three finite numbers (metres), got {tgt}")
    return tgt


def _goals(e_fk: np.ndarray, tip_rot: np.ndarray, blend: np.ndarray, hit: int, tgt: np.ndarray) -> np.ndarray:
    """``(T, 3)`` effector goals: the FK effector plus ``blend`` times the hit's offset (§2.2.4: carried in the effector joint's frame)."""
    local = tip_rot[hit].T @ (tgt - e_fk[hit])
    return e_fk + blend[:, None] * np.einsum("tab,b->ta", tip_rot, local)


def aim(problem: HitProblem, target: np.ndarray) -> HitProblem:
    """``problem`` with a new ``target (3,)``: exactly what :func:`setup` builds for it, without
    redoing the work that does not depend on the target (model, FK, chains, the PCA of the style
    weights, the floor clearance). An interactive drag sets up once and aims many times."""
    if problem.tip_rotations is None:
        raise MjmotionError("this HitProblem has no tip rotations; build it with hitpoint.setup")
    tgt = _check_target(np.asarray(target, dtype=float))
    goals = _goals(problem.effector_fk, problem.tip_rotations, problem.blend, problem.hit, tgt)
    return replace(problem, target=tgt, goals=goals, requested=None)


# --- target grids (experiments) ---------------------------------------------------------------
def swing_plane_axes(problem: HitProblem) -> np.ndarray:
    """``(2, 3)`` unit axes of the plane across the swing at the hit: horizontal, then up-ish.

    Both are perpendicular to the effector's velocity at the hit frame; the second is the world's
    up made perpendicular to it.
    """
    e = problem.effector_fk
    h = int(np.clip(problem.hit, 1, len(e) - 2))
    v = e[h + 1] - e[h - 1]
    v /= np.linalg.norm(v)
    up = np.array([0.0, 0.0, 1.0]) - v[2] * v
    up /= np.linalg.norm(up)
    return np.stack([np.cross(v, up), up])


def target_grid(problem: HitProblem, spacing: float) -> np.ndarray:
    """``(9, 3)`` offsets of a 3×3 grid in the plane across the swing (metres): ``{−s, 0, s}`` across
    and ``{−s, 0, s}`` up, or ``{0, s, 2s}`` up when a row ``s`` lower would put the effector's
    lowest point (a club's head, a bat's toe) under the floor (:attr:`HitProblem.clearance`): a ball
    on the ground or a tee can only be met higher."""
    axes = swing_plane_axes(problem)
    steps = (-spacing, 0.0, spacing)
    h = problem.hit
    grounded = (
        problem.clearance is not None and problem.source_lowest is not None and problem.source_lowest[h] - spacing * axes[1, 2] < problem.clearance[h]
    )
    ups = (0.0, spacing, 2 * spacing) if grounded else steps
    return np.array([a * axes[0] + b * axes[1] for a in steps for b in ups])


def grid_reports(
    motion: Motion,
    spacings: tuple[float, ...] = (0.1, 0.2),
    prop: mjcf.Prop | None = None,
    **options: object,
) -> list[dict]:
    """Adapt ``motion`` to every target of the 3×3 grids at ``spacings`` and return the reports.

    Each report gets ``offset`` (the grid offset, metres), ``spacing``, ``first_last_equal`` (the
    first and last frames are the source's) and ``untouched_equal`` (root and every joint outside
    the two chains are the source's). ``options`` go to :func:`adapt` (``solver``, ``wrist``,
    ``falloff``, …). The club is fitted once for all targets.
    """
    if prop is None and options.get("effector", "club") == "club":
        prop = fit_club(motion)
    base = setup(motion, offset=np.zeros(3), prop=prop, **{k: v for k, v in options.items() if k in _SETUP_KEYS})  # type: ignore[arg-type]
    out = []
    for spacing in spacings:
        for off in target_grid(base, spacing):
            a = adapt(motion, offset=off, prop=prop, **options)  # type: ignore[arg-type]
            r = dict(a.report)
            r["offset"] = off.tolist()
            r["spacing"] = spacing
            r["first_last_equal"], r["untouched_equal"] = source_kept(a)
            out.append(r)
    return out


_SETUP_KEYS = ("frame", "effector", "falloff", "wrist", "lock", "margin", "weights", "edge", "chain_start", "source_ball")


# --- solving -----------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Adaptation:
    """The adapted clip and its report.

    Attributes:
        motion: the adapted clip (only the two chains' joints differ from the source).
        report: the JSON report (keys as in the issue).
        achieved: ``(T, 3)`` effector in the result; ``goal_error``: ``(T,)`` metres;
        grip_error: ``(T,)`` metres (second hand's distance to its source placement).
    """

    motion: Motion
    report: dict
    achieved: np.ndarray
    goal_error: np.ndarray
    grip_error: np.ndarray
    problem: HitProblem

    def __repr__(self) -> str:
        """The adapted clip and its headline numbers (:attr:`report` has them all)."""
        from .summary import fields

        keep = ("solver", "hit_frame", "reachable", "hit_error_m", "grip_error_m", "style_rmse")
        return fields("Adaptation", repr(self.motion.name), **{k: self.report[k] for k in keep if k in self.report})

    def to_markdown(self) -> str:
        """The report as a two-column Markdown table, rounded for reading."""
        from .summary import markdown_table

        return markdown_table(self.report, header=("hit point", self.motion.name or "value"))


def source_kept(adaptation: Adaptation) -> tuple[bool, bool]:
    """``(first_last_equal, untouched_equal)``: the first and last frames are the source's; the root
    and every joint outside the two chains are the source's (bit for bit)."""
    p, out = adaptation.problem, adaptation.motion
    src = p.source
    moved = set(p.lead.joint_indices) | (set(p.second.joint_indices) if p.second is not None else set())
    still = [j for j in range(src.skeleton.n_joints) if j not in moved]
    ends = bool(np.array_equal(out.rotations[[0, -1]], src.rotations[[0, -1]]))
    kept = bool(np.array_equal(out.rotations[:, still], src.rotations[:, still]) and np.array_equal(out.root_positions, src.root_positions))
    return ends, kept


def _rotations(problem: HitProblem, lead_delta: np.ndarray, second_delta: np.ndarray | None) -> np.ndarray:
    """``(T, J, 4)`` local rotations of the source with both chains' ``δ (T, n)`` applied."""
    q = problem.source.rotations.copy()
    ji = problem.lead.joint_indices
    q[:, ji] = problem.lead.apply(q[:, ji], lead_delta)
    if problem.second is not None and second_delta is not None:
        j2 = problem.second.joint_indices
        q[:, j2] = problem.second.apply(q[:, j2], second_delta)
    return q


def frame_ik(problem: HitProblem, solver: str) -> TwoHandIK:
    """The per-frame IK of ``problem``'s chains with ``solver`` (``nlp``, ``dls`` or ``ccd``)."""
    src, lead, second = problem.source, problem.lead, problem.second
    return TwoHandIK(
        problem.compiled,
        lead,
        second,
        problem.qpos,
        lead.bounds(src),
        second.bounds(src) if second is not None else None,
        lead.cones(src),
        second.cones(src) if second is not None else None,
        problem.second_relative,
        solver,
        problem.points,
        problem.radius,
    )


def _margin(problem: HitProblem, t: int, sol: FrameSolution) -> float:
    """Room (metres) a frame's solution has: negative unless the goal is reached, the grip kept and
    the effector no lower than allowed (``HitProblem.clearance``)."""
    clear = problem.clearance[t] if problem.clearance is not None else -np.inf
    return float(min(REACH_TOLERANCE - sol.error, REACH_TOLERANCE - sol.grip_error, sol.lowest - clear))


def _fraction(problem: HitProblem, ik: TwoHandIK, t: int, goal: np.ndarray, oracle: TwoHandIK | None = None) -> float:
    """The largest fraction of frame ``t``'s offset toward ``goal`` the chains reach (:func:`mjmotion.ik.reach.nearest_reachable`).

    ``oracle``: a faster IK (DLS) that finds the fraction first; ``ik`` then checks it and, if it
    cannot reach that far, searches below it.
    """
    e = problem.effector_fk[t]
    off = goal - e
    length = float(np.linalg.norm(off))
    # the source's own pose has at least this much room (its goal met, its grip, its own height)
    start = min(REACH_TOLERANCE, CLEARANCE_SLACK)
    top = 1.0
    if oracle is not None and oracle is not ik:
        top = nearest_reachable(lambda x: _margin(problem, t, oracle.solve(t, e + x * off)), length, start)
        if _margin(problem, t, ik.solve(t, e + top * off)) >= 0:
            return top
    return top * nearest_reachable(lambda x: _margin(problem, t, ik.solve(t, e + x * top * off)), top * length, start)


def _scaled_goals(problem: HitProblem, fraction: np.ndarray | float) -> np.ndarray:
    """``(T, 3)`` goals with each frame's offset from the FK effector scaled by ``fraction``."""
    f = np.broadcast_to(np.asarray(fraction, dtype=float), (problem.source.n_frames,))
    return problem.effector_fk + f[:, None] * (problem.goals - problem.effector_fk)


def stop_short(problem: HitProblem, ik: TwoHandIK, oracle: TwoHandIK | None = None) -> HitProblem:
    """The problem with its target moved back along the offset to the nearest point the chains can
    reach at the hit frame (the grip kept, the club off the floor; :func:`mjmotion.ik.reach.nearest_reachable`),
    or ``problem`` itself when the target can be reached."""
    h = problem.hit
    s = _fraction(problem, ik, h, problem.goals[h], oracle)
    if s >= 1.0:
        return problem
    # not to the very edge: the frames around the hit, at the edge of the reach too, keep some room
    s *= 1.0 - SHORT_ROOM
    return replace(_stopped_at(problem, s), goals=_scaled_goals(problem, s))


def _stopped_at(problem: HitProblem, s: float) -> HitProblem:
    """``problem`` with its target ``s`` of the way from the source hit point to it; the target asked for kept as ``requested``."""
    e = problem.effector_fk[problem.hit]
    asked = problem.requested if problem.requested is not None else problem.target
    return replace(problem, target=e + s * (problem.target - e), requested=asked)


def preview_frames(problem: HitProblem, n: int) -> np.ndarray:
    """About ``n`` of the frames the blend touches, for a coarse solve: spaced evenly in time plus
    the blend's change (so the short ramp around the hit gets its share), with both ends and the hit frame."""
    active = np.flatnonzero(problem.blend > 0)
    if n <= 0 or len(active) <= n:
        return active
    change = np.abs(np.diff(problem.blend[active]))
    u = np.arange(len(active)) / (len(active) - 1) + np.concatenate([[0.0], np.cumsum(change)]) / max(float(change.sum()), 1e-12)
    picks = np.minimum(np.searchsorted(u, np.linspace(0.0, u[-1], n)), len(active) - 1)
    keep = np.union1d(active[picks], [active[0], active[-1]])
    return np.union1d(keep, [problem.hit]) if problem.blend[problem.hit] > 0 else keep


def _solve_frames(
    problem: HitProblem,
    ik: TwoHandIK,
    oracle: TwoHandIK | None = None,
    frames: np.ndarray | None = None,
    on_frame: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Per-frame solve of every frame the blend touches, or of ``frames``
    (:class:`mjmotion.ik.twohand.TwoHandIK`); ``on_frame(i, n)`` before each first solve.

    A frame whose goal cannot be reached gets the largest fraction of its offset that can be
    (:func:`_fraction`, found with ``oracle`` first when given), the fractions are made gradual
    (:func:`mjmotion.ik.reach.envelope`, ``FRACTION_RATE``) and the frames they shorten are solved again
    (twice at most). Returns both chains' ``δ``, the fractions ``(T,)`` and the frames solved.
    """
    t_n = problem.source.n_frames
    d1 = np.zeros((t_n, problem.lead.n_dof))
    d2 = np.zeros((t_n, problem.second.n_dof if problem.second else 0))
    active = np.flatnonzero(problem.blend > 0) if frames is None else np.asarray(frames, dtype=int)
    goals = problem.goals
    sols = {}
    for i, t in enumerate(active):
        if on_frame is not None:
            on_frame(i, len(active))
        sols[int(t)] = ik.solve(int(t), goals[t])
    fraction = np.ones(t_n)
    for _ in range(2):
        bad = [t for t, sol in sols.items() if _margin(problem, t, sol) < 0]
        if not bad:
            break
        for t in bad:
            fraction[t] *= _fraction(problem, ik, t, goals[t], oracle)
        fraction = envelope(fraction, FRACTION_RATE / problem.source.fps)
        goals = _scaled_goals(problem, fraction)
        for t in active[fraction[active] < 1.0]:
            sols[int(t)] = ik.solve(int(t), goals[t])
    for t, sol in sols.items():
        d1[t], d2[t] = sol.lead, sol.second
    return d1, d2, fraction, len(active)


def _solve_shot(problem: HitProblem, smoothness: float, goals_all: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Whole-shot NLP over the frames the blend touches, to ``goals_all (T, 3)``; the others stay
    the source (``δ = 0``). Returns both chains' ``δ`` and whether IPOPT met every constraint."""
    from .ik.nlp import ShotSolver, SymbolicFK

    c = problem.compiled
    lead, second = problem.lead, problem.second
    t_n = problem.source.n_frames
    d1 = np.zeros((t_n, lead.n_dof))
    d2 = np.zeros((t_n, second.n_dof if second else 0))
    frames = np.flatnonzero(problem.blend > 0)
    n = len(frames)
    if n == 0:
        return d1, d2, True
    fk = SymbolicFK(c, [lead] + ([second] if second else []))
    # Base frames come from the source FK (the lead chain's base is never moved).
    data = mujoco.MjData(c.model)
    params = np.empty((n, fk.n_params))
    for i, t in enumerate(frames):
        data.qpos[:] = problem.qpos[t]
        mujoco.mj_kinematics(c.model, data)
        params[i] = fk.params(problem.qpos[t], data.xpos, data.xmat)
    goals = goals_all[frames]
    lo, hi = (x[frames] for x in lead.bounds(problem.source))
    cones = lead.cones(problem.source)[frames]
    if second is not None:
        lo2, hi2 = second.bounds(problem.source)
        lo, hi = np.hstack([lo, lo2[frames]]), np.hstack([hi, hi2[frames]])
        cones = np.hstack([cones, second.cones(problem.source)[frames]])
        assert problem.second_relative is not None, "setup gives a second chain its grip placement"
        rel = problem.second_relative[frames]
        goals = np.hstack([goals, rel[:, :3, 3], rel[:, :3, :3].transpose(0, 2, 1).reshape(n, 9)])
    solver = ShotSolver(c, lead, second, frames, smoothness=smoothness)
    res = solver.solve(params, goals, lo, hi, cones)
    d1[frames] = res.lead
    if second is not None:
        d2[frames] = res.second
    return d1, d2, res.success


def adapt(
    motion: Motion,
    target: np.ndarray | None = None,
    offset: np.ndarray | None = None,
    frame: int | None = None,
    effector: str = "club",
    solver: str = "nlp",
    falloff: float = DEFAULT_FALLOFF,
    wrist: str = "locked",
    lock: tuple[str, ...] | list[str] = (),
    margin: float = DEFAULT_MARGIN,
    weights: str = "style",
    edge: float = DEFAULT_EDGE,
    smoothness: float = 100.0,
    chain_start: str | None = None,
    prop: mjcf.Prop | None = None,
    style: bool = True,
    source_ball: np.ndarray | None = None,
    joint_limits: np.ndarray | None = None,
) -> Adaptation:
    """Adapt ``motion`` so its effector meets ``target`` (or the source hit point + ``offset``) at the hit frame.

    Args:
        motion: the source swing/kick/punch.
        target, offset: ``(3,)`` metres in the model's world frame (exactly one).
        frame: the hit frame (default: detected, :func:`detect_hit_frame`: the lowest pass of the
            effector in the downswing, or the downswing frame nearest ``source_ball``).
        effector: ``club`` (fitted, two hands), ``left_foot``, ``right_foot``, ``left_fist``,
            ``right_fist`` or a site name of the compiled model.
        solver: ``nlp`` (per frame, CasADi/IPOPT), ``nlp-shot`` (whole shot), ``dls`` or ``ccd``.
        falloff: metres, the importance blend's falloff distance (§2.2.5; different values give
            different trajectories to the same hit, §2.4).
        wrist: the effector-side wrist's freedom: ``locked`` (§2.3.3), ``swing`` (2 DOF) or ``ball``.
        lock: further joints of the chain to lock. A ``lock`` joint not in the chain, or a ``wrist``
            other than ``locked`` for a chain with no wrist (a foot's), is refused: it would change nothing.
        margin: radians added to the clip's range for the rotation limits.
        weights: stiffness weights: ``style`` (learned from the source's PCA style space,
            :func:`style_weights`), ``clip`` (the coordinate's variance in the clip) or ``uniform``.
        edge: seconds of taper to the source at both ends.
        smoothness: weight of the acceleration term (``nlp-shot``).
        chain_start: override the chain's first joint (default: the root's child toward the effector).
        prop: the club to use (default: :func:`fit_club`).
        style: compute ``style_rmse`` (PCA of the source; METRICS.md "Style").
        source_ball: ``(3,)`` metres, where the ball was in the source (for the hit frame's detection).
        joint_limits: ``(J,)`` radians, cone limits on every joint's local rotation angle
            (default: :func:`judge_cones`, the judge's joint ranges, or the source's own largest
            angle for a joint it already takes beyond its range; ``inf`` for none); the chains keep within them exactly, and a frame whose source is already
            beyond a limit does not go further.

    A target the chains cannot reach at the hit frame (within their limits, with the second hand
    on the grip and the effector no lower than the floor, or than the source where it is lower)
    is stopped short along the offset at the nearest point they can reach; the report says how
    far short (``short_by_m``) and the result is written as the best effort.
    """
    _check_solver(solver)
    if not (is_real(smoothness) and smoothness >= 0):
        raise MjmotionError(f"smoothness={smoothness!r}: expected a finite number ≥ 0")
    problem = setup(
        motion, target, offset, frame, effector, falloff, wrist, lock, margin, weights, edge, chain_start, prop, source_ball, joint_limits
    )
    return solve(problem, solver, smoothness, style)


def _check_solver(solver: str) -> None:
    if solver not in SOLVERS:
        raise MjmotionError(f"--solver must be one of {', '.join(SOLVERS)}, got {solver!r}")


def solve(
    problem: HitProblem,
    solver: str = "nlp",
    smoothness: float = 100.0,
    style: bool = True,
    preview: int = 0,
    on_frame: Callable[[int, int], None] | None = None,
) -> Adaptation:
    """Solve a :class:`HitProblem` (:func:`setup`, or :func:`aim` at a new target): the IK part of :func:`adapt`.

    ``solve(setup(m, target, ...), solver)`` is ``adapt(m, target, ..., solver=solver)``.

    Args:
        preview: a coarse preview (per-frame solvers) when the blend touches more frames than
            this: solve only about ``preview`` of them (:func:`preview_frames`, the hit frame among
            them) and interpolate the chains' ``δ`` linearly in between. The hit frame is solved
            as exactly as ever, the frames between are approximate; the report gets
            ``preview_frames``. ``0``: every frame, as :func:`adapt`.
        on_frame: ``(i, n)`` before each frame's solve (progress; it may raise to stop the solve).
    """
    _check_solver(solver)
    if preview and solver == "nlp-shot":
        raise MjmotionError("a preview needs a per-frame solver (nlp, dls or ccd)")
    motion = problem.source
    active = np.flatnonzero(problem.blend > 0)
    frames = preview_frames(problem, preview) if 0 < preview < len(active) else None
    start = time.perf_counter()
    # The per-frame IK decides what can be reached (the whole-shot NLP uses the per-frame NLP for it).
    ik = frame_ik(problem, "nlp" if solver == "nlp-shot" else solver)
    # DLS finds how far a goal can be reached fast; the solver itself confirms it
    oracle = ik if solver == "dls" else frame_ik(problem, "dls")
    problem = stop_short(problem, ik, oracle)
    name = f"{motion.name}_hit" if motion.name else "hit"
    fraction = np.ones(motion.n_frames)
    if solver == "nlp-shot":
        d1, d2, ok = _solve_shot(problem, smoothness, problem.goals)
        n = len(active)
        if not ok:
            # some frame cannot meet its goal with the grip kept: shorten those goals, then solve again
            _, _, fraction, _ = _solve_frames(problem, ik, oracle)
            d1, d2, _ = _solve_shot(problem, smoothness, _scaled_goals(problem, fraction))
    else:
        d1, d2, fraction, n = _solve_frames(problem, ik, oracle, frames, on_frame)
    if fraction[problem.hit] < 1.0:
        # frames beside the hit fell short and the gradual envelope took the hit with them: the
        # target is where the hit now stops (so short_by_m and the message say how far short)
        problem = _stopped_at(problem, float(fraction[problem.hit]))
    if frames is not None:
        # between solved frames the δ of both chains is interpolated (it is 0 outside the blend)
        d1[active] = _interp_rows(active, frames, d1[frames])
        d2[active] = _interp_rows(active, frames, d2[frames])
    d1, d2, paced = _pace(problem, ik, d1, d2)
    out = motion.replace(rotations=_rotations(problem, d1, d2 if problem.second is not None else None), name=name)
    elapsed = time.perf_counter() - start
    a = _report(problem, out, solver, elapsed, n, style, fraction, paced)
    if frames is not None:
        a.report["preview_frames"] = int(len(frames))
    return a


def _interp_rows(at: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``(len(at), n)``: each column of ``y (len(x), n)`` interpolated linearly at ``at``."""
    return np.stack([np.interp(at, x, y[:, k]) for k in range(y.shape[1])], axis=1) if y.shape[1] else np.zeros((len(at), 0))


def judge_cones(motion: Motion) -> np.ndarray:
    """The default cone limits ``(J,)`` radians: the judge's joint ranges (:func:`mjmotion.limits.joint_limits`,
    which the compiled model declares and ``evaluate``'s ``limit_violation_ratio`` counts), kept
    :data:`CONE_CLEARANCE` inside so a written BVH reads within them; where the source itself turns
    a joint beyond its range somewhere (a rig's bind rotation stored in its channels, as iClone's
    and the ASF hands' are), that range is not this rig's and the joint keeps within the source's own
    largest angle."""
    judge = limits.joint_limits(motion.skeleton) - CONE_CLEARANCE
    own = rotation_angle(motion.rotations).max(axis=0)
    return np.where(own > judge, own, judge)


def _pace(problem: HitProblem, ik: TwoHandIK, d1: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Both chains' ``δ`` with no chain joint turning faster than ``JOINT_SPEED_BOUND`` × its own
    peak in the source (:func:`mjmotion.ik.reach.paced_walk`): from the hit outward, a frame whose solution would
    be too fast moves the lead only part of the way there and puts the second hand back on the grip
    for that pose. Returns them and the number of frames slowed."""
    src, lead, second = problem.source, problem.lead, problem.second
    chains = [c for c in (lead, second) if c is not None]
    cols = [c.joint_indices for c in chains]
    q_src = [src.rotations[:, j] for j in cols]
    moving = [np.array([cj.dof > 0 for cj in c.joints]) for c in chains]

    def peaks(q: np.ndarray) -> np.ndarray:
        return rotation_angle(rot.multiply(rot.conjugate(q[:-1]), q[1:])).max(axis=0) if len(q) > 1 else np.zeros(q.shape[1])

    bound = [JOINT_SPEED_BOUND * peaks(q) + 1e-12 for q in q_src]
    cones = [c.cones(src) for c in chains]
    d1, d2 = d1.copy(), d2.copy()
    # every frame's own solution, at once
    solved = [lead.apply(q_src[0], d1)] + ([second.apply(q_src[1], d2)] if second is not None else [])

    def rotations(t: int, ab: tuple[np.ndarray, np.ndarray] | None) -> list[np.ndarray]:
        if ab is None:  # the frame's own solution
            return [r[t] for r in solved]
        out = [lead.apply(q_src[0][t : t + 1], ab[0][None])[0]]
        if second is not None:
            out.append(second.apply(q_src[1][t : t + 1], ab[1][None])[0])
        return out

    def fast(prev: list[np.ndarray], now: list[np.ndarray]) -> bool:
        return any(np.any((rotation_angle(rot.multiply(rot.conjugate(p), n)) > b) & m) for p, n, b, m in zip(prev, now, bound, moving))

    # the walk's last accepted frame: both chains' δ and the chain joints' rotations
    state: dict[str, np.ndarray] = {}
    state_rot: list[list[np.ndarray]] = [[]]
    trial: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def candidate(t: int, lam: float) -> tuple[np.ndarray, np.ndarray] | None:
        if lam >= 1.0:
            return None
        if lam not in trial:
            a = state["lead"] + lam * (d1[t] - state["lead"])
            # a step between two frames' solutions can leave this frame's cones (each frame's FK
            # differs): back toward this frame's source pose until it is within them
            a = lead.within_cones(q_src[0][t], a, cones[0][t])
            # from the previous frame's grip (to stay on its branch), else afresh from the source's
            prev = state["second"] if second is None else second.within_cones(q_src[1][t], state["second"], cones[1][t])
            warm = ik.hold(t, a, dls_only=True, start=prev)
            if warm.grip_error > PACED_GRIP:
                cold = ik.hold(t, a, dls_only=True)
                warm = cold if cold.grip_error < warm.grip_error else warm
            trial[lam] = (a, warm.second)
        return trial[lam]

    def step_ok(t: int, lam: float) -> bool:
        return not fast(state_rot[0], rotations(t, candidate(t, lam)))

    def accept(t: int, lam: float) -> None:
        ab = candidate(t, lam)
        state_rot[0] = rotations(t, ab)
        if ab is not None:
            d1[t], d2[t] = ab
        state["lead"], state["second"] = d1[t].copy(), d2[t].copy()
        trial.clear()

    h = problem.hit
    if second is not None and ik.solver != "dls":
        # the walk's frames hold the grip by DLS: so does the hit, where DLS holds it as well
        held = ik.hold(h, d1[h], dls_only=True)
        if held.grip_error <= REACH_TOLERANCE:
            d2[h] = held.second
            solved[1][h] = second.apply(q_src[1][h : h + 1], d2[h][None])[0]
    n = 0
    for step in (1, -1):
        state["lead"], state["second"], state_rot[0] = d1[h].copy(), d2[h].copy(), rotations(h, None)
        ends = np.arange(h + step, src.n_frames) if step > 0 else np.arange(h - 1, -1, -1)
        n += paced_walk(ends, step_ok, accept)
    return d1, d2, n


def _report(problem: HitProblem, out: Motion, solver: str, elapsed: float, n: int, style: bool, fraction: np.ndarray, paced: int) -> Adaptation:
    c = problem.compiled
    pose = kinematics.forward(c, out)
    tip = _frames(pose, problem.effector.joint)
    achieved = np.einsum("tab,b->ta", tip[:, :3, :3], np.asarray(problem.effector.offset)) + tip[:, :3, 3]
    goal_err = np.linalg.norm(achieved - problem.goals, axis=1)
    grip = np.zeros(out.n_frames)
    if problem.second is not None:
        want = tip @ problem.second_relative
        grip = np.linalg.norm(pose.joint_positions[:, problem.second.tip] - want[:, :3, 3], axis=1)
    asked = problem.requested if problem.requested is not None else problem.target
    hit_err = float(np.linalg.norm(achieved[problem.hit] - asked))
    reachable = hit_err <= REACH_TOLERANCE
    rmse = k = None
    if style:
        from .style import style_rmse

        r, kk = style_rmse(problem.source, out, space=problem.space)
        rmse, k = float(r), int(kk)
    active = problem.blend > 0
    low = np.min(tip[:, 2, 3][:, None] + tip[:, 2, :3] @ problem.points.T, axis=1) - problem.radius
    report = {
        "hit_frame": int(problem.hit),
        "hit_rule": problem.hit_rule,
        "floor_m": problem.floor,
        "source_effector_height_m": float(problem.effector_fk[problem.hit, 2] - problem.floor),
        "source_effector": problem.effector_fk[problem.hit].tolist(),
        "target": asked.tolist(),
        "stopped_target": problem.target.tolist(),
        "short_by_m": float(np.linalg.norm(asked - problem.target)),
        "achieved_effector": achieved[problem.hit].tolist(),
        "hit_error_m": hit_err,
        "reachable": bool(reachable),
        "max_goal_error_m": float(goal_err.max()),
        "frames_shortened": int(np.count_nonzero(active & (fraction < 1.0))),
        "style_rmse": rmse,
        "k": k,
        "grip_error_m": float(grip.max()),
        "lowest_above_floor_m": float(low.min() - problem.floor),
        "joint_speed_ratio": joint_speed_ratio(problem, out),
        "frames_paced": int(paced),
        "solve_s_per_frame": float(elapsed / n) if n else 0.0,
        "solver": solver,
    }
    if not reachable:
        dist = float(np.linalg.norm(asked - problem.effector_fk[problem.hit]))
        report["message"] = (
            f"target unreachable: it is {dist:.3f} m from the source hit point; stopped {report['short_by_m']:.3f} m short of it "
            f"along the offset, at the nearest point the chain {problem.lead.names[0]}..{problem.lead.names[-1]} reaches within "
            "its limits with the grip kept and the effector off the floor (best effort kept)"
        )
    return Adaptation(out, report, achieved, goal_err, grip, problem)


def joint_speed_ratio(problem: HitProblem, out: Motion) -> float:
    """Largest ratio, over the chains' moving joints, of a joint's peak angular speed in ``out`` to
    its own peak in the source (1: no joint faster than it ever is in the source)."""
    joints = [cj.joint for c in (problem.lead, problem.second) if c is not None for cj in c.joints if cj.dof]
    if not joints or out.n_frames < 2:
        return 0.0

    def peaks(m: Motion) -> np.ndarray:
        q = m.rotations[:, joints]
        return rotation_angle(rot.multiply(rot.conjugate(q[:-1]), q[1:])).max(axis=0)

    return float(np.max(peaks(out) / np.maximum(peaks(problem.source), 1e-12)))
