"""The bind pose: a standing T-pose of any skeleton, in which the character's surface is made.

A BVH rest pose (every rotation at identity) is a T-pose for some skeletons (CMU ASF, cgspeed
Daz, the bundled humanoid), arms down at the sides for others (cgspeed 3dsMax), and meaningless
for rigs whose joint frames are not aligned with the world (iClone's Character Creator rig: every
bone points up). The surface is meshed once, in one pose, so that pose must keep the limbs apart.

:func:`bind_rotations` starts from a base pose — the rest pose, or for a skeleton whose rest pose
does not stand (head above the hips, feet below them) the first standing frame of a clip — and
turns joints with the smallest rotations that aim them:

* the root so that the body stands up (hips → head along +z) and faces +x (right → left hip +y);
* each joint on the path from the root to the head so that its bone points up (+z);
* collar bones, upper arms, forearms and hands sideways (left +y, right -y): a T-pose;
* thighs and shanks down, splayed 5° so the legs do not touch;
* feet back to their base orientation relative to the body (flat if the base stood flat).

Everything else (hip joints, pelvis, toes, fingers, eyes, helper bones) keeps its base rotation.
A skeleton without a head and two feet found by name has no body plan to aim by: its bind pose
is its rest pose.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot
from ..errors import MjmotionError
from ..skeleton import Motion, Skeleton

#: Splay of the legs in the bind pose, radians from vertical.
LEG_SPLAY = np.radians(5.0)
_ARM = ("girdle", "upper_arm", "forearm", "hand")
_LEG = ("thigh", "shank")


def world_pose(skeleton: Skeleton, local: np.ndarray, root: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of one pose from its offsets (no position channels).

    Args:
        local: ``(J, 4)`` local rotations (the root's is its world orientation).
        root: ``(3,)`` root position; default the origin.
    Returns:
        ``(J, 3)`` world positions and ``(J, 4)`` world rotations.
    """
    n = skeleton.n_joints
    pos = np.zeros((n, 3))
    wrot = np.zeros((n, 4))
    for j in range(n):
        p = int(skeleton.parents[j])
        if p < 0:
            pos[j] = np.zeros(3) if root is None else root
            wrot[j] = local[j]
        else:
            pos[j] = pos[p] + rot.rotate(wrot[p], skeleton.offsets[j])
            wrot[j] = rot.multiply(wrot[p], local[j])
    return pos, rot.normalize(wrot)


def _head(skeleton: Skeleton) -> int | None:
    from ..mjcf import segments

    seg = segments(skeleton)
    heads = [j for j, s in enumerate(seg) if s == "head"]
    named = [j for j in heads if "head" in skeleton.names[j].lower()]
    found = named or heads
    return found[0] if found else None


def _hips(skeleton: Skeleton) -> tuple[int, int] | None:
    """The first thigh joint of the left and the right leg."""
    from ..mjcf import segments

    seg = segments(skeleton)
    feet = skeleton.feet()
    if set(feet) != {"left", "right"}:
        return None
    out = []
    for side in ("left", "right"):
        ankle = feet[side][0]
        chain = [ankle]
        while chain[-1] > 0:
            chain.append(int(skeleton.parents[chain[-1]]))
        thighs = [j for j in chain if seg[j] == "thigh"]
        out.append(thighs[-1] if thighs else chain[max(len(chain) - 2, 0)])
    return out[0], out[1]


def _standing(skeleton: Skeleton, positions: np.ndarray) -> bool:
    """Whether a pose stands: the head well above the hips and the ankles well below them."""
    head, hips, feet = _head(skeleton), _hips(skeleton), skeleton.feet()
    if head is None or hips is None:
        return False
    stature = max(skeleton.stature(), 1e-6)
    pelvis = positions[list(hips)].mean(axis=0)
    ankles = positions[[feet["left"][0], feet["right"][0]]]
    return bool(positions[head, 2] - pelvis[2] > 0.2 * stature and np.all(pelvis[2] - ankles[:, 2] > 0.25 * stature))


def base_rotations(skeleton: Skeleton, reference: Motion | None = None) -> np.ndarray:
    """``(J, 4)`` the pose the bind pose starts from: the rest pose if it stands, else the first
    standing frame of ``reference``.

    Raises :class:`MjmotionError` if neither stands.
    """
    rest = np.tile(rot.IDENTITY, (skeleton.n_joints, 1))
    if _standing(skeleton, world_pose(skeleton, rest)[0]):
        return rest
    if reference is not None:
        step = max(1, reference.n_frames // 200)
        for i in range(0, reference.n_frames, step):
            if _standing(skeleton, world_pose(skeleton, reference.rotations[i])[0]):
                return reference.rotations[i].copy()
    raise MjmotionError(
        "the skeleton's rest pose does not stand (head above the hips, feet below them)"
        + (" and no frame of the clip does" if reference is not None else "; give a clip whose frames do")
    )


def _min_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation (wxyz) taking direction ``a`` to direction ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = float(np.linalg.norm(axis))
    c = float(np.dot(a, b))
    if s < 1e-12:
        if c > 0:
            return rot.IDENTITY.copy()
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return np.array([0.0, *(perp / np.linalg.norm(perp))])
    return rot.exp(axis / s * np.arctan2(s, c))


def _toward(skeleton: Skeleton, j: int, goal: int | None) -> np.ndarray | None:
    """``(3,)`` local direction of ``j``'s bone: toward the child leading to ``goal`` if given,
    else the mean of its child and End Site offsets; ``None`` if it has no bone."""
    kids = skeleton.children(j)
    if goal is not None:
        on_path = [c for c in kids if c == goal or goal in skeleton.descendants(c)]
        if on_path and np.linalg.norm(skeleton.offsets[on_path[0]]) > 1e-9:
            return skeleton.offsets[on_path[0]]
    tips = [skeleton.offsets[c] for c in kids] + [skeleton.end_offsets[e] for e in np.flatnonzero(skeleton.end_parents == j)]
    tips = [t / np.linalg.norm(t) for t in tips if np.linalg.norm(t) > 1e-9]
    if not tips:
        return None
    mean = np.mean(tips, axis=0)
    return mean if np.linalg.norm(mean) > 1e-9 else tips[0]


def bind_rotations(skeleton: Skeleton, reference: Motion | None = None) -> np.ndarray:
    """``(J, 4)`` local rotations of the bind pose (see the module docstring)."""
    from ..mjcf import segments

    seg = segments(skeleton)
    head, hips = _head(skeleton), _hips(skeleton)
    if head is None or hips is None:
        return np.tile(rot.IDENTITY, (skeleton.n_joints, 1))  # no body plan to aim by: the rest pose as it is
    local = base_rotations(skeleton, reference)
    pos, wrot = world_pose(skeleton, local)
    feet = skeleton.feet()
    hands = skeleton.hands()
    # The root: hips → head up, right → left hip along +y.
    up = pos[head] - pos[list(hips)].mean(axis=0)
    lateral = pos[hips[0]] - pos[hips[1]]
    z = up / np.linalg.norm(up)
    y = lateral - np.dot(lateral, z) * z
    if np.linalg.norm(y) < 1e-9:
        y = np.cross(z, [1.0, 0.0, 0.0])
    y /= np.linalg.norm(y)
    frame = np.column_stack([np.cross(y, z), y, z])
    align = rot.from_matrix(frame.T)
    base_world = rot.multiply(align, wrot)  # every joint's base orientation, turned with the body
    local[0] = rot.multiply(align, local[0])
    spine = set(skeleton.chain(0, head))
    ankles = {feet[s][0]: s for s in feet}
    side_of = {}
    for side, h in hands.items():
        k = h
        while k > 0 and seg[k] in _ARM:
            side_of[k] = side
            k = int(skeleton.parents[k])
    for side, (ankle, _) in feet.items():
        k = ankle
        while k > 0 and seg[k] in (*_LEG, "foot"):
            side_of[k] = side
            k = int(skeleton.parents[k])
    wrot = np.zeros_like(local)
    for j in range(skeleton.n_joints):
        p = int(skeleton.parents[j])
        parent = rot.IDENTITY if p < 0 else wrot[p]
        world = rot.multiply(parent, local[j])
        target = goal = None
        sign = 1.0 if side_of.get(j) == "left" else -1.0
        if j in spine:
            target, goal = np.array([0.0, 0.0, 1.0]), head
        elif seg[j] in _ARM and j in side_of:
            target, goal = np.array([0.0, sign, 0.0]), (hands[side_of[j]] if seg[j] != "hand" else None)
        elif seg[j] in _LEG and j in side_of:
            target = np.array([0.0, sign * np.sin(LEG_SPLAY), -np.cos(LEG_SPLAY)])
            goal = feet[side_of[j]][0]
        if j in ankles:
            world = base_world[j]  # the foot as it was, relative to the turned body
        elif target is not None and (direction := _toward(skeleton, j, goal)) is not None:
            world = rot.multiply(_min_rotation(rot.rotate(world, direction), target), world)
        world = rot.normalize(world)
        local[j] = rot.multiply(rot.conjugate(parent), world)
        wrot[j] = world
    return rot.normalize(local)
