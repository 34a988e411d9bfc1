"""The bundled humanoid and the pieces every generator shares: NumPy forward kinematics,
analytic two-bone IK and the assembly of a :class:`~mjmotion.skeleton.Motion` from world-space
goals (pelvis, planted feet, hand targets) and local rotations (spine, head, free limbs).

World conventions as everywhere in mjmotion: Z up, metres, the character faces +X in its rest
pose, its left is +Y. The rest pose is a T-pose whose every body frame is aligned with the world,
so a bone's rest direction is simply its offset.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .. import rotations as rot
from ..skeleton import CM, Motion, Skeleton

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
            (f"{side}Toe", f"{side}Foot", (TOE_FORWARD, 0.0, -0.06)),
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


def joint(name: str) -> int:
    return skeleton().index(name)


@dataclass(frozen=True)
class FootGeometry:
    """Where the sole is, from the compiled model's foot geoms (so "planted" means on the floor).

    Attributes:
        ankle_height: ankle joint above the sole plane of a flat foot, metres.
        toe_height: ball-of-foot (toe) joint above the sole plane, metres.
    """

    ankle_height: float
    toe_height: float


@lru_cache(maxsize=1)
def foot_geometry() -> FootGeometry:
    """The sole plane of a flat foot: the lowest point of every geom on the foot and toe bodies
    (boxes and bone capsules) in the compiled rest pose, measured through MuJoCo."""
    import mujoco

    from .. import mjcf

    skel = skeleton()
    compiled = mjcf.compile(skel)
    m = compiled.model
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)
    ankle, toe = skel.feet()["left"]
    bodies = {int(compiled.body_ids[ankle]), int(compiled.body_ids[toe])}
    lowest = np.inf
    for g in range(m.ngeom):
        if int(m.geom_bodyid[g]) not in bodies:
            continue
        c, mat, size = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            low = c[2] - np.abs(mat[2]) @ size
        elif m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            low = c[2] - abs(mat[2, 2]) * size[1] - size[0]
        else:
            continue
        lowest = min(lowest, float(low))
    return FootGeometry(
        ankle_height=float(d.xpos[compiled.body_ids[ankle], 2] - lowest),
        toe_height=float(d.xpos[compiled.body_ids[toe], 2] - lowest),
    )


# --- rotations ---------------------------------------------------------------------------------
def axis_angle(axis: str, angle: np.ndarray | float) -> np.ndarray:
    """Quaternions ``(..., 4)`` rotating ``angle`` radians about the world/local ``axis`` (x, y or z)."""
    a = np.asarray(angle, dtype=float)
    q = np.zeros(a.shape + (4,))
    q[..., 0] = np.cos(a / 2)
    q[..., 1 + "xyz".index(axis)] = np.sin(a / 2)
    return q


def yaw(angle: np.ndarray | float) -> np.ndarray:
    return axis_angle("z", angle)


def compose(*qs: np.ndarray) -> np.ndarray:
    """``q1 ⊗ q2 ⊗ …`` (the last applied first), broadcasting."""
    out = qs[0]
    for q in qs[1:]:
        out = rot.multiply(out, q)
    return out


def frame_rotation(bone: np.ndarray, pole: np.ndarray, rest_bone: np.ndarray, rest_pole: np.ndarray) -> np.ndarray:
    """World rotations ``(T, 4)`` taking a segment's rest frame to the frame spanned by ``bone``
    (its direction, ``(T, 3)``) and ``pole`` (a direction to keep in its bending plane, ``(T, 3)``).

    ``rest_bone``/``rest_pole``: the same two directions in the rest pose ``(3,)``.
    """

    def frame(b: np.ndarray, p: np.ndarray) -> np.ndarray:
        b = b / np.linalg.norm(b, axis=-1, keepdims=True)
        p = p - np.sum(p * b, axis=-1, keepdims=True) * b
        p = p / np.linalg.norm(p, axis=-1, keepdims=True)
        return np.stack([b, p, np.cross(b, p)], axis=-1)

    f_world = frame(np.asarray(bone, dtype=float), np.asarray(pole, dtype=float))
    f_rest = frame(np.asarray(rest_bone, dtype=float)[None], np.asarray(rest_pole, dtype=float)[None])[0]
    return rot.from_matrix(f_world @ f_rest.T)


def two_bone_ik(root: np.ndarray, target: np.ndarray, l1: float, l2: float, pole: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Analytic two-bone IK: the middle joint (knee, elbow) for each frame.

    Args:
        root: ``(T, 3)`` hip/shoulder positions.
        target: ``(T, 3)`` desired ankle/wrist positions.
        l1, l2: bone lengths.
        pole: ``(T, 3)`` direction the middle joint bulges toward.

    Returns ``(middle (T, 3), end (T, 3), normal (T, 3))``: the end is ``target`` when
    reachable, else the nearest reachable point on the line from ``root`` to it; ``normal`` is
    the unit normal of the limb's bending plane (the hinge axis of the middle joint).
    """
    v = target - root
    d_raw = np.linalg.norm(v, axis=-1)
    u = v / np.maximum(d_raw, 1e-12)[:, None]
    d = np.clip(d_raw, abs(l1 - l2) + 1e-6, l1 + l2 - 1e-9)
    cos_a = np.clip((l1**2 + d**2 - l2**2) / (2 * l1 * d), -1.0, 1.0)
    w = pole - np.sum(pole * u, axis=-1, keepdims=True) * u
    w /= np.linalg.norm(w, axis=-1, keepdims=True)
    mid = root + l1 * (cos_a[:, None] * u + np.sqrt(1 - cos_a**2)[:, None] * w)
    return mid, root + d[:, None] * u, np.cross(u, w)


def forward_kinematics(root_positions: np.ndarray, local: np.ndarray, skel: Skeleton | None = None) -> tuple[np.ndarray, np.ndarray]:
    """World joint positions ``(T, J, 3)`` and rotations ``(T, J, 4)`` from root positions
    ``(T, 3)`` and local rotations ``(T, J, 4)`` (NumPy; independent of MuJoCo)."""
    skel = skel or skeleton()
    t, j_count = local.shape[:2]
    pos = np.empty((t, j_count, 3))
    wq = np.empty((t, j_count, 4))
    pos[:, 0] = root_positions
    wq[:, 0] = local[:, 0]
    for j in range(1, j_count):
        p = int(skel.parents[j])
        wq[:, j] = rot.multiply(wq[:, p], local[:, j])
        pos[:, j] = pos[:, p] + rot.rotate(wq[:, p], skel.offsets[j])
    return pos, wq


class PoseBuilder:
    """Fills a clip's local rotations top-down: torso first, then limbs from world-space goals.

    ``local`` starts at the identity; set torso rotations with :meth:`set_local`, call
    :meth:`update` to get world frames, then place legs and arms with :meth:`leg`/:meth:`arm`.
    """

    def __init__(self, n_frames: int, root_positions: np.ndarray):
        self.skel = skeleton()
        self.t = n_frames
        self.root = np.asarray(root_positions, dtype=float)
        self.local = np.broadcast_to(rot.IDENTITY, (n_frames, self.skel.n_joints, 4)).copy()
        self.world_pos: np.ndarray | None = None
        self.world_rot: np.ndarray | None = None

    def set_local(self, name: str, q: np.ndarray) -> None:
        self.local[:, joint(name)] = q

    def update(self) -> None:
        self.world_pos, self.world_rot = forward_kinematics(self.root, self.local)

    def pos(self, name: str) -> np.ndarray:
        assert self.world_pos is not None
        return self.world_pos[:, joint(name)]

    def wrot(self, name: str) -> np.ndarray:
        assert self.world_rot is not None
        return self.world_rot[:, joint(name)]

    def _set_world(self, name: str, world: np.ndarray) -> None:
        j = joint(name)
        parent = self.world_rot[:, self.skel.parents[j]]  # type: ignore[index]
        self.local[:, j] = rot.multiply(rot.conjugate(parent), world)
        self.world_rot[:, j] = world  # type: ignore[index]

    def leg(self, side: str, ankle: np.ndarray, foot_world: np.ndarray, toe_world: np.ndarray, pole: np.ndarray, planted: np.ndarray) -> np.ndarray:
        """Place a leg: ankle position ``(T, 3)``, foot and toe world rotations ``(T, 4)``, knee
        bulging toward ``pole (T, 3)``. Returns the reached ankle positions ``(T, 3)``.

        ``planted (T,)`` bool: frames whose foot keeps ``foot_world`` exactly (it stands on its
        footprint). In the other frames the ankle's rotation is held inside the judge's range
        (:func:`ankle_limited`), the toe turning with the foot.
        """
        hip = self.pos(f"{side}UpLeg")
        knee, reached, n = two_bone_ik(hip, ankle, THIGH, SHIN, pole)
        down, fwd = np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.0])
        # Each bone's pole is n × bone: in the bending plane, toward the bulge, never along the bone.
        self._set_world(f"{side}UpLeg", frame_rotation(knee - hip, np.cross(n, knee - hip), down, fwd))
        shin = frame_rotation(reached - knee, np.cross(n, reached - knee), down, fwd)
        self._set_world(f"{side}Leg", shin)
        local = rot.multiply(rot.conjugate(shin), foot_world)
        limited = ankle_limited(local, self.skel.index(f"{side}Foot"))
        # Only free frames the limit changes are recomputed: planted feet stay bit-exact on their plan.
        bent = ~np.asarray(planted, dtype=bool) & np.any(limited != local, axis=-1)
        foot, toe = foot_world.copy(), toe_world.copy()
        foot[bent] = rot.multiply(shin[bent], limited[bent])
        toe[bent] = rot.multiply(foot[bent], rot.multiply(rot.conjugate(foot_world[bent]), toe_world[bent]))
        self._set_world(f"{side}Foot", foot)
        self._set_world(f"{side}Toe", toe)
        return reached

    def arm(self, side: str, wrist: np.ndarray, pole: np.ndarray, hand_world: np.ndarray | None = None) -> np.ndarray:
        """Place an arm: wrist position ``(T, 3)``, elbow bulging toward ``pole (T, 3)``, hand world
        rotation ``(T, 4)`` (default: continuing the forearm). Returns the reached wrists."""
        s = 1.0 if side == "Left" else -1.0
        shoulder = self.pos(f"{side}Arm")
        elbow, reached, n = two_bone_ik(shoulder, wrist, UPPER_ARM, FOREARM, pole)
        out, back = np.array([0.0, s, 0.0]), np.array([-1.0, 0.0, 0.0])
        self._set_world(f"{side}Arm", frame_rotation(elbow - shoulder, np.cross(n, elbow - shoulder), out, back))
        fore = frame_rotation(reached - elbow, np.cross(n, reached - elbow), out, back)
        self._set_world(f"{side}ForeArm", fore)
        self._set_world(f"{side}Hand", fore if hand_world is None else hand_world)
        return reached

    def motion(self, fps: float, name: str) -> Motion:
        q = rot.make_continuous(rot.normalize(self.local), axis=0)
        return Motion(skeleton=self.skel, fps=float(fps), root_positions=self.root.copy(), rotations=q, name=name)


#: How far inside the judge's range a free foot's ankle stays (its rotation saturates at the range minus this).
ANKLE_MARGIN = np.radians(5.0)
#: The saturation starts this far below that ceiling (identity below it, so ordinary gaits are untouched).
ANKLE_KNEE = np.radians(12.0)


def ankle_limited(local: np.ndarray, ankle: int) -> np.ndarray:
    """Ankle local rotations ``(N, 4)`` (``local``, the same shape) with their angle smoothly saturated below the judge's
    range (:func:`mjmotion.limits.joint_limits`) of joint ``ankle``: unchanged up to
    ``range − ANKLE_MARGIN − ANKLE_KNEE``, then approaching ``range − ANKLE_MARGIN`` along a tanh
    (slope 1 at the knee, so the foot's motion stays smooth), about the same axis.

    A swinging foot whose sole the plan keeps level while the shin swings back and up (a run's
    heel kick, a kick's chamber) would otherwise bend the ankle 80–90°; limited, it follows the shin.
    """
    from ..limits import joint_limits

    ceiling = float(joint_limits(skeleton())[ankle]) - ANKLE_MARGIN
    knee = ceiling - ANKLE_KNEE
    r = rot.log(local)
    a = np.linalg.norm(r, axis=-1)
    over = a > knee
    limited = knee + ANKLE_KNEE * np.tanh((a - knee) / ANKLE_KNEE)
    return np.where(over[:, None], rot.exp(r * (limited / np.maximum(a, 1e-12))[:, None]), local)


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk blend ``10s³ − 15s⁴ + 6s⁵`` of ``s`` clipped to [0, 1] (zero speed and
    acceleration at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def reach_need(pb: PoseBuilder, ankles: dict[str, np.ndarray], reach: float = 0.99) -> np.ndarray:
    """``(T,)`` how far (m) the root must come down so that every leg reaches its ankle goal
    with at most ``reach`` of its length (negative: room to spare). Updates ``pb``'s frames."""
    pb.update()
    need = np.full(pb.t, -np.inf)
    limit = reach * (THIGH + SHIN)
    for side, ankle in ankles.items():
        d = ankle - pb.pos(f"{side}UpLeg")
        dh2 = np.sum(d[:, :2] ** 2, axis=1)
        need = np.maximum(need, -d[:, 2] - np.sqrt(np.maximum(limit**2 - dh2, 0.0)))
    return need


def lower_pelvis(pb: PoseBuilder, ankles: dict[str, np.ndarray], fps: float, reach: float = 0.99, constant: bool = False) -> None:
    """Lower the root smoothly wherever a leg would need more than ``reach`` of its length to get
    from its hip to ``ankles[side] (T, 3)``; updates ``pb``'s world frames.

    The needed drop is dilated by a ±3σ maximum filter before Gaussian smoothing, so the smooth
    drop is never smaller than the needed one. ``constant``: lower every frame by the largest
    need instead (keeps the shape of the height curve, e.g. a ballistic flight).
    """
    from scipy.ndimage import gaussian_filter1d, maximum_filter1d

    need = np.maximum(reach_need(pb, ankles, reach), 0.0)
    sigma = 0.06 * fps
    size = 2 * int(np.ceil(3 * sigma)) + 1
    if constant:
        drop = np.full(pb.t, need.max())
    else:
        drop = gaussian_filter1d(maximum_filter1d(need, size=size, mode="nearest"), sigma, mode="nearest", truncate=3.0)
    pb.root[:, 2] -= np.maximum(drop, 0.0)
    pb.update()
