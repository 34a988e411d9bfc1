"""Joint ranges: how far each joint of a skeleton may turn from its rest orientation.

A range is one number per joint, the largest rotation angle (radians) of the joint's local
rotation away from identity — exactly what a MuJoCo ball joint's ``range[1]`` limits, so
:func:`mjmotion.mjcf.compile` declares these on every ball joint and
:func:`mjmotion.evaluate.limit_violation_ratio` counts frames beyond them. The root's free joint
is unlimited (``inf``).

Each joint gets a *class* from the skeleton's structure (:func:`joint_classes`): up from each
foot the ankle, knee and hip; up from each hand the wrist, elbow, shoulder and shoulder girdle;
below them toes and fingers; neck, head, eyes and jaw by name; helper bones (``twist``,
``share``) by name; everything else is spine. :data:`DEFAULT_DEGREES` gives each class an
anatomical default (sums of the joint's swing and twist ranges, rounded up: a ball joint's one
angle combines both). :data:`WIDENED` then raises the range of joints by name where a real clip
of the shared CMU set needs more, each with the clip and the reason — mostly rigs that store a
bind rotation in their channels, so that their "rest" is not a standing pose (iClone's thighs sit
at about 175° from identity in every frame). With these ranges every shared clip, from its
first captured frame, stays inside its ranges (``tests/test_limits.py``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .skeleton import Skeleton

#: Anatomical default per joint class, degrees of rotation from the rest orientation.
DEFAULT_DEGREES: dict[str, float] = {
    "spine": 60.0,  # per vertebral segment group: flexion ~40 + axial twist ~20
    "neck": 70.0,
    "head": 70.0,
    "eye": 45.0,
    "jaw": 40.0,
    "girdle": 45.0,  # clavicle elevation/protraction
    "shoulder": 160.0,  # from a T-pose: arm down 90 plus 70 of twist
    "elbow": 160.0,  # flexion 150 plus pronation-supination
    "wrist": 90.0,
    "finger": 100.0,
    "hip": 125.0,  # flexion 120 with abduction/twist
    "knee": 150.0,
    "ankle": 75.0,  # dorsi 20 + plantar 50 with inversion
    "toe": 80.0,
    "helper": 90.0,  # twist and share bones follow part of another joint's rotation
}


@dataclass(frozen=True)
class Widening:
    """A range raised by name where a real clip needs it: ``pattern`` (regex on the joint name,
    case-sensitive, full match), the new range in ``degrees``, the ``clip`` and ``reason``."""

    pattern: str
    degrees: float
    clip: str
    reason: str


#: Where the shared clips need more than the anatomical default (measured maxima in parentheses).
WIDENED: tuple[Widening, ...] = (
    Widening(r"[lr](hand|thumb)", 180.0, "cmu_asfamc_converted/64_03, 64_04", "the ASF hand and thumb channels sit at a half turn (180°)"),
    Widening(r"CC_Base_[LR]_Thigh", 180.0, "cmu_iclone_ccrig/*", "iClone stores a ~175° bind rotation in the thigh channel (168–180°)"),
    Widening(r"CC_Base_[LR]_Foot", 135.0, "cmu_iclone_ccrig/002_07", "iClone's foot channel holds a ~90° bind rotation (124°)"),
    Widening(r"CC_Base_[LR]_Clavicle", 95.0, "cmu_iclone_ccrig/*", "a constant 88.5° bind rotation"),
    Widening(r"CC_Base_Hip", 110.0, "cmu_iclone_ccrig/002_01, 002_03", "under RL_BoneRoot the hip holds an ~85° bind rotation (98°)"),
    Widening(r"CC_Base_[LR]_Hand", 110.0, "cmu_iclone_ccrig/002_07", "bind rotation plus wrist flexion (101°)"),
    Widening(r"CC_Base_[LR]_Thumb1", 165.0, "cmu_iclone_ccrig/002_07", "one captured frame at 158° (raw data)"),
    Widening(r"CC_Base_.*(Eye|Teeth\d*|RibsTwist)", 180.0, "cmu_iclone_ccrig/*", "half-turn bind rotations of face and rib helper bones"),
    Widening(r"CC_Base_(FacialBone|JawRoot|UpperJaw)", 125.0, "cmu_iclone_ccrig/*", "bind rotations of 90–120°"),
    Widening(r"RightWrist", 105.0, "cmu_cgspeed_max/102_01", "wrist flexion with twist (98°)"),
    Widening(r"RThumb", 115.0, "cmu_cgspeed_max/131_01", "thumb channel (110°)"),
)

_HELPER = re.compile(r"twist|share", re.IGNORECASE)
_EYE = re.compile(r"eye", re.IGNORECASE)
_JAW = re.compile(r"jaw|teeth|tongue|facial", re.IGNORECASE)
_NECK = re.compile(r"neck", re.IGNORECASE)
_HEAD = re.compile(r"head", re.IGNORECASE)


def joint_classes(skeleton: Skeleton) -> tuple[str, ...]:
    """Each joint's class (a key of :data:`DEFAULT_DEGREES`, or ``"root"``), ``(J,)``.

    Structure first (the named feet and hands and the chains above them), then names for the
    parts structure cannot tell (neck, head, eyes, jaw, helper bones); the rest is spine.
    """
    n = skeleton.n_joints
    label: list[str | None] = [None] * n
    parents = skeleton.parents

    def up(j: int) -> int:
        return int(parents[j]) if j > 0 else -1

    for ankle, _toe in skeleton.feet().values():
        for k in skeleton.descendants(ankle):
            label[k] = "toe"
        label[ankle] = "ankle"
        for cls, k in zip(("knee", "hip"), (up(ankle), up(up(ankle)))):
            if k > 0:
                label[k] = cls
    for hand in skeleton.hands().values():
        for k in skeleton.descendants(hand):
            label[k] = "finger"
        label[hand] = "wrist"
        k = hand
        for cls in ("elbow", "shoulder", "girdle"):
            k = up(k)
            if k <= 0:
                break
            label[k] = cls
    head = next((j for j, name in enumerate(skeleton.names) if _HEAD.search(name) and "end" not in name.lower()), None)
    below_head = set(skeleton.descendants(head)) if head is not None else set()
    out = []
    for j, name in enumerate(skeleton.names):
        if j == 0:
            out.append("root")
        elif _HELPER.search(name):
            out.append("neck" if _NECK.search(name) else "helper")
        elif label[j] is not None:
            out.append(label[j])  # type: ignore[arg-type]
        elif _EYE.search(name):
            out.append("eye")
        elif _JAW.search(name):
            out.append("jaw")
        elif _NECK.search(name):
            out.append("neck")
        elif j == head or j in below_head:
            out.append("head")
        else:
            out.append("spine")
    return tuple(out)


def widening(name: str) -> Widening | None:
    """The :data:`WIDENED` entry for a joint name, or None (the first full match wins)."""
    return next((w for w in WIDENED if re.fullmatch(w.pattern, name)), None)


def joint_limits(skeleton: Skeleton) -> np.ndarray:
    """``(J,)`` largest rotation angle (radians) of each joint from its rest orientation.

    The class default (:data:`DEFAULT_DEGREES`), or the :data:`WIDENED` range where one matches
    the joint's name (never narrower than the default); ``inf`` for the root, at most π.
    """
    classes = joint_classes(skeleton)
    out = np.empty(skeleton.n_joints)
    for j, (name, cls) in enumerate(zip(skeleton.names, classes)):
        if cls == "root":
            out[j] = math.inf
            continue
        deg = DEFAULT_DEGREES[cls]
        w = widening(name)
        if w is not None:
            deg = max(deg, w.degrees)
        out[j] = math.radians(min(deg, 180.0))
    return out


def rotation_angles(rotations: np.ndarray) -> np.ndarray:
    """Rotation angle (radians, in [0, π]) of unit quaternions ``(..., 4)`` wxyz: ``(...)``."""
    return 2.0 * np.arctan2(rot.norm(rotations[..., 1:]), np.abs(rotations[..., 0]))


def violations(skeleton: Skeleton, rotations: np.ndarray, limits: np.ndarray | None = None) -> np.ndarray:
    """``(T, J)`` bool: joints turned beyond their range in ``rotations (T, J, 4)``."""
    lim = joint_limits(skeleton) if limits is None else np.asarray(limits, dtype=float)
    return rotation_angles(rotations) > lim[None, :]


#: Radians below a range's end where :func:`within` starts to ease a joint's angle in (10°): the angle
#: stays continuous and smooth and ends inside the range, and a joint that far inside is left as it is.
EASE = math.radians(10.0)


def within(skeleton: Skeleton, rotations: np.ndarray, limits: np.ndarray | None = None, ease: float = EASE) -> np.ndarray:
    """``rotations (T, J, 4)`` with every joint brought inside its range (``limits``, default
    :func:`joint_limits`). A joint that leaves its range in some frame has, in every frame, its rotation
    angle ``θ`` beyond ``a = limit − ease`` made ``a + ease·tanh((θ − a)/ease)``: below ``limit``, smooth
    in ``θ`` (no kink where it nears the end, which read as a pop), about the same axis. Angles under
    ``a``, and every joint that stays in range, are kept exactly (a clip in range comes back unchanged).
    Where an operation (a variation scaled in PCA space) would turn a joint past what a body can."""
    lim = joint_limits(skeleton) if limits is None else np.asarray(limits, dtype=float)
    q = np.array(rotations, dtype=float, copy=True)
    theta = rotation_angles(q)
    start = np.maximum(lim - ease, 0.0)[None, :]
    leaves = np.isfinite(lim) & (theta.max(axis=0, initial=0.0) > lim)
    over = leaves[None, :] & (theta > start)
    if not over.any():
        return q
    soft = np.minimum(ease, lim)[None, :]
    # (ending 1e-4 rad inside the range: an angle eased to its very end read as beyond it once written to BVH)
    eased = np.where(over, start + np.maximum(soft - 1e-4, 0.0) * np.tanh((theta - start) / np.where(soft > 0, soft, 1.0)), theta)
    v = q[..., 1:]
    n = rot.norm(v)
    sign = np.where(q[..., 0] < 0, -1.0, 1.0)  # (the same rotation with w ≥ 0: θ in [0, π])
    axis = sign[..., None] * v / np.where(n > 0, n, 1.0)[..., None]
    q[over, 0] = np.cos(eased[over] / 2)
    q[over, 1:] = np.sin(eased[over] / 2)[:, None] * axis[over]
    return q
