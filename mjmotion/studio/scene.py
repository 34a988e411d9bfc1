"""Characters drawn in the viser scene from the compiled MuJoCo model, posed by ``mj_kinematics``.

The geoms are the renderer's: bone capsules, foot and toe boxes, props, the ball (the floor is
the scene's grid). A capsule is drawn exactly as a cylinder and two spheres; each kind of
primitive is one batched mesh per character, so a frame is three messages whatever the
skeleton. How a character is drawn is a *draw mode* (:data:`DRAW_MODES`): a factory
``(scene, name, compiled, color, reference=None) -> Drawing`` (``reference``: a clip of the
character, for modes that need one). The skinned character (:mod:`.skinned`) plugs in as more
modes with :func:`register_draw_mode`; it receives the same :class:`Pose`, which carries the
bodies' world frames as well as the geoms'.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np

from .. import rotations as rot
from ..mjcf import CompiledModel
from ..skeleton import Motion

#: Body colours of characters shown side by side (the plots' palette).
PALETTE = ((77, 140, 217), (242, 153, 51), (89, 191, 89), (179, 128, 217), (217, 64, 64), (102, 204, 204))
CONTACT_RGB = (40, 200, 90)


@dataclass(frozen=True, eq=False)
class Pose:
    """World frames of one frame of a model: geoms ``pos (G, 3)``, ``quat (G, 4)``; bodies ``(B, 3)``, ``(B, 4)``."""

    geom_pos: np.ndarray
    geom_quat: np.ndarray
    body_pos: np.ndarray
    body_quat: np.ndarray


class Kinematics:
    """``qpos → Pose`` for one compiled model (one ``MjData``; not shared between threads)."""

    def __init__(self, compiled: CompiledModel):
        self.compiled = compiled
        self.model = compiled.model
        self.data = mujoco.MjData(self.model)

    def pose(self, qpos: np.ndarray) -> Pose:
        d = self.data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, d)
        # geom orientation = its body's world orientation times the geom's frame in the body
        gq = rot.multiply(d.xquat[self.model.geom_bodyid], self.model.geom_quat)
        return Pose(d.geom_xpos.copy(), gq, d.xpos.copy(), d.xquat.copy())

    def poses(self, qpos: np.ndarray) -> list[Pose]:
        """One :class:`Pose` per row of ``qpos: (T, nq)``."""
        return [self.pose(q) for q in np.atleast_2d(qpos)]


class Drawing(Protocol):
    """What a draw mode returns: a character in the scene that can be posed, tinted and removed."""

    def update(self, pose: Pose) -> None: ...
    def set_geom_colors(self, colors: dict[int, tuple[int, int, int]]) -> None: ...
    def set_visible(self, visible: bool) -> None: ...
    def remove(self) -> None: ...


DrawFactory = Callable[..., Drawing]  # (scene, name, compiled, color, reference=None)


def _unit_cylinder(n: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Radius 1, height 1 along z, centred; capped."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    v = np.vstack([np.c_[ring, np.full(n, -0.5)], np.c_[ring, np.full(n, 0.5)], [[0, 0, -0.5], [0, 0, 0.5]]])
    i = np.arange(n)
    j = (i + 1) % n
    side = np.r_[np.c_[i, j, n + j], np.c_[i, n + j, n + i]]
    caps = np.r_[np.c_[np.full(n, 2 * n), j, i], np.c_[np.full(n, 2 * n + 1), n + i, n + j]]
    return v.astype(np.float32), np.r_[side, caps].astype(np.uint32)


def _unit_sphere(n_lat: int = 8, n_lon: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Radius 1 (a UV sphere)."""
    th = np.linspace(0, np.pi, n_lat + 1)
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    v = np.array([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)] for t in th for p in ph])
    faces = []
    for a in range(n_lat):
        for b in range(n_lon):
            p0, p1 = a * n_lon + b, a * n_lon + (b + 1) % n_lon
            q0, q1 = p0 + n_lon, p1 + n_lon
            faces += [(p0, q0, q1), (p0, q1, p1)]
    return v.astype(np.float32), np.array(faces, dtype=np.uint32)


def _unit_box() -> tuple[np.ndarray, np.ndarray]:
    """Half-extent 1 on every axis."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float32)
    f = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return v, np.array(f, dtype=np.uint32)


MESHES = {"cylinder": _unit_cylinder(), "sphere": _unit_sphere(), "box": _unit_box()}


@dataclass(frozen=True, eq=False)
class GeomLayout:
    """Which geoms of a model become which primitive instances.

    Attributes:
        cylinders, boxes: geom ids drawn as a cylinder (capsules, cylinders) or a box.
        caps: ``(geom id, ±1)`` per sphere instance at a capsule's end; ``balls``: sphere geom ids.
        half: ``(G,)`` half-length along z of capsules and cylinders; ``size``: ``(G, 3)`` MuJoCo sizes.
        rgb: ``(G, 3)`` uint8 base colours.
    """

    cylinders: np.ndarray
    boxes: np.ndarray
    caps: np.ndarray
    cap_sign: np.ndarray
    balls: np.ndarray
    size: np.ndarray
    rgb: np.ndarray

    @classmethod
    def of(cls, compiled: CompiledModel, body_color: tuple[int, int, int], geoms: np.ndarray | None = None) -> GeomLayout:
        """The layout of every geom but the floor, or of ``geoms`` (ids) only."""
        m = compiled.model
        body_geoms = set(int(g) for g in compiled.body_geom_ids)
        foot = {int(g) for ids in compiled.foot_geoms.values() for g in ids}
        t = m.geom_type
        keep = np.ones(m.ngeom, dtype=bool) if geoms is None else np.isin(np.arange(m.ngeom), geoms)
        capsule, cyl = mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER
        cylinders = np.flatnonzero(((t == capsule) | (t == cyl)) & keep)
        caps = np.flatnonzero((t == capsule) & keep)
        rgb = np.clip(m.geom_rgba[:, :3] * 255, 0, 255).astype(np.uint8)
        for g in body_geoms - foot:
            rgb[g] = body_color
        return cls(
            cylinders=cylinders,
            boxes=np.flatnonzero((t == mujoco.mjtGeom.mjGEOM_BOX) & keep),
            caps=np.r_[caps, caps],
            cap_sign=np.r_[np.ones(len(caps)), -np.ones(len(caps))],
            balls=np.flatnonzero((t == mujoco.mjtGeom.mjGEOM_SPHERE) & keep),
            size=m.geom_size.copy(),
            rgb=rgb,
        )

    def instances(self, pose: Pose) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """``kind → (positions (N, 3), wxyzs (N, 4))`` for the pose."""
        p, q = pose.geom_pos, pose.geom_quat
        axis = rot.rotate(q[self.caps], np.array([0.0, 0.0, 1.0]))
        sph_pos = np.r_[p[self.caps] + axis * (self.cap_sign * self.size[self.caps, 1])[:, None], p[self.balls]]
        ident = np.broadcast_to(rot.IDENTITY, (len(sph_pos), 4))
        return {
            "cylinder": (p[self.cylinders], q[self.cylinders]),
            "sphere": (sph_pos, ident),
            "box": (p[self.boxes], q[self.boxes]),
        }

    def scales(self) -> dict[str, np.ndarray]:
        s = self.size
        return {
            "cylinder": np.c_[s[self.cylinders, 0], s[self.cylinders, 0], 2 * s[self.cylinders, 1]],
            "sphere": np.repeat(np.r_[s[self.caps, 0], s[self.balls, 0]][:, None], 3, axis=1),
            "box": s[self.boxes].copy(),
        }

    def geoms(self) -> dict[str, np.ndarray]:
        """Geom id of every instance, per kind."""
        return {"cylinder": self.cylinders, "sphere": np.r_[self.caps, self.balls], "box": self.boxes}


class PrimitiveDrawing:
    """The default draw mode: the model's geoms (or only ``geoms``) as batched cylinders, spheres and boxes."""

    def __init__(
        self,
        scene: Any,
        name: str,
        compiled: CompiledModel,
        color: tuple[int, int, int],
        reference: Motion | None = None,
        geoms: np.ndarray | None = None,
    ):
        self._layout = GeomLayout.of(compiled, color, geoms)
        self._geoms = self._layout.geoms()
        scales = self._layout.scales()
        self._handles: dict[str, Any] = {}
        rest = Kinematics(compiled).pose(compiled.model.qpos0)
        for kind, (pos, quat) in self._layout.instances(rest).items():
            if len(pos) == 0:
                continue
            v, f = MESHES[kind]
            self._handles[kind] = scene.add_batched_meshes_simple(
                f"{name}/{kind}",
                v,
                f,
                batched_wxyzs=quat,
                batched_positions=pos,
                batched_scales=scales[kind],
                batched_colors=self._layout.rgb[self._geoms[kind]],
                lod="off",
            )

    def update(self, pose: Pose) -> None:
        for kind, (pos, quat) in self._layout.instances(pose).items():
            h = self._handles.get(kind)
            if h is not None:
                h.batched_positions = pos.astype(np.float32)
                h.batched_wxyzs = np.ascontiguousarray(quat, dtype=np.float32)

    def set_geom_colors(self, colors: dict[int, tuple[int, int, int]]) -> None:
        """Override some geoms' colours (the others back to their base colour)."""
        for kind, h in self._handles.items():
            ids = self._geoms[kind]
            rgb = self._layout.rgb[ids].copy()
            for k, g in enumerate(ids):
                if int(g) in colors:
                    rgb[k] = colors[int(g)]
            h.batched_colors = rgb

    def set_visible(self, visible: bool) -> None:
        for h in self._handles.values():
            h.visible = visible

    def remove(self) -> None:
        for h in self._handles.values():
            h.remove()
        self._handles.clear()


#: Draw modes by name; the first is the default.
DRAW_MODES: dict[str, DrawFactory] = {"capsules": PrimitiveDrawing}


def register_draw_mode(name: str, factory: DrawFactory) -> None:
    """Add a way to draw characters (e.g. the skinned mesh); it appears in the Studio's Character menu."""
    DRAW_MODES[name] = factory
