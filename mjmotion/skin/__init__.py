"""A skinned character for any skeleton (seed 000 §1.1.2): surface, weights, LBS and DQS.

The pieces, each its own module:

* :mod:`.bind` — a standing T-pose of the skeleton (the bind pose);
* :mod:`.mesh` — a closed surface around the compiled model's geoms in that pose;
* :mod:`.weights` — up to four bone weights per vertex from bind-pose distance, smoothed;
* :mod:`.deform` — linear blend skinning (Eq. 1) and dual-quaternion skinning, all frames at once.

Public API::

    s = skin.build(compiled, reference=motion)        # a Skin: mesh, weights, bind frames
    v, n = skin.deformed(s, compiled, motion, "lbs")    # (T, V, 3) vertices and normals
    a = skin.animate(motion)                          # faces, bind vertices, per-frame vertices
    compiled = skin.attach(compiled, s)               # the skin as a MuJoCo <skin> (MjSpec)

The skin a model carries in MuJoCo is the same mesh and weights: MuJoCo deforms it by vertex
blending when it draws (``mjv_updateScene``), and the tests check that :func:`deformed` with
``"lbs"`` gives MuJoCo's vertices.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from .. import mjcf
from ..errors import MjmotionError, is_real, is_whole
from ..skeleton import Motion
from . import bind, mesh
from . import deform as _deform
from . import weights as _weights

__all__ = ["Skin", "SkinnedMotion", "Settings", "build", "deformed", "deformed_frames", "animate", "attach", "bind_qpos"]


@dataclass(frozen=True)
class Settings:
    """How the surface and weights are made, in metres for a 1.75 m character (scaled with stature).

    Attributes:
        voxel: marching-cubes grid spacing (1.4 cm gives 11–15k vertices on the shared skeletons).
        blend: fillet width where two geoms meet (the smooth union).
        margin: how far outside the geoms the surface lies (so the skin covers them).
        falloff: the weights' distance bound (see :mod:`.weights`).
        smoothing: neighbour-averaging passes over the weights.
        influences: most bones per vertex (1–4).
    """

    voxel: float = 0.014
    blend: float = 0.02
    margin: float = 0.004
    falloff: float = 0.03
    smoothing: int = 3
    influences: int = 4

    def __post_init__(self) -> None:
        # (a voxel of 0 or NaN, a negative margin, a NaN blend were "negative dimensions"; 10 m a scikit-image error)
        for label, value, low, high in (("voxel", self.voxel, 0.002, 0.2), ("blend", self.blend, 0.0, 0.2),
                                        ("margin", self.margin, 0.0, 0.1), ("falloff", self.falloff, 0.001, 0.5)):  # fmt: skip
            if not (is_real(value) and low <= value <= high):
                raise MjmotionError(f"skin.Settings {label}={value!r}: expected metres from {low:g} to {high:g}")
        for label, value, low, high in (("smoothing", self.smoothing, 0, 100), ("influences", self.influences, 1, 4)):
            if not (is_whole(value) and low <= value <= high):
                raise MjmotionError(f"skin.Settings {label}={value!r}: expected a whole number from {low} to {high}")


@dataclass(frozen=True, eq=False)
class Skin:
    """A character surface bound to a skeleton.

    Attributes:
        vertices: ``(V, 3)`` bind-pose positions, metres (the bind pose stands on z = 0).
        faces: ``(F, 3)`` triangles, counter-clockwise seen from outside; the mesh is closed.
        normals: ``(V, 3)`` bind-pose unit normals, outward.
        joints: ``(N,)`` skeleton joint index of each bone the skin follows.
        bodies: ``(N,)`` their names (the MuJoCo bodies).
        bind_positions: ``(N, 3)``; bind_rotations: ``(N, 4)`` those bodies' frames in the bind pose.
        weights: influences per vertex; ``weights.bones`` index ``joints``.
        parents: ``(N,)`` each bone's nearest ancestor among ``joints`` (index into it; ``-1`` none).
        bind_pose: ``(J, 4)`` local rotations of the bind pose (:func:`.bind.bind_rotations`).
        bind_root: ``(3,)`` the root's position in the bind pose.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    bodies: tuple[str, ...]
    bind_positions: np.ndarray
    bind_rotations: np.ndarray
    weights: _weights.Weights
    parents: np.ndarray
    bind_pose: np.ndarray
    bind_root: np.ndarray

    @property
    def n_vertices(self) -> int:
        return int(len(self.vertices))


@dataclass(frozen=True, eq=False)
class SkinnedMotion:
    """A clip's skin, frame by frame (what a viewer needs).

    Attributes:
        faces: ``(F, 3)``; bind_vertices: ``(V, 3)``.
        vertices: ``(T, V, 3)`` deformed positions; normals: ``(T, V, 3)`` or ``None``.
        fps: the clip's frame rate.
    """

    faces: np.ndarray
    bind_vertices: np.ndarray
    vertices: np.ndarray
    normals: np.ndarray | None
    fps: float

    def __repr__(self) -> str:
        """``SkinnedMotion(11806 vertices, 23608 faces, 241 frames at 60 fps)``: no arrays."""
        return f"SkinnedMotion({len(self.bind_vertices)} vertices, {len(self.faces)} faces, {len(self.vertices)} frames at {self.fps:.6g} fps)"


def bind_qpos(compiled: mjcf.CompiledModel, local: np.ndarray) -> np.ndarray:
    """``(nq,)`` the model's ``qpos0`` with the joints at ``local: (J, 4)`` rotations, standing on the floor."""
    import mujoco

    q = compiled.model.qpos0.copy()
    for j in range(compiled.skeleton.n_joints):
        a = compiled.qpos_adr[j]
        q[a : a + 4] = local[j]
    m = compiled.model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    q[2] -= mjcf.lowest_point(m, d, mjcf.character_geoms(m, int(compiled.body_ids[0])))
    return q


_CACHE: OrderedDict[str, Skin] = OrderedDict()
_CACHE_SIZE = 16


def build(compiled: mjcf.CompiledModel, reference: Motion | None = None, settings: Settings = Settings()) -> Skin:
    """The skin of ``compiled``'s character: its geoms meshed in the bind pose, weighted by distance.

    Args:
        compiled: the character's model (its capsules and foot boxes are the shapes).
        reference: a clip of the skeleton, used only if the rest pose does not stand (see :mod:`.bind`).
        settings: mesh and weight parameters.

    Skins are cached in memory by the model's geometry and bind pose, so tests and renders that
    share a skeleton mesh it once. Raises :class:`MjmotionError` for a skeleton with one joint,
    bones too short to give it a body, or a character under 25 cm.
    """
    import mujoco

    skel = compiled.skeleton
    if skel.n_joints < 2:
        raise MjmotionError("a skeleton of one joint has no bones to put a surface on")
    local = bind.bind_rotations(skel, reference)
    q = bind_qpos(compiled, local)
    m = compiled.model
    geoms = mjcf.character_geoms(m, int(compiled.body_ids[0]))
    shapes, data = mesh.shapes_at(m, q, geoms)
    if shapes.n_shapes == 0:
        raise MjmotionError("every bone is shorter than 1 cm: the skeleton has no body to put a surface on")
    lo, hi = shapes.bounds()
    extent = float(np.max(hi.max(axis=0) - lo.min(axis=0)))
    if extent < 0.25:
        raise MjmotionError(f"the character is {100 * extent:.1f} cm across: too small for a skin (are its units right? see --units)")
    scale = float(np.clip(skel.stature(), 0.3, 3.0)) / 1.75
    key = _key(shapes, settings, scale)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    verts, faces = mesh.surface(shapes, settings.voxel * scale, settings.blend * scale, settings.margin * scale)
    w = _weights.from_distances(shapes.body_distances(verts), faces, settings.falloff * scale, settings.smoothing, settings.influences)
    body_names = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or "" for b in shapes.bodies)
    joint_of = {int(b): j for j, b in enumerate(compiled.body_ids)}
    joints = [joint_of[int(b)] for b in shapes.bodies]
    out = Skin(
        vertices=verts,
        faces=faces,
        normals=_vertex_normals(verts, faces),
        joints=np.array(joints, dtype=int),
        bodies=body_names,
        bind_positions=data.xpos[shapes.bodies].copy(),
        bind_rotations=data.xquat[shapes.bodies].copy(),
        weights=w,
        parents=_bone_parents(skel.parents, joints),
        bind_pose=local,
        bind_root=q[0:3].copy(),
    )
    _CACHE[key] = out
    if len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return out


def _bone_parents(parents: np.ndarray, joints: list[int]) -> np.ndarray:
    where = {j: i for i, j in enumerate(joints)}
    out = np.full(len(joints), -1, dtype=int)
    for i, j in enumerate(joints):
        p = int(parents[j])
        while p >= 0 and p not in where:
            p = int(parents[p])
        out[i] = where.get(p, -1)
    return out


def _key(shapes: mesh.Shapes, settings: Settings, scale: float) -> str:
    h = hashlib.sha1(repr((settings, scale)).encode())
    for a in (shapes.capsules, shapes.radii, shapes.capsule_body, shapes.box_centers, shapes.box_axes, shapes.box_half, shapes.box_body):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(V, 3)`` area-weighted unit vertex normals (as MuJoCo computes a skin's)."""
    fn = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    n = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(n, faces[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def deformed(
    skin: Skin,
    compiled: mjcf.CompiledModel,
    motion: Motion,
    method: str = "lbs",
    normals: bool = True,
) -> tuple[np.ndarray, np.ndarray | None]:
    """The skin over every frame of ``motion``: ``(T, V, 3)`` vertices and normals (or ``None``).

    ``method``: ``"lbs"`` (linear blend skinning, seed 000 Eq. 1) or ``"dqs"`` (dual quaternions).
    Bone frames come from MuJoCo's forward kinematics of ``compiled``.
    """
    from .. import kinematics

    pose = kinematics.forward(compiled, motion)
    return deformed_frames(skin, pose.joint_positions[:, skin.joints], pose.joint_rotations[:, skin.joints], method, normals)


def deformed_frames(
    skin: Skin, positions: np.ndarray, rotations: np.ndarray, method: str = "lbs", normals: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """The skin for bone frames ``positions: (T, N, 3)`` and ``rotations: (T, N, 4)`` (``skin.joints`` order)."""
    q, t = _deform.bone_transforms(positions, rotations, skin.bind_positions, skin.bind_rotations)
    n0 = skin.normals if normals else None
    if method == "lbs":
        return _deform.lbs(skin.vertices, skin.weights.dense(len(skin.joints)), q, t, n0)
    if method == "dqs":
        return _deform.dqs(skin.vertices, skin.weights.bones, skin.weights.values, q, t, n0, skin.parents)
    raise MjmotionError(f"unknown skinning method {method!r}; expected 'lbs' or 'dqs'")


def animate(motion: Motion, method: str = "lbs", normals: bool = True, settings: Settings = Settings()) -> SkinnedMotion:
    """Faces, bind vertices and per-frame vertices of ``motion``'s character (for a viewer)."""
    compiled = mjcf.compile(motion.skeleton)
    s = build(compiled, reference=motion, settings=settings)
    v, n = deformed(s, compiled, motion, method, normals)
    return SkinnedMotion(faces=s.faces, bind_vertices=s.vertices, vertices=v, normals=n, fps=motion.fps)


#: Geom group the character's own geoms move to in a skinned model: MuJoCo draws groups 0–2 by default.
HIDDEN_GROUP = 3


def attach(
    compiled: mjcf.CompiledModel, skin: Skin, rgba: tuple[float, float, float, float] = (0.75, 0.6, 0.5, 1.0), hide_geoms: bool = True
) -> mjcf.CompiledModel:
    """``compiled`` carrying ``skin`` as a MuJoCo ``<skin>``.

    With ``hide_geoms`` the character's capsules and foot boxes (still its collision and mass
    geometry) move to geom group :data:`HIDDEN_GROUP`, which viewers do not draw unless asked
    (key ``3`` in MuJoCo's viewer); props and the floor stay visible.
    """
    return mjcf.with_skin(compiled, hide_group=HIDDEN_GROUP if hide_geoms else None, **skin_arguments(skin, rgba=rgba))


def skin_arguments(skin: Skin, prefix: str = "", **extra: object) -> dict[str, object]:
    """Keyword arguments of :func:`mjmotion.mjcf.add_skin` for ``skin`` (bodies named with ``prefix``)."""
    return dict(
        vertices=skin.vertices,
        faces=skin.faces,
        bodies=[prefix + b for b in skin.bodies],
        bind_positions=skin.bind_positions,
        bind_rotations=skin.bind_rotations,
        bones=skin.weights.bones,
        weights=skin.weights.values,
        **extra,
    )
