"""IK chains: which joints move, with which freedoms, within which limits (seed 003 §2.1–2.2).

A chain joint's rotation is its FK rotation followed by a product of single-axis rotations about
its free axes, ``q = q_fk ⊗ Rot(b₁, δ₁) ⊗ Rot(b₂, δ₂) ⊗ Rot(b₃, δ₃)`` (axes in the joint's own
frame, the first ``k`` columns of a right-handed basis ``B``). ``δ = 0`` is the FK pose exactly
(§2.2.3: IK starts from the frame's FK pose), a hinge stays a hinge exactly, and every solver —
CCD, DLS and the CasADi NLP — works in the same coordinates ``δ``.

Freedoms (§2.1.2): an elbow or knee is a **hinge** (1 DOF, axis = the clip's own flexion axis);
a forearm roll bone (CMU's ``lwrist``) is a hinge about its twist axis; a wrist (``lhand``) is a
**swing** (2 DOF across the hand bone, no twist) or **locked** (0 DOF, §2.3.3); every other joint is
a **ball** (3 DOF). Limits (§2.1.3) come from **the clip's own range with a margin**, not anatomy
tables: each free coordinate of ``B``-axis Euler angles of ``q_ref⁻¹ q`` (``q_ref`` the clip's mean
rotation of the joint) stays within the clip's min/max widened by ``margin``. A result's coordinate
is taken as the FK frame's plus ``δ`` (exact for hinges, first order for 2/3-axis joints), so the
limits are per-frame box bounds on ``δ`` that always contain 0.

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
from scipy.spatial.transform import Rotation

from .. import rotations as rot
from ..errors import MjmotionError
from ..mjcf import CompiledModel
from ..skeleton import Motion, Skeleton

FREEDOMS = ("ball", "swing", "hinge", "locked")
#: Default widening of the clip's range for the rotation limits (radians).
DEFAULT_MARGIN = np.deg2rad(20.0)
#: Lowest standard deviation used for stiffness weights (a joint still in the clip is not rigid).
WEIGHT_FLOOR = np.deg2rad(3.0)

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
    """

    joint: int
    freedom: str
    basis: np.ndarray
    dof: int
    q_ref: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    weight: np.ndarray


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

    def coordinates(self, local_rotations: np.ndarray) -> np.ndarray:
        """Limit coordinates ``(T, n_dof)`` of chain-joint rotations ``(T, Jc, 4)`` (or of a motion's)."""
        cols = []
        for i, j in enumerate(self.joints):
            if j.dof:
                cols.append(_coords(j.basis, j.q_ref, local_rotations[:, i])[:, : j.dof])
        return np.concatenate(cols, axis=1) if cols else np.zeros((local_rotations.shape[0], 0))

    def bounds(self, motion: Motion) -> tuple[np.ndarray, np.ndarray]:
        """Per-frame box bounds ``(T, n_dof)`` on ``δ`` from the joints' limits (always contain 0)."""
        c = self.coordinates(motion.rotations[:, self.joint_indices])
        lo = np.concatenate([j.lower for j in self.joints]) if self.n_dof else np.zeros(0)
        hi = np.concatenate([j.upper for j in self.joints]) if self.n_dof else np.zeros(0)
        return np.minimum(lo - c, 0.0), np.maximum(hi - c, 0.0)

    def apply(self, fk_rotations: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """Chain-joint rotations ``(..., Jc, 4)`` for FK rotations ``(..., Jc, 4)`` and ``δ (..., n_dof)``."""
        return rot.multiply(fk_rotations, perturbation(self.factor_axes(), self.padded(delta)))


def perturbation(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``Rot(a₁, θ₁) ⊗ Rot(a₂, θ₂) ⊗ Rot(a₃, θ₃)`` per joint: axes ``(Jc, 3, 3)``, angles ``(..., Jc, 3)`` → ``(..., Jc, 4)``."""
    half = 0.5 * angles
    f = np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * axes], axis=-1)
    return rot.multiply(rot.multiply(f[..., 0, :], f[..., 1, :]), f[..., 2, :])


def _coords(basis: np.ndarray, q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles ``(T, 3)`` about the basis axes of ``q_ref⁻¹ ⊗ q``."""
    rel = rot.to_matrix(rot.multiply(rot.conjugate(q_ref), q))
    m = np.einsum("ji,tjk,kl->til", basis, rel, basis)
    return Rotation.from_matrix(m).as_euler("XYZ")


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
) -> ChainJoint:
    """The :class:`ChainJoint` for joint ``j`` of ``motion`` with ``freedom`` and limits from the clip.

    ``axis``: for a hinge, the hinge axis (default: the clip's principal rotation axis of the joint).
    """
    if freedom not in FREEDOMS:
        raise MjmotionError(f"freedom must be one of {', '.join(FREEDOMS)}, got {freedom!r}")
    skel = motion.skeleton
    q = rot.make_continuous(motion.rotations[:, j])
    q_ref = rot.normalize(rot.weighted_average(q, np.ones(len(q))))
    v = rot.log(rot.multiply(rot.conjugate(q_ref)[None], q))
    if freedom == "hinge":
        a = _principal_axis(v, bone_axis(skel, j) if axis is None else axis) if axis is None else np.asarray(axis, float)
        a = a / np.linalg.norm(a)
        basis = _complete(a)
        dof = 1
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
    lower = c.min(axis=0) - margin if dof else np.zeros(0)
    upper = c.max(axis=0) + margin if dof else np.zeros(0)
    sd = np.maximum(c.std(axis=0), WEIGHT_FLOOR) if dof else np.zeros(0)
    return ChainJoint(j, freedom, basis, dof, q_ref, lower, upper, sd**2)


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
    """
    skel = motion.skeleton
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
        if skel.names[j] in lock:
            freedom = "locked"
        elif role in ("hinge", "twist"):
            freedom = "hinge"
        elif role == "wrist":
            freedom = wrist
        else:
            freedom = "ball"
        joints.append(chain_joint(motion, j, freedom, margin))
    if weights == "uniform":
        joints = [ChainJoint(c.joint, c.freedom, c.basis, c.dof, c.q_ref, c.lower, c.upper, np.ones(c.dof)) for c in joints]
    elif weights == "clip":
        top = max((float(c.weight.max()) for c in joints if c.dof), default=1.0)
        joints = [ChainJoint(c.joint, c.freedom, c.basis, c.dof, c.q_ref, c.lower, c.upper, c.weight / top) for c in joints]
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
        self.q_fk = np.zeros((len(chain.joints), 4))
        self.jacp = np.zeros((3, self.model.nv))
        self.jacr = np.zeros((3, self.model.nv))

    def set_frame(self, qpos: np.ndarray) -> None:
        """Load the FK pose ``qpos: (nq,)`` of a frame; ``δ = 0`` reproduces it."""
        self.data.qpos[:] = qpos
        self.q_fk = self.data.qpos[self.qidx].reshape(-1, 4).copy()
        self._angles = np.zeros((len(self.chain.joints), 3))

    def set_delta(self, delta: np.ndarray) -> None:
        """Apply ``δ (n_dof,)`` to the loaded frame and run ``mj_kinematics``."""
        self._angles = self.chain.padded(delta)
        pert = perturbation(self.axes, self._angles)
        self.data.qpos[self.qidx] = rot.multiply(self.q_fk, pert).ravel()
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
        the factor axes: coordinate ``i`` of a joint turns about ``(Rᵢ₊₁⋯R₃)ᵀ bᵢ`` in that frame.
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
