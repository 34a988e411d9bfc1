"""Compile a :class:`~mjmotion.skeleton.Skeleton` to a MuJoCo model with ``mujoco.MjSpec``.

Each BVH joint becomes a body named exactly like the joint, carrying a **ball joint** (the root
a free joint). Ball joints, not hinge triplets: a BVH joint may list its Euler channels in any
order, and a quaternion ``qpos`` is that rotation exactly, with no gimbal lock and no order to
remember; per-joint freedoms (a 1-DOF elbow) are the IK layer's parametrisation, on top.
Joints that carry position channels also get three slide joints (x, y, z of the parent frame)
before the ball joint, so every BVH motion has a ``qpos``.

Geometry: a capsule along every bone (radius from its length), a box under each foot and toe
for ground contact, masses from one density chosen so the total is a realistic body mass for
the character's size. Body geoms collide with the floor, props' geoms and the ball, not with
each other. The world has a checker floor (z = 0), lights and a camera tracking the character.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from xml.etree import ElementTree

import mujoco
import numpy as np

from . import limits
from . import rotations as rot
from .caps import MAX_MODEL_JOINTS
from .errors import MjmotionError, is_real
from .skeleton import Skeleton

#: Names of the elements mjmotion adds; a skeleton may not use them for its joints.
FLOOR = "floor"
BALL = "ball"
TRACK_CAMERA = "track"
#: Body mass index used to give the character a realistic mass for its size (kg / m²).
BODY_MASS_INDEX = 21.5
#: Ankle joint centre above the sole in stance, × stature: measured on the shared rigs whose feet have
#: toe joints (ASF 0.047, iClone 0.049, cgspeed 3dsMax 0.049; median ankle height over stance frames
#: above the detected floor). A toe-less foot whose End Site is shallower (cgspeed daz: 3.7 cm below
#: the ankle, at the ball of the foot) gets its sole this deep, so it stands on the floor.
ANKLE_HEIGHT = 0.048
#: Least half thickness of a toe box, metres (a toe whose joint lies on the sole stands on this much box).
TOE_BOX_HALF = 0.008
#: Heel behind the ankle, × stature (foot length 0.152 × stature, the ankle about a fifth of it from the heel).
HEEL_BACK = 0.03
#: Foot geometry for :func:`compile`: per joint, box geoms ``{"foot/<side>" | "toe/<side>": (pos (3,),
#: quat (4,) wxyz, half_sizes (3,))}`` in that joint's body frame (world-aligned at rest).
FootBoxes = dict[int, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]]
#: Deepest joint chain ``compile`` accepts. MuJoCo's compile time grows with the cube of the chain
#: depth (measured: 200 deep 0.16 s, 400 deep 1.2 s, 1,000 deep 21 s), a human skeleton is < 40 deep.
MAX_DEPTH = 256


@dataclass(frozen=True)
class Prop:
    """A rigid stick held by a joint: a bat, a club, a racket handle.

    The prop's frame sits at the grip; its +z axis points from the grip to the head.

    Attributes:
        name: body and site prefix (``"club"``, ``"bat"``).
        joint: the skeleton joint that holds it.
        pos: ``(3,)`` grip position in the joint's body frame, metres.
        quat: ``(4,)`` wxyz orientation of the prop frame in the joint's body frame.
        length: grip to tip, metres.
        radius: shaft radius, metres.
        sweet_spot: distance from the grip to the sweet spot along +z, metres.
        mass: kg (used by the ball-launch simulation).
    """

    name: str
    joint: str
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    length: float = 1.0
    radius: float = 0.02
    sweet_spot: float = 0.9
    mass: float = 0.4

    def __post_init__(self) -> None:
        # (a negative length or a zero quaternion was taken; a NaN one failed in MuJoCo's compiler)
        if not isinstance(self.name, str) or not self.name or not isinstance(self.joint, str) or not self.joint:
            raise MjmotionError(f"Prop: name and joint must be non-empty strings, got {self.name!r} and {self.joint!r}")
        check_vector(f"Prop {self.name} pos", self.pos, 3, "metres")
        check_vector(f"Prop {self.name} quat", self.quat, 4, "wxyz")
        if float(np.linalg.norm(np.asarray(self.quat, dtype=float))) < 1e-9:
            raise MjmotionError(f"Prop {self.name} quat: expected a rotation (a non-zero quaternion), got {self.quat!r}")
        for label, value, unit in (("length", self.length, "metres"), ("radius", self.radius, "metres"), ("mass", self.mass, "kg")):
            _check_positive(f"Prop {self.name} {label}", value, unit)
        if not is_real(self.sweet_spot):
            raise MjmotionError(f"Prop {self.name} sweet_spot: expected a finite distance from the grip (metres), got {self.sweet_spot!r}")

    @property
    def site(self) -> str:
        """Name of the sweet-spot site (the effector)."""
        return f"{self.name}/sweet_spot"


#: Standard props: length, shaft radius, sweet spot from the grip, mass.
PROP_PRESETS: dict[str, dict[str, float]] = {
    "club": dict(length=1.10, radius=0.012, sweet_spot=1.06, mass=0.35),  # a driver-length golf club
    "bat": dict(length=0.86, radius=0.035, sweet_spot=0.68, mass=1.2),  # a cricket bat
}


@dataclass(frozen=True)
class Ball:
    """A free ball. ``radius`` in metres (cricket 0.036, golf 0.0214), ``mass`` in kg."""

    position: tuple[float, float, float] = (1.0, 0.0, 0.5)
    radius: float = 0.036
    mass: float = 0.16

    def __post_init__(self) -> None:
        # (a NaN position gave NaN hit metrics read as a hit, and 100,000 MuJoCo warnings in MUJOCO_LOG.TXT)
        check_vector("Ball position", self.position, 3, "metres")
        _check_positive("Ball radius", self.radius, "metres")
        _check_positive("Ball mass", self.mass, "kg")


def check_vector(label: str, value: object, n: int, unit: str) -> None:
    """Refuse ``value`` unless it is ``n`` finite numbers (an ``MjmotionError`` naming ``label`` and ``unit``)."""
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        v = np.zeros(0)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise MjmotionError(f"{label}: expected {n} finite numbers ({unit}), got {value!r}")


def _check_positive(label: str, value: object, unit: str) -> None:
    if not (is_real(value) and value > 0):  # type: ignore[operator]
        raise MjmotionError(f"{label}: expected a finite number > 0 ({unit}), got {value!r}")


@dataclass(frozen=True, eq=False)
class CompiledModel:
    """A compiled character model and the map from skeleton joints to ``qpos``.

    Attributes:
        skeleton: the source skeleton.
        spec: the ``MjSpec`` it was built from (writable to XML).
        model: the ``MjModel``.
        body_ids: ``(J,)`` body id of each joint.
        qpos_adr: ``(J,)`` ``qpos`` address of each joint's rotation (root: the free joint's
            quaternion; others: the ball joint).
        dof_adr: ``(J,)`` first ``qvel`` index of each joint's rotation (3 per joint).
        slide_adr: ``(J,)`` ``qpos`` address of the first of three slide joints, or -1.
        site_names: names of all sites (End Sites ``JOINT/end``, ``JOINT/end1``…, prop sites).
        props: the props compiled in.
        ball: the ball, if any; ``ball_qpos_adr`` its free joint's address.
    """

    skeleton: Skeleton
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    body_ids: np.ndarray
    qpos_adr: np.ndarray
    dof_adr: np.ndarray
    slide_adr: np.ndarray
    site_names: tuple[str, ...]
    props: tuple[Prop, ...] = ()
    ball: Ball | None = None
    ball_qpos_adr: int = -1
    foot_geoms: dict[str, tuple[int, ...]] = field(default_factory=dict)

    @property
    def body_geom_ids(self) -> np.ndarray:
        """Ids of the character's own geoms (bones and feet; not props, ball or floor)."""
        ids = set(int(b) for b in self.body_ids)
        gb = self.model.geom_bodyid
        return np.array([g for g in range(self.model.ngeom) if int(gb[g]) in ids], dtype=int)

    def site_id(self, name: str) -> int:
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        if i < 0:
            raise MjmotionError(f"no site named {name!r}; sites are: {', '.join(self.site_names[:12])}…")
        return int(i)

    def to_xml(self) -> str:
        """MJCF text that loads to the same kinematics.

        MuJoCo's writer keeps six significant digits; body and site frames are written again
        here at full precision so that joint and site positions are reproduced exactly.
        """
        root = ElementTree.fromstring(self.spec.to_xml())
        bodies = {b.name: b for b in self.spec.bodies}
        sites = {s.name: s for s in self.spec.sites}
        for el in root.iter("body"):
            b = bodies.get(el.get("name", ""))
            if b is not None:
                _set_vec(el, "pos", b.pos, default=(0.0, 0.0, 0.0))
                _set_vec(el, "quat", b.quat, default=(1.0, 0.0, 0.0, 0.0))
                if b.explicitinertial and el.find("inertial") is None:
                    # MuJoCo's writer drops explicit inertials; zero-length bones need theirs.
                    inertial = ElementTree.Element(
                        "inertial",
                        pos="0 0 0",
                        mass=repr(float(b.mass)),
                        diaginertia=" ".join(repr(float(x)) for x in b.inertia),
                    )
                    el.insert(0, inertial)
        for el in root.iter("site"):
            st = sites.get(el.get("name", ""))
            if st is not None:
                _set_vec(el, "pos", st.pos, default=(0.0, 0.0, 0.0))
        _skins_at_full_precision(root, self.spec)
        ElementTree.indent(root, "  ")
        return ElementTree.tostring(root, encoding="unicode") + "\n"

    def save_xml(self, path: str | os.PathLike[str]) -> None:
        from .outputs import write_text_atomic

        write_text_atomic(path, self.to_xml())


def _skins_at_full_precision(root: ElementTree.Element, spec: mujoco.MjSpec) -> None:
    """Skin vertices and bind frames as MuJoCo stores them (float32, 9 digits), not the writer's 6."""
    skins = {s.name: s for s in spec.skins}
    for el in root.iter("skin"):
        s = skins.get(el.get("name", ""))
        if s is None:
            continue
        el.set("vertex", _floats32(s.vert))
        for bone, pos, quat, w in zip(el.iter("bone"), np.reshape(s.bindpos, (-1, 3)), np.reshape(s.bindquat, (-1, 4)), s.vertweight):
            bone.set("bindpos", " ".join(repr(float(x)) for x in pos))
            bone.set("bindquat", " ".join(repr(float(x)) for x in quat))
            bone.set("vertweight", _floats32(w))


def _floats32(values: object) -> str:
    """The shortest text that reads back as the same float32 values."""
    return " ".join(np.format_float_positional(x, unique=True, trim="-") for x in np.asarray(values, dtype=np.float32))


def _set_vec(el: ElementTree.Element, attr: str, value: np.ndarray, default: tuple[float, ...]) -> None:
    v = np.asarray(value, dtype=float)
    if np.allclose(v, default, rtol=0.0, atol=0.0) and attr not in el.attrib:
        return
    el.set(attr, " ".join(repr(float(x)) for x in v))


def default_prop(skeleton: Skeleton, kind: str, joint: str) -> Prop:
    """A ``kind`` prop (``club`` or ``bat``) held at the end of ``joint``'s bone, along it.

    The grip sits where the bone ends (its first child or End Site in the rest pose) and the
    shaft continues the bone's direction. Fitting a club to both hands is
    :func:`mjmotion.hitpoint.fit_club`'s job; this is the plain one-hand attachment.
    """
    if kind not in PROP_PRESETS:
        raise MjmotionError(f"unknown prop {kind!r}; expected one of {', '.join(PROP_PRESETS)}")
    j = skeleton.index(joint)
    tips = [skeleton.offsets[c] for c in skeleton.children(j)]
    tips += [skeleton.end_offsets[e] for e in np.flatnonzero(skeleton.end_parents == j)]
    tips = [t for t in tips if np.linalg.norm(t) > 1e-6]
    if tips:
        tip = np.asarray(tips[0])
        direction = tip / np.linalg.norm(tip)
    else:
        tip = np.zeros(3)
        direction = np.array([0.0, 0.0, -1.0])
    quat = _quat_z_to(direction)
    return Prop(name=kind, joint=joint, pos=tuple(tip), quat=tuple(quat), **PROP_PRESETS[kind])  # type: ignore[arg-type]


def parse_prop_option(skeleton: Skeleton, text: str) -> Prop:
    """A prop from the CLI form ``KIND:JOINT`` (``club:lwrist``); ``KIND`` alone picks the right hand."""
    kind, _, joint = text.partition(":")
    if not joint:
        hands = skeleton.hands()
        if "right" not in hands:
            raise MjmotionError(f"--prop {text}: no right hand found by name; say which joint, e.g. {kind}:JOINT")
        joint = skeleton.names[hands["right"]]
    return default_prop(skeleton, kind, joint)


def _quat_z_to(direction: np.ndarray) -> np.ndarray:
    """Quaternion rotating +z onto the unit vector ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    axis = np.cross(z, d)
    s = np.linalg.norm(axis)
    if s < 1e-12:
        return np.array([1.0, 0, 0, 0]) if d[2] > 0 else np.array([0.0, 1.0, 0, 0])
    angle = np.arctan2(s, float(np.dot(z, d)))
    return rot.exp(axis / s * angle)


#: Segment mass fractions of the whole body (de Leva 1996, male; limbs per side, head with neck).
SEGMENT_MASS = {
    "head": 0.0694, "trunk": 0.4346, "upper_arm": 0.0271, "forearm": 0.0162, "hand": 0.0061,
    "thigh": 0.1416, "shank": 0.0433, "foot": 0.0137,
}  # fmt: skip
#: Capsule radius of each segment's bones, metres for a 1.75 m stature (shoulder girdle and neck thinner).
SEGMENT_RADIUS = {
    "head": 0.085, "neck": 0.05, "girdle": 0.05, "trunk": 0.10, "upper_arm": 0.045, "forearm": 0.037,
    "hand": 0.025, "thigh": 0.07, "shank": 0.05, "foot": 0.03,
}  # fmt: skip
_LIMB = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot", "head")


def segments(skeleton: Skeleton) -> list[str]:
    """Each joint's body segment (the bones hanging from it belong to it).

    Found from the named hands, feet and head: a hand's joint and everything below it is
    ``hand``, its parent ``forearm``, the next ``upper_arm`` and the one above that the shoulder
    ``girdle`` (trunk mass); likewise ``foot``/``shank``/``thigh`` from the ankle. ``head`` is
    the head and neck joints and below. Helper bones (twists) take their parent's segment;
    everything else is ``trunk``.
    """
    label: list[str | None] = [None] * skeleton.n_joints

    def mark_subtree(j: int, name: str) -> None:
        for k in [j, *skeleton.descendants(j)]:
            label[k] = name

    for j, n in enumerate(skeleton.names):
        low = n.lower()
        if ("head" in low or "neck" in low) and "end" not in low and label[j] is None:
            mark_subtree(j, "head")
            if "neck" in low:
                label[j] = "neck"
    for chain_start, names in (
        ([h for h in skeleton.hands().values()], ("hand", "forearm", "upper_arm", "girdle")),
        ([a for a, _ in skeleton.feet().values()], ("foot", "shank", "thigh")),
    ):
        for j in chain_start:
            mark_subtree(j, names[0])
            k = j
            for seg in names[1:]:
                k = int(skeleton.parents[k])
                if k <= 0:
                    break
                label[k] = seg
    out: list[str] = []
    for j in range(skeleton.n_joints):
        lab = label[j]
        if lab is None:
            p = int(skeleton.parents[j])
            above = label[p] if p >= 0 else None
            lab = above if above is not None and above in _LIMB else "trunk"
            label[j] = lab
        out.append(lab)
    return out


def _mass_class(segment: str) -> str:
    return {"neck": "head", "girdle": "trunk"}.get(segment, segment)


def mat_quat(m: np.ndarray) -> np.ndarray:
    """The unit quaternion (w ≥ 0) of a rotation matrix ``(3, 3)``, by MuJoCo (SciPy's import costs ~0.3 s)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(m, dtype=float).ravel())
    return rot.positive_w(q)


def _look_quat(forward: np.ndarray) -> np.ndarray:
    """Orientation of a camera looking along ``forward`` with the world's +z up (cameras look along -z)."""
    z = -forward / np.linalg.norm(forward)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    return mat_quat(np.column_stack([x, np.cross(z, x), z]))


def check_model_size(skeleton: Skeleton) -> None:
    """Refuse a skeleton deeper than :data:`MAX_DEPTH` or with more joints than ``caps.MAX_MODEL_JOINTS``
    (what :func:`compile` refuses; the verbs check each clip as it is read, naming its file)."""
    depth = np.zeros(skeleton.n_joints, dtype=int)
    for j in range(1, skeleton.n_joints):
        depth[j] = depth[skeleton.parents[j]] + 1
    if depth.max() + 1 > MAX_DEPTH:
        raise MjmotionError(
            f"skeleton is {depth.max() + 1} joints deep (joint {skeleton.names[int(depth.argmax())]!r}); "
            f"MuJoCo models are limited to {MAX_DEPTH} nested bodies here (compile time grows with the "
            "cube of the depth) — is this a character skeleton?"
        )
    if skeleton.n_joints > MAX_MODEL_JOINTS:
        raise MjmotionError(
            f"skeleton has {skeleton.n_joints} joints; MuJoCo models are limited to {MAX_MODEL_JOINTS} joints here "
            "(compile time grows faster than the joint count) — is this a character skeleton?"
        )


def compile(
    skeleton: Skeleton,
    props: tuple[Prop, ...] | list[Prop] = (),
    ball: Ball | None = None,
    total_mass: float | None = None,
    actuators: bool = False,
    foot_boxes: FootBoxes | None = None,
) -> CompiledModel:
    """Build and compile the MuJoCo model of ``skeleton`` with optional props and a ball.

    The initial pose (``qpos0``) is the rest pose standing on the floor: its lowest geom at z = 0.

    Args:
        skeleton: the character.
        props: sticks attached to joints (see :class:`Prop`).
        ball: a free ball, or ``None``.
        total_mass: the character's mass in kg; default ``BODY_MASS_INDEX × height²``.
        actuators: add a position servo per joint degree of freedom (see :func:`add_actuators`).
        foot_boxes: the feet's box geoms instead of those built from the rest pose (e.g. the judge's
            soles calibrated on a clip: :func:`mjmotion.feet.judged_model`).
    """
    check_model_size(skeleton)
    if not all(isinstance(p, Prop) for p in props) or isinstance(props, Prop):
        raise MjmotionError(f"props: expected a list of mjcf.Prop, got {props!r}")
    names = [p.name for p in props]
    if len(set(names)) != len(names):  # (MuJoCo's "repeated name 'club'")
        raise MjmotionError(f"props: two props named {next(n for n in names if names.count(n) > 1)!r}; give each prop its own name")
    if ball is not None and not isinstance(ball, Ball):
        raise MjmotionError(f"ball: expected an mjcf.Ball, got {ball!r}")
    # "world": MuJoCo's own body 0, which every model has.
    reserved = {"world", FLOOR, BALL} | set(names)
    clash = reserved.intersection(skeleton.names)
    if clash:
        raise MjmotionError(
            f"joint name(s) {sorted(clash)} clash with names the MuJoCo model uses (MuJoCo's world body, mjmotion's floor, ball and props); rename the joint"
        )
    height = float(np.clip(skeleton.stature(), 0.3, 3.0))
    mass = total_mass if total_mass is not None else BODY_MASS_INDEX * height**2
    spec = mujoco.MjSpec()
    spec.modelname = "mjmotion"
    spec.option.timestep = 0.002
    add_world(spec)
    bodies: list[mujoco.MjsBody] = []
    site_names: list[str] = []
    foot_geoms: dict[str, list[str]] = {}
    feet = skeleton.feet()
    foot_boxes = _foot_boxes(skeleton, feet) if foot_boxes is None else _checked_boxes(skeleton, foot_boxes)
    ankles = {a for a, _ in feet.values()}
    segment_of = segments(skeleton)
    # Joint ranges (mjmotion/limits.py): the largest rotation from rest, in the compiler's angle unit.
    ranges = limits.joint_limits(skeleton)
    to_unit = np.degrees if spec.compiler.degree else (lambda x: x)
    volumes: dict[str, float] = {}
    class_geoms: dict[str, list[mujoco.MjsGeom]] = {}
    for j, name in enumerate(skeleton.names):
        parent = spec.worldbody if j == 0 else bodies[int(skeleton.parents[j])]
        body = parent.add_body(name=name, pos=[0.0, 0.0, 0.0] if j == 0 else skeleton.offsets[j].tolist())
        bodies.append(body)
        if j == 0:
            body.add_freejoint(name=name)
            body.add_camera(
                name=TRACK_CAMERA,
                mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM,
                pos=[0.0, -4.0 * height / 1.75, 0.3],
                quat=_look_quat(np.array([0.0, 1.0, -0.05])).tolist(),
            )
        else:
            if skeleton.has_positions(j):
                for axis, label in zip(np.eye(3), "xyz"):
                    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, name=f"{name}/slide_{label}", axis=axis.tolist())
            body.add_joint(
                type=mujoco.mjtJoint.mjJNT_BALL, name=name, limited=mujoco.mjtLimited.mjLIMITED_TRUE, range=[0.0, float(to_unit(ranges[j]))]
            )
        tips = [(skeleton.offsets[c], None) for c in skeleton.children(j)]
        ends = np.flatnonzero(skeleton.end_parents == j)
        for k, e in enumerate(ends):
            site = f"{name}/end" if k == 0 else f"{name}/end{k}"
            body.add_site(name=site, pos=skeleton.end_offsets[e].tolist(), size=[0.01, 0, 0], group=3)
            site_names.append(site)
            tips.append((skeleton.end_offsets[e], None))
        n_geoms = 0
        seg = segment_of[j]
        radius = SEGMENT_RADIUS[seg] * height / 1.75
        for c, (tip, _) in zip(skeleton.children(j) + [-1] * len(ends), tips):
            length = float(np.linalg.norm(tip))
            if length < 0.01 * height / 1.75 or seg == "foot":
                continue  # the foot's boxes are its geometry: bone capsules would poke through the sole
            if j == 0 and length > 0.35 * height:
                # An armature root on the floor (iClone's RL_BoneRoot) is not a body segment.
                continue
            r = min(radius, 0.5 * length) if seg in ("hand", "head", "neck") else radius
            end = np.asarray(tip, dtype=float)
            if c in ankles:
                # The shank's end cap stops at the ankle instead of reaching a radius past it (below the sole).
                end = end * max(length - r, 0.5 * length) / length
            geom = body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0.0, 0.0, 0.0, *end.tolist()],
                size=[r, 0, 0],
                contype=1,
                conaffinity=0,
                rgba=[0.75, 0.6, 0.5, 1.0],
                group=1,
            )
            float_len = float(np.linalg.norm(end))
            volumes[_mass_class(seg)] = volumes.get(_mass_class(seg), 0.0) + np.pi * r * r * float_len + 4.0 / 3.0 * np.pi * r**3
            class_geoms.setdefault(_mass_class(seg), []).append(geom)
            n_geoms += 1
        for label, (pos, quat, half) in foot_boxes.get(j, {}).items():
            geom = body.add_geom(
                name=label,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=pos.tolist(),
                quat=quat.tolist(),
                size=half.tolist(),
                contype=1,
                conaffinity=0,
                rgba=[0.3, 0.3, 0.35, 1.0],
                group=1,
            )
            foot_geoms.setdefault(label.split("/")[1], []).append(label)
            volumes["foot"] = volumes.get("foot", 0.0) + 8.0 * float(np.prod(half))
            class_geoms.setdefault("foot", []).append(geom)
            n_geoms += 1
        if n_geoms == 0:
            # A zero-length bone (a hip joint, a twist bone): a tiny explicit inertia keeps MuJoCo valid.
            body.mass = 1e-4
            body.inertia = [1e-8, 1e-8, 1e-8]
            body.explicitinertial = True
    for prop in props:
        j = skeleton.index(prop.joint)
        pb = bodies[j].add_body(name=prop.name, pos=list(prop.pos), quat=list(prop.quat))
        pb.add_geom(
            name=prop.name,
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.0, 0.0, 0.0, 0.0, 0.0, prop.length],
            size=[prop.radius, 0, 0],
            contype=1,
            conaffinity=0,
            mass=prop.mass,
            rgba=[0.55, 0.35, 0.15, 1.0],
        )
        for sname, z in (("grip", 0.0), ("sweet_spot", prop.sweet_spot), ("tip", prop.length)):
            pb.add_site(name=f"{prop.name}/{sname}", pos=[0.0, 0.0, z], size=[0.015, 0, 0], rgba=[1, 0.9, 0.1, 1])
            site_names.append(f"{prop.name}/{sname}")
    if ball is not None:
        bb = spec.worldbody.add_body(name=BALL, pos=list(ball.position))
        bb.add_freejoint(name=BALL)
        bb.add_geom(
            name=BALL,
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[ball.radius, 0, 0],
            mass=ball.mass,
            contype=1,
            conaffinity=1,
            rgba=[0.85, 0.1, 0.1, 1.0],
        )
    # One density per segment so segment masses follow de Leva's fractions (absent segments' share
    # is spread over the rest): mass distribution drives the inverse-dynamics residuals.
    present = {c: SEGMENT_MASS[c] * (1 if c in ("head", "trunk") else 2) for c in class_geoms}
    scale = 1.0 / sum(present.values()) if present else 0.0
    for cls, geoms in class_geoms.items():
        density = mass * present[cls] * scale / max(volumes[cls], 1e-12)  # (a segment of zero-length bones: its spheres)
        for g in geoms:
            g.density = density
    model = spec.compile()
    _stand(spec, model, bodies[0], skeleton)
    compiled = _index(skeleton, spec, model, tuple(site_names), tuple(props), ball, foot_geoms)
    return add_actuators(compiled) if actuators else compiled


def add_world(spec: mujoco.MjSpec) -> None:
    """The shared stage: checker floor at z = 0, key and fill lights, headlight, offscreen size."""
    spec.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.22, 0.26, 0.30],
        rgb2=[0.17, 0.20, 0.24],
        width=512,
        height=512,
        mark=mujoco.mjtMark.mjMARK_EDGE,
        markrgb=[0.45, 0.5, 0.55],
    )
    mat = spec.add_material(name="grid", texrepeat=[1, 1], texuniform=True, reflectance=0.05)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.worldbody.add_geom(
        name=FLOOR,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 0.05],
        material="grid",
        contype=0,
        conaffinity=1,
    )
    spec.worldbody.add_light(name="key", pos=[2.0, -2.0, 5.0], dir=[-0.3, 0.3, -1.0], castshadow=True)
    spec.worldbody.add_light(name="fill", pos=[-3.0, 3.0, 4.0], dir=[0.5, -0.5, -1.0], castshadow=False)
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.global_.offwidth = 1920
    spec.visual.global_.offheight = 1080


def _checked_boxes(skeleton: Skeleton, boxes: FootBoxes) -> FootBoxes:
    """``boxes`` if every key is a foot joint and every label ``foot/<side>`` or ``toe/<side>``."""
    feet = skeleton.feet()
    joints = {j for a, t in feet.values() for j in (a, t) if j is not None}
    for j, named in boxes.items():
        for label in named:
            kind, _, side = label.partition("/")
            if j not in joints or kind not in ("foot", "toe") or side not in feet:
                raise MjmotionError(f"compile: foot box {label!r} on joint {j} is not a foot or toe box of {sorted(feet)} feet")
    return boxes


def _foot_boxes(skeleton: Skeleton, feet: dict[str, tuple[int, int | None]]) -> FootBoxes:
    """Per joint, box geoms ``{name: (pos, quat, half_sizes)}`` in that joint's body frame.

    Built in the rest pose, where body frames are aligned with the world: the box runs from a
    heel behind the ankle to the toe tip, its sole at the lowest toe point along the
    skeleton's rest "up" (feet → head; a rest pose need not be upright).
    """
    if not feet:
        return {}
    rest = skeleton.rest_positions()
    ends = skeleton.rest_end_positions()
    height = float(np.clip(skeleton.stature(), 0.3, 3.0))
    ankles = np.array([rest[a] for a, _ in feet.values()])
    head = _head_position(skeleton, rest)
    up = head - ankles.mean(axis=0)
    if np.linalg.norm(up) < 1e-9:
        return {}
    up /= np.linalg.norm(up)
    out: dict[int, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
    for side, (ankle, toe) in feet.items():
        # The toe tip: the farthest End Site or joint below the ankle.
        below = skeleton.descendants(ankle)
        pts = [rest[c] for c in below] + [ends[e] for e in range(len(ends)) if skeleton.end_parents[e] in below + [ankle]]
        if not pts:
            continue
        pts_arr = np.asarray(pts)
        a = rest[ankle]
        horiz = (pts_arr - a) - np.outer((pts_arr - a) @ up, up)
        tip = pts_arr[int(np.argmax(np.linalg.norm(horiz, axis=1)))]
        fwd = (tip - a) - np.dot(tip - a, up) * up
        flen = float(np.linalg.norm(fwd))
        if flen < 1e-6:
            continue
        fwd /= flen
        side_axis = np.cross(up, fwd)
        frame = np.column_stack([fwd, side_axis, up])
        quat = mat_quat(frame)
        sole = min(float(np.dot(p - a, up)) for p in pts_arr)
        heel = 0.25 * flen
        if toe is None and -sole < ANKLE_HEIGHT * height:
            # A foot chain that stops at the ball of the foot: the sole and heel from foot proportions.
            sole, heel = -ANKLE_HEIGHT * height, max(heel, HEEL_BACK * height)
        top = min(0.0, sole + 0.09 * height / 1.75)
        half_w = 0.045 * height / 1.75
        if toe is None:
            lo, hi = -heel, flen
            center = a + fwd * (lo + hi) / 2 + up * (sole + top) / 2
            half = np.array([(hi - lo) / 2, half_w, max((top - sole) / 2, 0.01)])
            out.setdefault(ankle, {})[f"foot/{side}"] = (center - a, quat, half)
        else:
            t = rest[toe]
            tdist = float(np.dot(t - a, fwd))
            lo, hi = -0.25 * flen, tdist
            center = a + fwd * (lo + hi) / 2 + up * (sole + top) / 2
            half = np.array([max((hi - lo) / 2, 0.01), half_w, max((top - sole) / 2, 0.01)])
            out.setdefault(ankle, {})[f"foot/{side}"] = (center - a, quat, half)
            t_sole = float(np.dot(a - t, up)) + sole  # the same sole plane, from the toe
            t_top = min(0.0, t_sole + 0.04 * height / 1.75)
            tlen = max(flen - tdist, 0.02)
            center_t = t + fwd * tlen / 2 + up * (t_sole + t_top) / 2
            half_t = np.array([tlen / 2, half_w, max((t_top - t_sole) / 2, TOE_BOX_HALF)])
            out.setdefault(toe, {})[f"toe/{side}"] = (center_t - t, quat, half_t)
    return out


def _head_position(skeleton: Skeleton, rest: np.ndarray) -> np.ndarray:
    for j, n in enumerate(skeleton.names):
        if "head" in n.lower() and "end" not in n.lower():
            return rest[j]
    # No head by name: the joint farthest from the feet along the spine is as good.
    return rest[int(np.argmax(np.linalg.norm(rest - rest[0], axis=1)))]


def _index(
    skeleton: Skeleton,
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    site_names: tuple[str, ...],
    props: tuple[Prop, ...],
    ball: Ball | None,
    foot_geoms: dict[str, list[str]],
) -> CompiledModel:
    j_count = skeleton.n_joints
    body_ids = np.empty(j_count, dtype=int)
    qpos_adr = np.empty(j_count, dtype=int)
    dof_adr = np.empty(j_count, dtype=int)
    slide_adr = np.full(j_count, -1, dtype=int)
    for j, name in enumerate(skeleton.names):
        body_ids[j] = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        adr = int(model.jnt_qposadr[jid])
        qpos_adr[j] = adr + 3 if j == 0 else adr
        dof_adr[j] = int(model.jnt_dofadr[jid]) + (3 if j == 0 else 0)
        if j > 0 and skeleton.has_positions(j):
            sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{name}/slide_x")
            slide_adr[j] = int(model.jnt_qposadr[sid])
    ball_adr = -1
    if ball is not None:
        ball_adr = int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, BALL)])
    geoms = {side: tuple(int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n)) for n in names) for side, names in foot_geoms.items()}
    return CompiledModel(
        skeleton=skeleton,
        spec=spec,
        model=model,
        body_ids=body_ids,
        qpos_adr=qpos_adr,
        dof_adr=dof_adr,
        slide_adr=slide_adr,
        site_names=site_names,
        props=props,
        ball=ball,
        ball_qpos_adr=ball_adr,
        foot_geoms=geoms,
    )


# --- a model a MuJoCo user can open: standing, a keyframe, servos, a skin ---------------------
#: Natural frequency (Hz) and damping ratio of the joint servos :func:`add_actuators` adds.
SERVO_HZ = 25.0
SERVO_DAMPING = 1.0
#: Armature of every actuated degree of freedom, kg·m² per kg of body mass for a 1.75 m character.
SERVO_ARMATURE = 2e-4


def lowest_point(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray | list[int]) -> float:
    """The lowest world z of ``geoms`` at ``data``'s kinematics (capsules, boxes, spheres, cylinders,
    ellipsoids exactly; other types by their bounding sphere)."""
    low = np.inf
    g_type = mujoco.mjtGeom
    for g in geoms:
        z, m22 = float(data.geom_xpos[g, 2]), data.geom_xmat[g].reshape(3, 3)[2]
        size, kind = model.geom_size[g], int(model.geom_type[g])
        if kind == g_type.mjGEOM_CAPSULE:
            reach = abs(m22[2]) * size[1] + size[0]
        elif kind == g_type.mjGEOM_BOX:
            reach = float(np.abs(m22) @ size)
        elif kind == g_type.mjGEOM_SPHERE:
            reach = size[0]
        elif kind == g_type.mjGEOM_CYLINDER:
            reach = abs(m22[2]) * size[1] + size[0] * np.sqrt(max(0.0, 1.0 - m22[2] ** 2))
        elif kind == g_type.mjGEOM_ELLIPSOID:
            reach = float(np.linalg.norm(m22 * size))
        else:
            reach = float(model.geom_rbound[g])
        low = min(low, z - reach)
    return float(low)


def character_geoms(model: mujoco.MjModel, root_body: int) -> np.ndarray:
    """Ids of the geoms on the skeleton's own bodies under ``root_body`` (props and their bodies excluded)."""
    body = model.geom_bodyid
    return np.flatnonzero((model.body_rootid[body] == root_body) & (model.body_jntnum[body] > 0))


def _stand(spec: mujoco.MjSpec, model: mujoco.MjModel, root: mujoco.MjsBody, skeleton: Skeleton) -> None:
    """Lift the rest pose (``qpos0``) so its lowest geom touches the floor.

    The free joint's ``qpos0`` is the root body's position, so the spec's root moves up; the
    compiled model's copies (``body_pos``, ``qpos0``, ``qpos_spring``) are set to what compiling
    again would give, which saves a second compile on every call.
    """
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, skeleton.names[0])
    geoms = character_geoms(model, bid)
    if len(geoms) == 0:
        return
    lift = -lowest_point(model, d, geoms)
    root.pos = [0.0, 0.0, lift]
    adr = int(model.jnt_qposadr[model.body_jntadr[bid]])
    model.body_pos[bid] = root.pos
    model.qpos0[adr + 2] = lift
    model.qpos_spring[adr + 2] = lift


def _recompiled(compiled: CompiledModel, spec: mujoco.MjSpec) -> CompiledModel:
    """``compiled`` with ``spec`` (an edited copy of its spec) compiled in; the input is untouched."""
    return dataclasses.replace(compiled, spec=spec, model=spec.compile())


def add_actuators(
    compiled: CompiledModel,
    neutral: np.ndarray | None = None,
    hz: float = SERVO_HZ,
    damping: float = SERVO_DAMPING,
    armature: float = SERVO_ARMATURE,
) -> CompiledModel:
    """A position servo per joint degree of freedom (the free root stays unactuated).

    A ball joint gets three position actuators on a ``site`` transmission with a ``refsite``:
    MuJoCo's actuator length is then the rotation vector (axis × angle) of the child's frame
    relative to a reference frame fixed in the parent, so the three are a servo on the joint's
    rotation away from a neutral pose (``neutral[j]``, its local rotation), with no gimbal lock and
    the ball-joint model (and ``qpos``) the rest of the lab uses. A rotation vector wraps at 180°:
    a ``joint`` transmission measures from the joint's zero, and rigs whose captured poses sit
    ~180° from their rest frames (iClone's thighs, eyes and teeth) would flip; measured from a
    standing neutral pose (the skin's bind pose) they stay far from it. Slide joints get one
    ``joint`` servo each. A pose's controls are its actuator lengths (:func:`add_keyframe` sets them).

    Gains scale with the inertia each joint moves: ``kp = I ω²``, ``kv = 2 ζ I ω``, ``I`` the
    joint-space mass matrix diagonal in the rest pose (the segment and everything distal to it, plus
    an armature of ``armature × body mass × (stature / 1.75 m)²`` that keeps fingers and helper
    bones from being so light that contacts make them unstable), so every joint has the natural
    frequency ``hz`` and damping ratio ``damping``. The integrator becomes ``implicitfast``, which
    treats the servos' damping implicitly.

    Args:
        neutral: ``(J, 4)`` local rotations the servos measure from; default the rest pose.
    """
    skel, spec = compiled.skeleton, compiled.spec.copy()
    neutral = np.tile(rot.IDENTITY, (skel.n_joints, 1)) if neutral is None else rot.normalize(neutral)
    total = float(compiled.model.body_mass[compiled.body_ids].sum())
    rotor = armature * total * (float(np.clip(skel.stature(), 0.3, 3.0)) / 1.75) ** 2
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_FREE:
            joint.armature = rotor
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    mass = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass)
    omega = 2.0 * np.pi * hz

    def servo(label: str, inertia: float, **transmission: object) -> None:
        act = spec.add_actuator(name=label, **transmission)
        act.set_to_position(kp=inertia * omega**2, kv=2.0 * damping * inertia * omega)

    for j, name in enumerate(skel.names):
        if j == 0:
            continue
        child, parent = spec.body(name), spec.body(skel.names[int(skel.parents[j])])
        child.add_site(name=f"{name}/servo", group=5)
        parent.add_site(name=f"{name}/servo_ref", pos=skel.offsets[j].tolist(), quat=neutral[j].tolist(), group=5)
        for k in range(3):
            gear = [0.0, 0.0, 0.0, *np.eye(3)[k]]
            inertia = float(mass[compiled.dof_adr[j] + k, compiled.dof_adr[j] + k])
            servo(f"{name}/{'xyz'[k]}", inertia, target=f"{name}/servo", refsite=f"{name}/servo_ref", trntype=mujoco.mjtTrn.mjTRN_SITE, gear=gear)
        if compiled.slide_adr[j] >= 0:
            for label in "xyz":
                jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{name}/slide_{label}")
                dof = int(m.jnt_dofadr[jid])
                servo(f"{name}/slide_{label}", float(mass[dof, dof]), target=f"{name}/slide_{label}", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    return _recompiled(compiled, spec)


def add_keyframe(compiled: CompiledModel, qpos: np.ndarray, name: str = "start", drop: bool = True) -> CompiledModel:
    """The pose ``qpos: (nq,)`` as a keyframe, moved up or down so its lowest character geom is on
    the floor (``drop=False``: where it is, e.g. already placed on a judged floor); with servos, its
    controls hold that pose (``mj_resetDataKeyframe`` loads both)."""
    m = compiled.model
    q = np.array(qpos, dtype=float)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    if drop:
        q[2] -= lowest_point(m, d, character_geoms(m, int(compiled.body_ids[0])))
    spec = compiled.spec.copy()
    key = spec.add_key(name=name, qpos=q.tolist())
    if m.nu:
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        key.ctrl = d.actuator_length.tolist()
    return _recompiled(compiled, spec)


def add_skin(
    spec: mujoco.MjSpec,
    vertices: np.ndarray,
    faces: np.ndarray,
    bodies: list[str] | tuple[str, ...],
    bind_positions: np.ndarray,
    bind_rotations: np.ndarray,
    bones: np.ndarray,
    weights: np.ndarray,
    name: str = "skin",
    rgba: tuple[float, float, float, float] = (0.75, 0.6, 0.5, 1.0),
    inflate: float = 0.0,
) -> mujoco.MjsSkin:
    """Add a MuJoCo skin (drawn, not simulated) to ``spec``.

    Args:
        vertices: ``(V, 3)`` bind-pose positions; faces: ``(F, 3)`` counter-clockwise from outside.
        bodies: ``(N,)`` names of the bodies the skin follows.
        bind_positions, bind_rotations: ``(N, 3)``, ``(N, 4)`` those bodies' frames in the bind pose.
        bones, weights: ``(V, K)`` index into ``bodies`` (``-1`` unused) and weight of each influence.
    """
    skin = spec.add_skin(name=name)
    skin.vert = np.asarray(vertices, dtype=float).ravel().tolist()
    skin.face = np.asarray(faces, dtype=int).ravel().tolist()
    skin.rgba = list(rgba)
    skin.inflate = inflate
    ids: list[list[int]] = [[] for _ in bodies]
    ws: list[list[float]] = [[] for _ in bodies]
    for v, k in zip(*np.nonzero(np.asarray(bones) >= 0)):
        b = int(bones[v, k])
        ids[b].append(int(v))
        ws[b].append(float(weights[v, k]))
    keep = [b for b in range(len(bodies)) if ids[b]]
    skin.bodyname = [bodies[b] for b in keep]
    skin.bindpos = np.asarray(bind_positions, dtype=float)[keep].ravel().tolist()
    skin.bindquat = np.asarray(bind_rotations, dtype=float)[keep].ravel().tolist()
    skin.vertid = [ids[b] for b in keep]
    skin.vertweight = [ws[b] for b in keep]
    return skin


def with_skin(compiled: CompiledModel, hide_group: int | None = None, **skin: object) -> CompiledModel:
    """``compiled`` with a skin added (the keyword arguments of :func:`add_skin`) and recompiled.

    ``hide_group``: move the character's own geoms (still its collision and mass) to this geom group.
    """
    spec = compiled.spec.copy()
    if hide_group is not None:
        mine = set(character_geoms(compiled.model, int(compiled.body_ids[0])).tolist())
        for g in spec.geoms:
            if g.id in mine:
                g.group = hide_group
    add_skin(spec, **skin)  # type: ignore[arg-type]
    return _recompiled(compiled, spec)
