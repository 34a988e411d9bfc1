"""The skinned character as Studio draw modes: ``skin (LBS)``, ``skin (DQS)`` and ``both``.

The skin is :mod:`mjmotion.skin`'s (a closed surface made around the model's geoms in a bind
pose, at most four bone weights per vertex). It follows the same :class:`~.scene.Pose` the
capsules use: the world frames of the skin's bodies (``Pose.body_pos``, ``Pose.body_quat``) give
each bone's motion from its bind frame (:func:`mjmotion.skin.deform.bone_transforms`), and
:class:`FrameSkinner` turns them into the frame's vertices. What does not change between frames
is prepared once — for LBS the sparse ``(V, 4N)`` matrix of weighted homogeneous bind vertices
(seed 000 Eq. 1 as one product), for DQS the ``(V, N)`` sparsity of the weights and the bone pairs
that share a vertex — so a frame is a sparse product and a few ``(V, 3)`` array operations, with
no per-vertex Python. It gives :func:`mjmotion.skin.deformed_frames`'s vertices (tests).

Upload: each frame assigns new ``(V, 3)`` float32 vertices to the existing viser mesh handles
(``MeshHandle.vertices``). viser sends that one property; its client writes the existing GPU
buffer in place (``bufferSubData``; viser 1.1 ``BasicMesh``) and recomputes smooth vertex
normals from the deformed triangles (``computeVertexNormals``, area-weighted like MuJoCo's skin
normals), so the skin shades without normals on the wire. The faces are sent once.

The mesh is split into the body and one part per foot (the faces whose three vertices follow
mostly that foot's bones), so the Evaluate tab can colour a foot in contact as it colours the
capsule figure's foot boxes; the parts share the deformed vertices, so the seams stay closed.
Props (bat, club) are drawn as primitives. ``both`` draws the capsules and, over them, the LBS
skin half transparent.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import rotations as rot
from ..errors import MjmotionError
from ..mjcf import CompiledModel, character_geoms
from ..skeleton import Motion
from ..skin import Skin, build
from ..skin.deform import _cross, _rotate, bone_transforms
from .scene import Pose, PrimitiveDrawing, register_draw_mode

METHODS = ("lbs", "dqs")
#: Opacity of the skin drawn over the capsules in the ``both`` mode.
BOTH_OPACITY = 0.45


class FrameSkinner:
    """One skin deformed one frame at a time, prepared once.

    Args:
        skin: the skin (:func:`mjmotion.skin.build`).
        method: ``"lbs"`` (linear blend skinning) or ``"dqs"`` (dual quaternions).

    Call it with the world frames of the skin's bones, ``positions: (N, 3)`` and
    ``rotations: (N, 4)`` in ``skin.joints`` order; it returns ``(V, 3)`` vertices.
    """

    def __init__(self, skin: Skin, method: str = "lbs"):
        from scipy import sparse

        if method not in METHODS:
            raise MjmotionError(f"unknown skinning method {method!r}; expected one of {', '.join(METHODS)}")
        self.skin, self.method = skin, method
        n_v, n_b = skin.n_vertices, len(skin.joints)
        bones = np.maximum(skin.weights.bones, 0)  # an unused slot weighs 0: any column will do
        values = np.where(skin.weights.bones >= 0, skin.weights.values, 0.0)
        k = bones.shape[1]
        if method == "lbs":
            # row v holds wᵢ·(v, 1) in bone i's four columns: v' = Σ wᵢ [Rᵢ | tᵢ] (v, 1)
            homog = np.hstack([skin.vertices, np.ones((n_v, 1))])
            cols = (4 * bones[:, :, None] + np.arange(4)).reshape(n_v, 4 * k)
            data = (values[:, :, None] * homog[:, None, :]).reshape(n_v, 4 * k)
            rows = np.repeat(np.arange(n_v), 4 * k)
            self._lbs = sparse.csr_matrix((data.ravel(), (rows, cols.ravel())), shape=(n_v, 4 * n_b))
        else:
            # each vertex flips its bones' dual quaternions to the hemisphere of its main bone (the
            # first slot); the sign of a (main, other) pair is computed once per pair per frame
            pairs, pair_of = np.unique(np.stack([np.repeat(bones[:, :1], k, axis=1), bones], axis=-1).reshape(-1, 2), axis=0, return_inverse=True)
            self._pairs, self._pair_of = pairs, pair_of.reshape(n_v, k)
            self._values = values
            self._indices = bones.ravel().astype(np.int32)  # scipy's index type: no cast per frame
            self._indptr = np.arange(0, n_v * k + 1, k, dtype=np.int32)
            self._shape = (n_v, n_b)
            self._bind = np.ascontiguousarray(skin.vertices.T)  # (3, V)

    def __call__(self, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        q, t = bone_transforms(positions[None], rotations[None], self.skin.bind_positions, self.skin.bind_rotations)
        q, t = q[0], t[0]
        if self.method == "lbs":
            m = np.concatenate([rot.to_matrix(q), t[:, :, None]], axis=2)  # (N, 3, 4)
            return np.asarray(self._lbs @ m.transpose(0, 2, 1).reshape(-1, 3))
        return self._dqs(q, t)

    def _dqs(self, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        from scipy import sparse

        # each bone's unit dual quaternion: real q, dual ½ (0, t) ⊗ q
        dq = np.concatenate([q, 0.5 * rot.multiply(np.c_[np.zeros(len(t)), t], q)], axis=1)  # (N, 8)
        sign = np.where(np.einsum("pc,pc->p", q[self._pairs[:, 0]], q[self._pairs[:, 1]]) < 0, -1.0, 1.0)
        w = sparse.csr_matrix(((self._values * sign[self._pair_of]).ravel(), self._indices, self._indptr), shape=self._shape)
        b = np.ascontiguousarray(np.asarray(w @ dq).T)  # (8, V), component-first
        b /= np.sqrt(np.einsum("cv,cv->v", b[:4], b[:4]))
        real, s, ds, du = b[None, :4], b[:1], b[4:5], b[5:]
        u = b[1:4]
        trans = 2.0 * (s * du - ds * u + _cross(u[None], du[None])[0])
        return (_rotate(real, self._bind)[0] + trans).T


def foot_parts(compiled: CompiledModel, skin: Skin) -> dict[str, np.ndarray]:
    """``{part: (F_p,) face indices}``: one part per foot side (faces whose vertices all follow a
    bone of that foot's bodies most), the rest ``"body"``; every face is in exactly one part."""
    m = compiled.model
    main_body = np.asarray(compiled.body_ids)[skin.joints][skin.weights.bones[:, 0]]  # (V,)
    rest = np.ones(len(skin.faces), dtype=bool)
    out: dict[str, np.ndarray] = {}
    for side, geoms in compiled.foot_geoms.items():
        on_foot = np.isin(main_body, m.geom_bodyid[list(geoms)])[skin.faces].all(axis=1) & rest
        if on_foot.any():
            out[side] = np.flatnonzero(on_foot)
            rest &= ~on_foot
    return {"body": np.flatnonzero(rest), **out}


class SkinDrawing:
    """A character drawn as its skin (plus its props as primitives); the :class:`~.scene.Drawing` protocol.

    Args:
        scene, name, compiled, color: as every draw mode (:data:`~.scene.DRAW_MODES`).
        reference: a clip of the character, for skeletons whose rest pose does not stand (:func:`mjmotion.skin.build`).
        method: ``"lbs"`` or ``"dqs"``.
        opacity: ``None`` opaque; ``props``: also draw the props.

    Raises :class:`MjmotionError` when the skeleton cannot carry a skin.
    """

    def __init__(
        self,
        scene: Any,
        name: str,
        compiled: CompiledModel,
        color: tuple[int, int, int],
        reference: Motion | None = None,
        method: str = "lbs",
        opacity: float | None = None,
        props: bool = True,
    ):
        self.skin = build(compiled, reference=reference)
        self.skinner = FrameSkinner(self.skin, method)
        self._bones = np.asarray(compiled.body_ids)[self.skin.joints]
        self._color = tuple(int(c) for c in color)
        self._part_geoms = {side: {int(g) for g in ids} for side, ids in compiled.foot_geoms.items()}
        bind = self.skin.vertices.astype(np.float32)
        #: ``(V, 3)`` float64 vertices of the last frame drawn (the bind pose before the first).
        self.vertices = self.skin.vertices.copy()
        self._parts: dict[str, tuple[Any, np.ndarray]] = {}
        for part, faces in foot_parts(compiled, self.skin).items():
            vids, local = np.unique(self.skin.faces[faces], return_inverse=True)
            handle = scene.add_mesh_simple(
                f"{name}/skin/{part}", bind[vids], local.reshape(-1, 3).astype(np.uint32), color=self._color, opacity=opacity
            )
            self._parts[part] = (handle, vids)
        own = character_geoms(compiled.model, int(compiled.body_ids[0]))
        others = np.setdiff1d(np.arange(1, compiled.model.ngeom), own)  # geom 0 is the floor
        self._props = PrimitiveDrawing(scene, f"{name}/props", compiled, color, geoms=others) if props and len(others) else None

    def update(self, pose: Pose) -> None:
        self.vertices = self.skinner(pose.body_pos[self._bones], pose.body_quat[self._bones])
        v = self.vertices.astype(np.float32)
        for handle, vids in self._parts.values():
            handle.vertices = v[vids]
        if self._props is not None:
            self._props.update(pose)

    def set_geom_colors(self, colors: dict[int, tuple[int, int, int]]) -> None:
        """A foot part takes the colour given to any of its foot's geoms; the rest keep the body colour."""
        for part, (handle, _) in self._parts.items():
            tint = [colors[g] for g in sorted(self._part_geoms.get(part, ())) if g in colors]
            handle.color = tuple(int(c) for c in tint[0]) if tint else self._color
        if self._props is not None:
            self._props.set_geom_colors(colors)

    def set_visible(self, visible: bool) -> None:
        for handle, _ in self._parts.values():
            handle.visible = visible
        if self._props is not None:
            self._props.set_visible(visible)

    def remove(self) -> None:
        for handle, _ in self._parts.values():
            handle.remove()
        self._parts.clear()
        if self._props is not None:
            self._props.remove()


class BothDrawing:
    """The capsules and, over them, the LBS skin at :data:`BOTH_OPACITY` (where the surface sits on the bones)."""

    def __init__(self, scene: Any, name: str, compiled: CompiledModel, color: tuple[int, int, int], reference: Motion | None = None):
        self.skin = SkinDrawing(scene, f"{name}/over", compiled, color, reference, "lbs", opacity=BOTH_OPACITY, props=False)
        self.capsules = PrimitiveDrawing(scene, name, compiled, color)
        self._parts = (self.capsules, self.skin)

    def update(self, pose: Pose) -> None:
        for d in self._parts:
            d.update(pose)

    def set_geom_colors(self, colors: dict[int, tuple[int, int, int]]) -> None:
        for d in self._parts:
            d.set_geom_colors(colors)

    def set_visible(self, visible: bool) -> None:
        for d in self._parts:
            d.set_visible(visible)

    def remove(self) -> None:
        for d in self._parts:
            d.remove()


def _skin_mode(method: str) -> Any:
    def factory(scene: Any, name: str, compiled: CompiledModel, color: tuple[int, int, int], reference: Motion | None = None) -> SkinDrawing:
        return SkinDrawing(scene, name, compiled, color, reference, method)

    return factory


def register_skin_modes() -> None:
    """Add ``skin (LBS)``, ``skin (DQS)`` and ``both`` to the Studio's Character menu (after ``capsules``)."""
    register_draw_mode("skin (LBS)", _skin_mode("lbs"))
    register_draw_mode("skin (DQS)", _skin_mode("dqs"))
    register_draw_mode("both", BothDrawing)
