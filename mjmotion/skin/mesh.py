"""The character's surface: a smooth union of its body geoms, meshed with marching cubes.

The compiled model's own geoms in the bind pose — a capsule along every bone, boxes under the
feet — are the shapes (:class:`Shapes`). Their signed distances are combined with a smooth
minimum (the union with a fillet of width ``blend`` where two shapes meet, so joints look like
joints), the field is sampled on a voxel grid, and scikit-image's marching cubes extracts the
level set ``margin`` outside the shapes: the skin encloses every geom, so a rendered skin covers
the capsule figure. Taubin smoothing (trimesh) removes the voxel terraces without shrinking the
surface; the mesh is closed and consistently wound, normals pointing out.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import MjmotionError


@dataclass(frozen=True, eq=False)
class Shapes:
    """Capsules and boxes in world coordinates, each belonging to one body.

    Attributes:
        capsules: ``(C, 2, 3)`` segment end points, metres.
        radii: ``(C,)`` capsule radii.
        capsule_body: ``(C,)`` index (into ``bodies``) of each capsule's body.
        box_centers: ``(B, 3)``; box_axes: ``(B, 3, 3)`` (columns are the box axes); box_half: ``(B, 3)``.
        box_body: ``(B,)``.
        bodies: ``(N,)`` the MuJoCo body ids the indices refer to.
    """

    capsules: np.ndarray
    radii: np.ndarray
    capsule_body: np.ndarray
    box_centers: np.ndarray
    box_axes: np.ndarray
    box_half: np.ndarray
    box_body: np.ndarray
    bodies: np.ndarray

    @property
    def n_shapes(self) -> int:
        return len(self.radii) + len(self.box_half)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(S, 3)`` lower and upper corners of each shape's bounding box (capsules first)."""
        lo_c = self.capsules.min(axis=1) - self.radii[:, None]
        hi_c = self.capsules.max(axis=1) + self.radii[:, None]
        ext = np.abs(self.box_axes) @ self.box_half[:, :, None] if len(self.box_half) else np.zeros((0, 3, 1))
        lo_b = self.box_centers - ext[..., 0]
        hi_b = self.box_centers + ext[..., 0]
        return np.vstack([lo_c, lo_b]), np.vstack([hi_c, hi_b])

    def distance(self, points: np.ndarray, shape: int) -> np.ndarray:
        """``(P,)`` signed distance of ``points: (P, 3)`` to shape ``shape`` (negative inside)."""
        nc = len(self.radii)
        if shape < nc:
            a, b = self.capsules[shape]
            ab = b - a
            t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-18), 0.0, 1.0)
            return np.linalg.norm(points - a - t[:, None] * ab, axis=1) - self.radii[shape]
        k = shape - nc
        local = (points - self.box_centers[k]) @ self.box_axes[k]
        q = np.abs(local) - self.box_half[k]
        return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)

    def shape_body(self) -> np.ndarray:
        """``(S,)`` body index of each shape (capsules first)."""
        return np.concatenate([self.capsule_body, self.box_body]).astype(int)

    def body_distances(self, points: np.ndarray) -> np.ndarray:
        """``(P, N)`` distance of each point to each body's nearest shape (clipped at 0 inside)."""
        out = np.full((len(points), len(self.bodies)), np.inf)
        for s, b in enumerate(self.shape_body()):
            out[:, b] = np.minimum(out[:, b], np.maximum(self.distance(points, s), 0.0))
        return out


def shapes_at(model: mujoco.MjModel, qpos: np.ndarray, geoms: np.ndarray) -> tuple[Shapes, mujoco.MjData]:
    """The capsules and boxes among ``geoms`` placed at configuration ``qpos`` (``mj_kinematics``)."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(model, d)
    caps, radii, cbody, centers, axes, half, bbody = [], [], [], [], [], [], []
    body_ids = sorted({int(model.geom_bodyid[g]) for g in geoms})
    index = {b: i for i, b in enumerate(body_ids)}
    for g in geoms:
        mat = d.geom_xmat[g].reshape(3, 3)
        c = d.geom_xpos[g].copy()
        size = model.geom_size[g]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            caps.append([c - mat[:, 2] * size[1], c + mat[:, 2] * size[1]])
            radii.append(size[0])
            cbody.append(index[int(model.geom_bodyid[g])])
        elif model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            centers.append(c)
            axes.append(mat.copy())
            half.append(size.copy())
            bbody.append(index[int(model.geom_bodyid[g])])
    shapes = Shapes(
        capsules=np.asarray(caps, dtype=float).reshape(-1, 2, 3),
        radii=np.asarray(radii, dtype=float),
        capsule_body=np.asarray(cbody, dtype=int),
        box_centers=np.asarray(centers, dtype=float).reshape(-1, 3),
        box_axes=np.asarray(axes, dtype=float).reshape(-1, 3, 3),
        box_half=np.asarray(half, dtype=float).reshape(-1, 3),
        box_body=np.asarray(bbody, dtype=int),
        bodies=np.asarray(body_ids, dtype=int),
    )
    return shapes, d


def _smooth_min(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum: ``min(a, b)`` where they differ by more than ``k``, a fillet below."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def distance_field(shapes: Shapes, voxel: float, blend: float, pad: float) -> tuple[np.ndarray, np.ndarray]:
    """The smooth-union distance on a grid: ``(X, Y, Z)`` values and the ``(3,)`` grid origin.

    Each shape is evaluated only inside its bounding box grown by ``pad`` (where it can change
    the union); elsewhere the field keeps a large value.
    """
    lo, hi = shapes.bounds()
    origin = lo.min(axis=0) - pad - 2 * voxel
    top = hi.max(axis=0) + pad + 2 * voxel
    dims = np.ceil((top - origin) / voxel).astype(int) + 1
    if int(np.prod(dims)) > 60_000_000:
        raise MjmotionError(f"the skin's voxel grid would be {dims.tolist()} voxels; is the skeleton in metres?")
    field = np.full(tuple(dims), 4.0 * pad + 1.0, dtype=np.float64)
    for s in range(shapes.n_shapes):
        i0 = np.maximum(np.floor((lo[s] - pad - origin) / voxel).astype(int), 0)
        i1 = np.minimum(np.ceil((hi[s] + pad - origin) / voxel).astype(int) + 1, dims)
        axes = [origin[k] + voxel * np.arange(i0[k], i1[k]) for k in range(3)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        d = shapes.distance(pts, s).reshape(tuple(i1 - i0))
        sl = tuple(slice(i0[k], i1[k]) for k in range(3))
        field[sl] = _smooth_min(field[sl], d, blend)
    return field, origin


def surface(shapes: Shapes, voxel: float, blend: float, margin: float, smoothing: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """A closed triangle mesh ``margin`` outside the smooth union of ``shapes``.

    Args:
        voxel: grid spacing, metres.
        blend: fillet width of the smooth union, metres.
        margin: how far outside the shapes the surface lies, metres.
        smoothing: Taubin smoothing iterations.
    Returns:
        ``(V, 3)`` vertices and ``(F, 3)`` faces, wound counter-clockwise seen from outside.
    """
    import trimesh
    from skimage import measure

    if shapes.n_shapes == 0:
        raise MjmotionError("the character has no bone long enough to give it a body (every bone is under 1 cm)")
    field, origin = distance_field(shapes, voxel, blend, pad=blend + margin + 2 * voxel)
    # The level a hair off ``margin``: a box face at exactly ``margin`` from a grid plane (axis-aligned
    # boxes in the bind pose) puts several vertices on one grid point, which merge into a pinched edge.
    level = margin + 1e-6 * voxel
    verts, faces, _, _ = measure.marching_cubes(field, level=level, spacing=(voxel, voxel, voxel))
    mesh = trimesh.Trimesh(verts + origin, faces, process=True)
    if smoothing:
        trimesh.smoothing.filter_taubin(mesh, lamb=0.5, nu=0.53, iterations=smoothing)
    if not mesh.is_watertight:
        raise MjmotionError("the character's surface did not close (marching cubes gave open edges); try another voxel size")
    if mesh.volume < 0:
        mesh.invert()
    return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64)
