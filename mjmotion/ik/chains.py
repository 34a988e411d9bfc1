"""IK chains: which joints move, with which freedoms, within which limits (seed 003 §2.1–2.2).

A chain joint's rotation is written in its own limit coordinates: ``q = q_ref ⊗ Rot(b₁, c₁) ⊗
Rot(b₂, c₂) ⊗ Rot(b₃, c₃)`` with ``q_ref`` the clip's mean rotation of the joint and ``b₁..b₃`` the
columns of a right-handed basis ``B`` in the joint's frame (intrinsic Euler angles about ``B``).
The IK coordinates ``δ`` are changes of the first ``dof`` of these angles from the frame's FK
pose, ``c = c_fk + δ``; the others stay at their FK values. ``δ = 0`` is the FK pose exactly
(§2.2.3: IK starts from the frame's FK pose), a hinge stays a hinge, a swing wrist keeps its twist
angle, and every solver — CCD, DLS and the CasADi NLP — works in the same coordinates ``δ``.

Freedoms (§2.1.2): an elbow or knee is a **hinge** (1 DOF, axis = the clip's own flexion axis;
an elbow whose clip also rolls it about its bone by more than ``HINGE_ROLL`` — pronation stored in
the elbow's channels, with no roll bone below — gets that roll too, and its carrying angle within
``ELBOW_CARRY`` of the clip's: 3 coordinates, flexion, carrying angle, roll);
a forearm roll bone (CMU's ``lwrist``) is a hinge about its twist axis; a wrist (``lhand``) is a
**swing** (2 DOF across the hand bone, no twist) or **locked** (0 DOF, §2.3.3); a joint the source
never turns (CMU's hip joints, clavicles and fingers: no degree of freedom in its skeleton) is
locked too; every other joint is a **ball** (3 DOF).

Limits (§2.1.3), enforced exactly: each free angle ``cᵢ`` stays within **the clip's own range
widened by a margin** — since the angles are the coordinates themselves, these are box bounds on
``δ`` that hold exactly, not to first order, for 2- and 3-axis joints as much as for hinges, and
always contain 0. A joint may also have a **cone** limit ``max_angle``, the largest rotation angle
of its local rotation (a model's joint range, e.g. ``mjmotion.limits.joint_limits``); a frame whose
source pose is already beyond it may not turn further out (:meth:`Chain.cones`). The NLP takes the
cone as a smooth constraint on the trace of the local rotation matrix; DLS and CCD shorten a step
that would leave it (:func:`cone_step`).

Stiffness (§1.10, Meredith & Maddock 2005): each coordinate has a weight ``w ∈ (0, 1]``; a small
weight is a stiff joint. ``weights="clip"`` gives the clip's own variance of the coordinate (a
joint that moves a lot in this shot is supple), floored and normalised to a maximum of 1;
:func:`mjmotion.hitpoint.style_weights` learns them from the clip's PCA style space instead.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field

import mujoco
import numpy as np

from .. import rotations as rot
from ..errors import MjmotionError
from ..mjcf import CompiledModel
from ..skeleton import Motion, Skeleton

FREEDOMS = ("ball", "swing", "hinge", "locked")
#: Default widening of the clip's range for the rotation limits (radians).
DEFAULT_MARGIN = np.deg2rad(20.0)
#: A hinge whose clip rolls about its bone over more than this range (radians) also rolls.
HINGE_ROLL = np.deg2rad(10.0)
#: Such an elbow's carrying angle (across flexion and roll) may leave the clip's range by this much (radians).
ELBOW_CARRY = np.deg2rad(5.0)
#: Lowest standard deviation used for stiffness weights (a joint still in the clip is not rigid).
WEIGHT_FLOOR = np.deg2rad(3.0)
#: A joint whose rotation never leaves this angle (radians) of its first frame is not a freedom of the character.
STILL_JOINT = 1e-6

_HINGE = re.compile(r"radius|forearm|elbow|tibia|shin|knee|lowleg|calf", re.IGNORECASE)
_WRIST = re.compile(r"hand|wrist", re.IGNORECASE)


@dataclass(frozen=True)
class Effector:
    """A point fixed in a joint's frame: a club's sweet spot, a point on a foot, a fist.

    Attributes:
        name: a label (``"club"``, ``"right_foot"``, or a site's name).
        joint: skeleton joint index whose frame carries the point.
        offset: ``(3,)`` metres, the point in that joint's frame.
    """

    name: str
    joint: int
    offset: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class ChainJoint:
    """One moving joint of a chain.

    Attributes:
        joint: skeleton joint index.
        freedom: ``ball``, ``swing``, ``hinge`` or ``locked``.
        basis: ``(3, 3)`` right-handed axes in the joint frame; the first ``dof`` are free.
        dof: number of free coordinates (3, 2, 1 or 0).
        q_ref: ``(4,)`` the clip's mean local rotation, the origin of the limit coordinates.
        lower, upper: ``(dof,)`` radians, limits on the coordinates (clip range ± margin).
        weight: ``(dof,)`` Meredith & Maddock weights in (0, 1]; small = stiff.
        max_angle: radians, the cone limit on the joint's local rotation angle (``inf``: none).
    """

    joint: int
    freedom: str
    basis: np.ndarray
    dof: int
    q_ref: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    weight: np.ndarray
    max_angle: float = np.inf


@dataclass(frozen=True, eq=False)
class Chain:
    """Joints from a chain start down to the joint holding the effector, with their freedoms.

    Attributes:
        skeleton: the character.
        joints: the chain's joints, parent before child (locked joints included, ``dof = 0``).
        effector: the point the chain moves (``None`` for a chain solved for a frame, e.g. a hand).
        tip: skeleton index of the chain's last joint (the effector's joint, or a hand).
    """

    skeleton: Skeleton
    joints: tuple[ChainJoint, ...]
    effector: Effector | None
    tip: int
    _cols: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def n_dof(self) -> int:
        return int(sum(j.dof for j in self.joints))

    @property
    def joint_indices(self) -> np.ndarray:
        return np.array([j.joint for j in self.joints], dtype=int)

    @property
    def weights(self) -> np.ndarray:
        """``(n_dof,)`` stiffness weights of all coordinates, chain order."""
        return np.concatenate([j.weight for j in self.joints]) if self.n_dof else np.zeros(0)

    @property
    def slices(self) -> list[slice]:
        """Per chain joint, its coordinates' slice of ``δ``."""
        out, a = [], 0
        for j in self.joints:
            out.append(slice(a, a + j.dof))
            a += j.dof
        return out

    @property
    def names(self) -> list[str]:
        return [self.skeleton.names[j.joint] for j in self.joints]

    def with_weights(self, weights: np.ndarray) -> Chain:
        """The same chain with stiffness weights ``(n_dof,)`` (chain order) replaced."""
        w = np.asarray(weights, dtype=float)
        if w.shape != (self.n_dof,) or not np.all(w > 0):
            raise MjmotionError(f"chain weights must be {self.n_dof} positive numbers, got shape {w.shape}")
        joints = tuple(dataclasses.replace(j, weight=w[s]) for j, s in zip(self.joints, self.slices))
        return dataclasses.replace(self, joints=joints)

    def factor_axes(self) -> np.ndarray:
        """``(Jc, 3, 3)`` per joint, the three factor axes (columns of ``basis``) as rows."""
        return np.stack([j.basis.T for j in self.joints])

    def padded(self, delta: np.ndarray) -> np.ndarray:
        """``delta: (..., n_dof)`` → ``(..., Jc, 3)`` angles per factor (0 for non-free factors)."""
        delta = np.asarray(delta, dtype=float)
        out = np.zeros((*delta.shape[:-1], len(self.joints), 3))
        for i, (j, s) in enumerate(zip(self.joints, self.slices)):
            out[..., i, : j.dof] = delta[..., s]
        return out

    def within_cones(self, fk_rotations: np.ndarray, delta: np.ndarray, cones: np.ndarray) -> np.ndarray:
        """One frame's ``delta (n_dof,)`` with each coned joint's part shortened toward 0 (the
        frame's FK pose, ``fk_rotations (Jc, 4)``, itself within ``cones (Jc,)`` radians as
        :meth:`cones` gives them) until the joint's rotation is within its cone."""
        start = self.angles(np.asarray(fk_rotations, dtype=float)[None])[0]
        step = self.padded(delta)
        axes = self.factor_axes()
        out = np.array(delta, dtype=float)
        for i, (j, sl) in enumerate(zip(self.joints, self.slices)):
            if j.dof and np.isfinite(cones[i]) and np.any(step[i] != 0.0):
                out[sl] *= cone_step(j.q_ref, axes[i], start[i], step[i], float(cones[i]))
        return out

    def angles(self, local_rotations: np.ndarray) -> np.ndarray:
        """All three limit angles ``(T, Jc, 3)`` of chain-joint rotations ``(T, Jc, 4)`` (0 for locked joints)."""
        out = np.zeros((local_rotations.shape[0], len(self.joints), 3))
        for i, j in enumerate(self.joints):
            if j.dof:
                out[:, i] = _coords(j.basis, j.q_ref, local_rotations[:, i])
        return out

    def coordinates(self, local_rotations: np.ndarray) -> np.ndarray:
        """Limit coordinates ``(T, n_dof)`` of chain-joint rotations ``(T, Jc, 4)`` (or of a motion's)."""
        a = self.angles(local_rotations)
        cols = [a[:, i, : j.dof] for i, j in enumerate(self.joints) if j.dof]
        return np.concatenate(cols, axis=1) if cols else np.zeros((local_rotations.shape[0], 0))

    @property
    def lower(self) -> np.ndarray:
        """``(n_dof,)`` the coordinates' lower limits (radians)."""
        return np.concatenate([j.lower for j in self.joints]) if self.n_dof else np.zeros(0)

    @property
    def upper(self) -> np.ndarray:
        """``(n_dof,)`` the coordinates' upper limits (radians)."""
        return np.concatenate([j.upper for j in self.joints]) if self.n_dof else np.zeros(0)

    def bounds(self, motion: Motion) -> tuple[np.ndarray, np.ndarray]:
        """Per-frame box bounds ``(T, n_dof)`` on ``δ``: exactly the joints' limits (they always contain 0)."""
        c = self.coordinates(motion.rotations[:, self.joint_indices])
        return np.minimum(self.lower - c, 0.0), np.maximum(self.upper - c, 0.0)

    def cones(self, motion: Motion) -> np.ndarray:
        """Per-frame cone limits ``(T, Jc)`` (radians): each joint's ``max_angle``, or the source's own
        angle where the source is already beyond it (so ``δ = 0`` is always allowed)."""
        limit = np.array([j.max_angle for j in self.joints])
        return np.maximum(limit, rotation_angle(motion.rotations[:, self.joint_indices]))

    @property
    def coned(self) -> np.ndarray:
        """``(Jc,) bool``: joints with a cone limit that can move."""
        return np.array([bool(j.dof) and np.isfinite(j.max_angle) for j in self.joints], dtype=bool)

    def apply(self, fk_rotations: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """Chain-joint rotations ``(T, Jc, 4)`` for FK rotations ``(T, Jc, 4)`` and ``δ (T, n_dof)``.

        A joint whose ``δ`` is zero in a frame keeps its FK rotation bit for bit.
        """
        fk = np.asarray(fk_rotations, dtype=float)
        d = self.padded(delta)
        out = fk.copy()
        moved = np.any(d != 0.0, axis=-1)  # (T, Jc)
        if not moved.any():
            return out
        a = self.angles(fk) + d
        q_ref = np.stack([j.q_ref for j in self.joints])
        new = rot.multiply(np.broadcast_to(q_ref, fk.shape), perturbation(self.factor_axes(), a))
        # the FK rotation's sign (a quaternion and its negative are the same rotation)
        new = np.where(np.sum(new * fk, axis=-1, keepdims=True) < 0, -new, new)
        out[moved] = new[moved]
        return out


def rotation_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle ``(...)`` in ``[0, π]`` radians of unit quaternions ``q: (..., 4)``."""
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def cone_step(q_ref: np.ndarray, axes: np.ndarray, start: np.ndarray, step: np.ndarray, limit: float, iters: int = 30) -> float:
    """Largest fraction ``s ∈ [0, 1]`` of ``step (3,)`` from the joint's angles ``start (3,)`` whose
    rotation ``q_ref ⊗ P(start + s·step)`` stays within the cone ``limit`` (radians).

    ``start`` must be inside (or no further out than allowed); bisection on ``s``.
    """

    def angle(s: float) -> float:
        return float(rotation_angle(rot.multiply(q_ref, perturbation(axes[None], (start + s * step)[None])[0])))

    if angle(1.0) <= limit:
        return 1.0
    base = max(angle(0.0), limit)
    lo, hi = 0.0, 1.0
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if angle(mid) <= base:
            lo = mid
        else:
            hi = mid
    return lo


def perturbation(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``Rot(a₁, θ₁) ⊗ Rot(a₂, θ₂) ⊗ Rot(a₃, θ₃)`` per joint: axes ``(Jc, 3, 3)``, angles ``(..., Jc, 3)`` → ``(..., Jc, 4)``."""
    half = 0.5 * angles
    f = np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * axes], axis=-1)
    return rot.multiply(rot.multiply(f[..., 0, :], f[..., 1, :]), f[..., 2, :])


def _coords(basis: np.ndarray, q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles ``(T, 3)`` about the basis axes of ``q_ref⁻¹ ⊗ q`` (``q: (T, 4)``).

    ``m = Bᵀ R(q_ref⁻¹ q) B = Rx(a) Ry(b) Rz(c)``: ``b = asin m₀₂``, ``a = atan2(−m₁₂, m₂₂)``,
    ``c = atan2(−m₀₁, m₀₀)`` (at ``|b| = 90°`` all of the turn goes to ``a``).
    """
    rel = rot.multiply(rot.conjugate(q_ref), q)
    m = np.einsum("ji,tjk,kl->til", basis, _matrix(rel), basis)
    sb = np.clip(m[:, 0, 2], -1.0, 1.0)
    b = np.arcsin(sb)
    lock = np.abs(sb) > 1.0 - 1e-12
    a = np.where(lock, np.arctan2(m[:, 2, 1], m[:, 1, 1]), np.arctan2(-m[:, 1, 2], m[:, 2, 2]))
    c = np.where(lock, 0.0, np.arctan2(-m[:, 0, 1], m[:, 0, 0]))
    return np.stack([a, b, c], axis=1)


def _matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)`` (w, x, y, z)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def _principal_axis(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Unit direction of largest spread of vectors ``v: (T, 3)`` (``fallback`` if they are all ~0)."""
    if v.shape[0] == 0 or np.max(np.linalg.norm(v, axis=1)) < 1e-6:
        return fallback / np.linalg.norm(fallback)
    _, _, vt = np.linalg.svd(v - 0.0, full_matrices=False)
    a = vt[0]
    return a if np.dot(a, v.sum(axis=0)) >= 0 else -a


def bone_axis(skeleton: Skeleton, j: int) -> np.ndarray:
    """Unit direction ``(3,)`` of joint ``j``'s bone in its own frame (first child or End Site)."""
    tips = [skeleton.offsets[c] for c in skeleton.children(j)]
    tips += [skeleton.end_offsets[e] for e in np.flatnonzero(skeleton.end_parents == j)]
    tips = [t for t in tips if np.linalg.norm(t) > 1e-6]
    if not tips:
        return np.array([1.0, 0.0, 0.0])
    t = np.asarray(tips[0], dtype=float)
    return t / np.linalg.norm(t)


def joint_role(skeleton: Skeleton, j: int) -> str:
    """``hinge``, ``twist`` (a forearm roll bone), ``wrist`` or ``ball`` from the joint's name and place."""
    name = skeleton.names[j]
    if _HINGE.search(name):
        return "hinge"
    if _WRIST.search(name):
        # CMU: 'lwrist' is the forearm roll bone and its child 'lhand' is the wrist proper.
        kids = [skeleton.names[c] for c in skeleton.children(j)]
        if "wrist" in name.lower() and any("hand" in k.lower() for k in kids):
            return "twist"
        return "wrist"
    return "ball"


def chain_joint(
    motion: Motion,
    j: int,
    freedom: str,
    margin: float = DEFAULT_MARGIN,
    axis: np.ndarray | None = None,
    max_angle: float = np.inf,
    roll: bool = False,
) -> ChainJoint:
    """The :class:`ChainJoint` for joint ``j`` of ``motion`` with ``freedom`` and limits from the clip.

    ``axis``: for a hinge, the hinge axis (default: the clip's principal rotation axis of the joint).
    ``max_angle``: the cone limit on the joint's local rotation angle (radians); ``inf`` where the
    clip's box (its range ± ``margin``) cannot reach it. ``roll``: a hinge that is an elbow or knee
    (not a roll bone), which also rolls where its clip rolls it (``HINGE_ROLL``).
    """
    if freedom not in FREEDOMS:
        raise MjmotionError(f"freedom must be one of {', '.join(FREEDOMS)}, got {freedom!r}")
    skel = motion.skeleton
    q = rot.make_continuous(motion.rotations[:, j])
    q_ref = rot.normalize(rot.weighted_average(q, np.ones(len(q))))
    v = rot.log(rot.multiply(rot.conjugate(q_ref)[None], q))
    rolling = False
    if freedom == "hinge":
        a = _principal_axis(v, bone_axis(skel, j) if axis is None else axis) if axis is None else np.asarray(axis, float)
        a = a / np.linalg.norm(a)
        basis = _complete(a)
        dof = 1
        if roll and axis is None:
            # An elbow whose channels also carry the forearm's pronation (no roll bone below it: the
            # bundled shots' arms) rolls about its bone in the clip: flexion across the bone, and
            # that roll as a second freedom.
            # With the mean's roll taken out of q_ref (q = swing ⊗ twist about the bone, keep the
            # swing), a bend-then-roll elbow is exactly q_ref ⊗ Rot(flex, c₁) ⊗ Rot(bone, c₂).
            b = bone_axis(skel, j)
            bent = _swing(q_ref, b)
            bend = rot.log(_swing(rot.multiply(rot.conjugate(bent)[None], q), b))
            flex = _principal_axis(bend - np.outer(bend @ b, b), _any_perpendicular(b))
            flex = flex - np.dot(flex, b) * b
            flex /= np.linalg.norm(flex)
            # Coordinates (flexion, carrying angle, roll): the first and last Euler angles have the
            # full circle (a roll past 90° stays continuous); the middle one barely moves in the clip.
            elbow = np.column_stack([flex, np.cross(b, flex), b])
            if np.ptp(_coords(elbow, bent, q)[:, 2]) > HINGE_ROLL:
                basis, dof, q_ref, rolling = elbow, 3, bent, True
    elif freedom in ("swing", "locked"):
        twist = bone_axis(skel, j)
        vp = v - np.outer(v @ twist, twist)
        b1 = _principal_axis(vp, _any_perpendicular(twist))
        b1 = b1 - np.dot(b1, twist) * twist
        b1 /= np.linalg.norm(b1)
        basis = np.column_stack([b1, np.cross(twist, b1), twist])
        dof = 2 if freedom == "swing" else 0
    else:
        basis = np.eye(3)
        dof = 3
    c = _coords(basis, q_ref, q)[:, :dof]
    margins = np.full(dof, float(margin))
    if rolling:
        margins[1] = min(float(margin), ELBOW_CARRY)
    lower = c.min(axis=0) - margins if dof else np.zeros(0)
    upper = c.max(axis=0) + margins if dof else np.zeros(0)
    sd = np.maximum(c.std(axis=0), WEIGHT_FLOOR) if dof else np.zeros(0)
    if np.isfinite(max_angle) and dof:
        # The rotation angle is a metric on rotations, so within the box q_ref ⊗ P(c) turns at most
        # angle(q_ref) + Σ|c_k| from rest: a cone that bound keeps inside cannot bind (and costs the
        # solvers a constraint for nothing).
        reach = float(rotation_angle(q_ref)) + float(np.sum(np.maximum(np.abs(lower), np.abs(upper))))
        if reach <= max_angle:
            max_angle = np.inf
    return ChainJoint(j, freedom, basis, dof, q_ref, lower, upper, sd**2, float(max_angle))


def _swing(q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The swing part ``(..., 4)`` of rotations ``q (..., 4)`` about ``axis (3,)``: ``q = swing ⊗ twist``,
    the twist about ``axis`` (the projection of ``q``'s vector part on it)."""
    w = q[..., :1]
    twist = np.concatenate([w, (q[..., 1:] @ axis)[..., None] * axis], axis=-1)
    n = np.linalg.norm(twist, axis=-1, keepdims=True)
    twist = np.where(n > 1e-12, twist / np.maximum(n, 1e-12), rot.IDENTITY)
    return rot.normalize(rot.multiply(q, rot.conjugate(twist)))


def _any_perpendicular(a: np.ndarray) -> np.ndarray:
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    p = np.cross(a, e)
    return p / np.linalg.norm(p)


def _complete(a: np.ndarray) -> np.ndarray:
    """A right-handed basis ``(3, 3)`` whose first column is ``a``."""
    b = _any_perpendicular(a)
    return np.column_stack([a, b, np.cross(a, b)])


def build_chain(
    motion: Motion,
    start: str | int,
    tip: str | int,
    effector: Effector | None = None,
    wrist: str = "locked",
    lock: tuple[str, ...] | list[str] = (),
    margin: float = DEFAULT_MARGIN,
    weights: str = "clip",
    max_angles: np.ndarray | None = None,
) -> Chain:
    """A chain from joint ``start`` down to ``tip`` (never the root: §2.2.2).

    Args:
        motion: the source clip (freedom axes, limits and weights come from it).
        start, tip: joint names or indices; ``tip`` must be below ``start``.
        effector: the point moved by the chain (its joint must be ``tip``).
        wrist: freedom of a wrist joint: ``locked`` (seed §2.3.3, the default), ``swing`` (2 DOF)
            or ``ball``.
        lock: names of further joints to lock.
        margin: radians added on both sides of the clip's range of each coordinate.
        weights: ``clip`` (variance of the coordinate in the clip, max 1) or ``uniform``.
        max_angles: ``(J,)`` radians per skeleton joint, cone limits on the local rotation angle
            (``inf`` or ``None``: no cone), e.g. ``mjmotion.limits.joint_limits(skeleton)``.
    """
    skel = motion.skeleton
    if max_angles is not None:
        max_angles = np.asarray(max_angles, dtype=float)
        if max_angles.shape != (skel.n_joints,) or np.any(np.isnan(max_angles)) or np.any(max_angles < 0):
            raise MjmotionError(f"joint limits must be {skel.n_joints} non-negative angles (radians, one per joint), got shape {max_angles.shape}")
    s = skel.index(start) if isinstance(start, str) else int(start)
    t = skel.index(tip) if isinstance(tip, str) else int(tip)
    if s == 0:
        raise MjmotionError("an IK chain may not include the root: the legs and feet would move (seed 003 §2.2.2)")
    if wrist not in ("locked", "swing", "ball"):
        raise MjmotionError(f"wrist must be locked, swing or ball, got {wrist!r}")
    if effector is not None and effector.joint != t:
        raise MjmotionError(f"the effector {effector.name!r} hangs from {skel.names[effector.joint]!r}, not the chain tip {skel.names[t]!r}")
    for name in lock:
        skel.index(name)
    joints = []
    for j in skel.chain(s, t):
        role = joint_role(skel, j)
        still = float(np.max(rot.angle_between(motion.rotations[:, j], motion.rotations[:1, j]), initial=0.0)) <= STILL_JOINT
        if skel.names[j] in lock or still:
            # a joint the source never turns is not a freedom of this character (CMU: hip joints, clavicles)
            freedom = "locked"
        elif role in ("hinge", "twist"):
            freedom = "hinge"
        elif role == "wrist":
            freedom = wrist
        else:
            freedom = "ball"
        cone = np.inf if max_angles is None else float(max_angles[j])
        joints.append(chain_joint(motion, j, freedom, margin, max_angle=cone, roll=role == "hinge" and freedom == "hinge"))
    if weights == "uniform":
        joints = [dataclasses.replace(c, weight=np.ones(c.dof)) for c in joints]
    elif weights == "clip":
        top = max((float(c.weight.max()) for c in joints if c.dof), default=1.0)
        joints = [dataclasses.replace(c, weight=c.weight / top) for c in joints]
    else:
        raise MjmotionError(f"weights must be 'clip' or 'uniform', got {weights!r}")
    return Chain(skel, tuple(joints), effector, t)


class ChainKinematics:
    """MuJoCo evaluation of a chain at one frame: set the FK pose, apply ``δ``, read positions and Jacobians.

    Holds one ``MjData``; not thread-safe. ``compiled`` must contain the effector's joint.
    """

    def __init__(self, compiled: CompiledModel, chain: Chain):
        self.compiled = compiled
        self.chain = chain
        self.model = compiled.model
        self.data = mujoco.MjData(self.model)
        self.qadr = np.array([compiled.qpos_adr[j.joint] for j in chain.joints], dtype=int)
        self.dadr = np.array([compiled.dof_adr[j.joint] for j in chain.joints], dtype=int)
        self.qidx = (self.qadr[:, None] + np.arange(4)).ravel()
        self.axes = chain.factor_axes()
        self.free = np.concatenate([np.arange(j.dof) + 3 * i for i, j in enumerate(chain.joints)]).astype(int) if chain.n_dof else np.zeros(0, int)
        self.dof_cols = (self.dadr[:, None] + np.arange(3)).ravel()
        self.tip_body = int(compiled.body_ids[chain.tip])
        eff = chain.effector
        self.eff_offset = np.zeros(3) if eff is None else np.asarray(eff.offset, dtype=float)
        self.q_ref = np.stack([j.q_ref for j in chain.joints]) if chain.joints else np.zeros((0, 4))
        self.moving = np.array([j.dof > 0 for j in chain.joints], dtype=bool)
        self.q_fk = np.zeros((len(chain.joints), 4))
        self.c_fk = np.zeros((len(chain.joints), 3))
        self._angles = np.zeros((len(chain.joints), 3))
        self.jacp = np.zeros((3, self.model.nv))
        self.jacr = np.zeros((3, self.model.nv))

    def set_frame(self, qpos: np.ndarray) -> None:
        """Load the FK pose ``qpos: (nq,)`` of a frame; ``δ = 0`` reproduces it."""
        self.data.qpos[:] = qpos
        self.q_fk = self.data.qpos[self.qidx].reshape(-1, 4).copy()
        self.c_fk = self.chain.angles(self.q_fk[None])[0]
        self._angles = self.c_fk.copy()

    def rotations(self, delta: np.ndarray) -> np.ndarray:
        """``(Jc, 4)`` chain-joint local rotations at ``δ (n_dof,)`` for the loaded frame (the FK
        rotation itself, bit for bit, for a joint whose ``δ`` is zero)."""
        d = self.chain.padded(delta)
        angles = self.c_fk + d
        out = self.q_fk.copy()
        moved = self.moving & np.any(d != 0.0, axis=-1)
        if moved.any():
            new = rot.multiply(self.q_ref[moved], perturbation(self.axes[moved], angles[moved]))
            out[moved] = np.where(np.sum(new * self.q_fk[moved], axis=-1, keepdims=True) < 0, -new, new)
        return out

    def set_delta(self, delta: np.ndarray) -> None:
        """Apply ``δ (n_dof,)`` to the loaded frame and run ``mj_kinematics``."""
        self._angles = self.c_fk + self.chain.padded(delta)
        self.data.qpos[self.qidx] = self.rotations(delta).ravel()
        mujoco.mj_kinematics(self.model, self.data)

    def tip_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """World position ``(3,)`` and rotation ``(3, 3)`` of the tip joint (after :meth:`set_delta`)."""
        b = self.tip_body
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()

    def effector(self) -> np.ndarray:
        """World position ``(3,)`` of the effector (after :meth:`set_delta`)."""
        b = self.tip_body
        return self.data.xpos[b] + self.data.xmat[b].reshape(3, 3) @ self.eff_offset

    def jacobian(self, rotation: bool = False) -> np.ndarray:
        """``(3, n_dof)`` (or ``(6, n_dof)`` with ``rotation``) Jacobian of the effector w.r.t. ``δ``.

        From ``mujoco.mj_jac`` (ball-joint velocities are in the joint's frame), mapped through
        the factor axes: angle ``i`` of a joint turns about ``(Rᵢ₊₁⋯R₃)ᵀ bᵢ`` in that frame, the
        factors ``R`` at the joint's current angles ``c_fk + δ``.
        """
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_jac(self.model, self.data, self.jacp, self.jacr, self.effector(), self.tip_body)
        omega = factor_rates(self.axes, self._angles)
        cols = []
        jp = self.jacp[:, self.dof_cols].reshape(3, -1, 3)
        blocks = [np.einsum("rjk,jik->rji", jp, omega)]
        if rotation:
            jr = self.jacr[:, self.dof_cols].reshape(3, -1, 3)
            blocks.append(np.einsum("rjk,jik->rji", jr, omega))
        for b in blocks:
            cols.append(b.reshape(3, -1)[:, self.free])
        return np.vstack(cols)


def factor_rates(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Joint-frame rotation axes ``(Jc, 3, 3)`` of each factor's angle at ``angles (Jc, 3)``.

    With ``P = F₁F₂F₃``, ``∂P/∂θᵢ`` is a rotation about ``(Fᵢ₊₁⋯F₃)ᵀ aᵢ`` in the joint's frame.
    """
    half = 0.5 * angles
    f = np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * axes], axis=-1)
    s3 = f[:, 2]
    s2 = rot.multiply(f[:, 1], f[:, 2])
    out = np.empty_like(axes)
    out[:, 0] = rot.rotate(rot.conjugate(s2), axes[:, 0])
    out[:, 1] = rot.rotate(rot.conjugate(s3), axes[:, 1])
    out[:, 2] = axes[:, 2]
    return out
