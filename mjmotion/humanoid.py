"""The bundled humanoid's skeleton, and how the judge knows it.

:func:`skeleton` is the 22-joint adult every bundled clip (:mod:`mjmotion.synth`) and
``models/humanoid.xml`` are made on. It lives here, outside the generators, because its feet are
known by design: :func:`bundled_scale` recognises it in a clip read back from BVH (the same joints
and bone proportions, at any size), so the judge (:mod:`mjmotion.feet`) stands it on the soles it
was made with (:func:`sole_depth`) instead of on the proportions measured on captured rigs.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .skeleton import CM, Skeleton

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")

#: Bone lengths of the bundled adult (≈ 1.75 m stature), metres.
THIGH = 0.44
SHIN = 0.42
UPPER_ARM = 0.28
FOREARM = 0.25
HAND = 0.17
HIP_WIDTH = 0.09  # half the distance between the hip joints
TOE_FORWARD = 0.14  # ankle → ball of the foot, along the foot
TOE_DROP = 0.06  # ankle → ball of the foot, down
TOE_TIP = 0.05  # ball of the foot → toe tip (the toe's End Site)


def _joint_table() -> list[tuple[str, str | None, tuple[float, float, float]]]:
    """``(name, parent, offset)`` in file order; offsets in the Z-up world, metres."""
    table: list[tuple[str, str | None, tuple[float, float, float]]] = [
        ("Hips", None, (0.0, 0.0, 1.0)),
        ("Spine", "Hips", (0.0, 0.0, 0.10)),
        ("Spine1", "Spine", (0.0, 0.0, 0.13)),
        ("Spine2", "Spine1", (0.0, 0.0, 0.13)),
        ("Neck", "Spine2", (0.0, 0.0, 0.16)),
        ("Head", "Neck", (0.0, 0.0, 0.10)),
    ]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        table += [
            (f"{side}Shoulder", "Spine2", (0.0, s * 0.03, 0.09)),
            (f"{side}Arm", f"{side}Shoulder", (0.0, s * 0.15, 0.0)),
            (f"{side}ForeArm", f"{side}Arm", (0.0, s * UPPER_ARM, 0.0)),
            (f"{side}Hand", f"{side}ForeArm", (0.0, s * FOREARM, 0.0)),
        ]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        table += [
            (f"{side}UpLeg", "Hips", (0.0, s * HIP_WIDTH, -0.06)),
            (f"{side}Leg", f"{side}UpLeg", (0.0, 0.0, -THIGH)),
            (f"{side}Foot", f"{side}Leg", (0.0, 0.0, -SHIN)),
            # The ball of the foot sits low and forward; the toe tip level with it (a flat sole).
            (f"{side}Toe", f"{side}Foot", (TOE_FORWARD, 0.0, -TOE_DROP)),
        ]
    return table


@lru_cache(maxsize=1)
def skeleton() -> Skeleton:
    """The bundled 22-joint humanoid (T-pose, facing +X; written as Y-up BVH in centimetres).

    Joints: Hips, Spine, Spine1, Spine2, Neck, Head; Left/Right Shoulder (clavicle), Arm,
    ForeArm, Hand; Left/Right UpLeg, Leg, Foot, Toe. End Sites on the head top, the hands'
    fingertips and the toe tips.
    """
    table = _joint_table()
    names = [n for n, _, _ in table]
    parents = [-1 if p is None else names.index(p) for _, p, _ in table]
    offsets = np.array([o for _, _, o in table])
    ends = [("Head", (0.0, 0.0, 0.13))]
    ends += [(f"{side}Hand", (0.0, s * HAND, 0.0)) for side, s in (("Left", 1.0), ("Right", -1.0))]
    ends += [(f"{side}Toe", (TOE_TIP, 0.0, 0.0)) for side in ("Left", "Right")]
    return Skeleton(
        names=tuple(names),
        parents=np.array(parents),
        offsets=offsets,
        channels=tuple(ROOT_CHANNELS if j == 0 else JOINT_CHANNELS for j in range(len(names))),
        end_parents=np.array([names.index(n) for n, _ in ends]),
        end_offsets=np.array([o for _, o in ends]),
        scale=CM,
        up="y",
    )


#: How closely a skeleton's bones must match the bundled ones' (relative to its stature) to be it.
SAME_BONES = 1e-4


def bundled_scale(skel: Skeleton) -> float | None:
    """The size of ``skel`` relative to the bundled humanoid when it *is* the bundled humanoid (the
    same joint names, parents and End Sites, every bone offset and End Site that size times the
    bundled one's within :data:`SAME_BONES` × stature, e.g. read back from a file ``synth``
    wrote, or rescaled); ``None`` for any other skeleton."""
    ref = skeleton()
    if skel.names != ref.names or not np.array_equal(skel.parents, ref.parents) or not np.array_equal(skel.end_parents, ref.end_parents):
        return None
    a = np.concatenate([ref.offsets[1:], ref.end_offsets]).ravel()  # the root's offset is where it stands, not a bone
    b = np.concatenate([skel.offsets[1:], skel.end_offsets]).ravel()
    s = float(a @ b / (a @ a))
    if not s > 0 or np.abs(b - s * a).max() > SAME_BONES * s * ref.stature():
        return None
    return s


def sole_depth(scale: float) -> float:
    """How far below its ankles the bundled humanoid at ``scale`` stands on a flat foot, metres:
    its toe joints and toe tips lie on the sole by design, and ``mjcf.compile``'s toe box reaches
    ``mjcf.TOE_BOX_HALF`` under them (``synth.foot_geometry`` measures the same through MuJoCo)."""
    from .mjcf import TOE_BOX_HALF

    return TOE_DROP * scale + TOE_BOX_HALF
