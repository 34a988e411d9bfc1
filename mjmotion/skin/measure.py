"""How much of a closed mesh is left near a joint: cross-section area and local volume.

Both look only at the part of the surface within ``radius`` of a point (a joint), so a plane
through the elbow measures the arm and not the torso it also cuts.

* :func:`section_area` — the area the mesh encloses in a plane: each face crossing the plane gives
  one segment, oriented by the face's outward normal, and Green's theorem sums the signed area
  ``½ Σ n·(a × b)`` without joining the segments into loops (a folded, self-crossing collapse
  counts its overlap once with each sign, so it reads as lost area).
* :func:`volume_in_ball` — the volume inside the mesh and inside a ball: vertical lines on a grid
  of columns, each cut by the surface into inside intervals (by crossing parity), clipped to the
  ball. Assumes no other part of the body crosses the ball's columns (true for an arm held out).
"""

from __future__ import annotations

import numpy as np


def _near(vertices: np.ndarray, faces: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Faces whose bounding box reaches within ``radius`` of ``centre``."""
    tri = vertices[faces]
    gap = np.maximum(tri.min(axis=1) - centre, 0.0) + np.maximum(centre - tri.max(axis=1), 0.0)
    return faces[np.linalg.norm(gap, axis=1) <= radius]


def section_area(vertices: np.ndarray, faces: np.ndarray, point: np.ndarray, normal: np.ndarray, radius: float) -> float:
    """Area enclosed by the mesh in the plane through ``point`` with ``normal``, near ``point``.

    Args:
        vertices: ``(V, 3)``; faces: ``(F, 3)`` wound counter-clockwise from outside.
        point, normal: the plane (``normal`` need not be unit).
        radius: only faces reaching this close to ``point`` count, metres.
    Returns:
        square metres.
    """
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    f = _near(vertices, faces, point, radius)
    tri = vertices[f] - point  # (F, 3, 3)
    s = tri @ n  # signed heights (F, 3)
    ends = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        cross = (s[:, i] > 0) != (s[:, j] > 0)
        t = np.where(cross, s[:, i] / np.where(cross, s[:, i] - s[:, j], 1.0), np.nan)
        ends.append(tri[:, i] + t[:, None] * (tri[:, j] - tri[:, i]))
    ends_arr = np.stack(ends, axis=1)  # (F, 3 edges, 3); NaN where the edge does not cross
    crossing = np.isfinite(ends_arr[..., 0])
    keep = crossing.sum(axis=1) == 2
    seg = ends_arr[keep][crossing[keep]].reshape(-1, 2, 3)
    if len(seg) == 0:
        return 0.0
    face_n = np.cross(tri[keep, 1] - tri[keep, 0], tri[keep, 2] - tri[keep, 0])
    a, b = seg[:, 0], seg[:, 1]
    # Counter-clockwise about n puts the outside on the right: (b − a) × n along the face normal.
    flip = np.einsum("ij,ij->i", np.cross(b - a, n), face_n) < 0
    a, b = np.where(flip[:, None], b, a), np.where(flip[:, None], a, b)
    return float(0.5 * np.sum(np.cross(a, b) @ n))


def volume_in_ball(vertices: np.ndarray, faces: np.ndarray, centre: np.ndarray, radius: float, spacing: float) -> float:
    """Volume of the mesh inside the ball (``centre``, ``radius``), by vertical columns ``spacing`` apart.

    Returns cubic metres. Faces reaching within ``2 × radius`` of the centre are used.
    """
    f = _near(vertices, faces, centre, 2.0 * radius)
    tri = vertices[f]
    g = np.arange(-radius + spacing / 2, radius, spacing)
    gx, gy = np.meshgrid(g, g, indexing="ij")
    inside = gx**2 + gy**2 < radius**2
    cols = np.column_stack([gx[inside], gy[inside]]) + centre[:2]  # (C, 2)
    half = np.sqrt(radius**2 - np.sum((cols - centre[:2]) ** 2, axis=1))
    lo, hi = centre[2] - half, centre[2] + half
    p0, e1, e2 = tri[:, 0, :2], tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-18
    p0, e1, e2, det, z = p0[ok], e1[ok], e2[ok], det[ok], tri[ok, :, 2]
    total = 0.0
    for start in range(0, len(cols), 512):
        c = cols[start : start + 512]
        d = c[:, None, :] - p0[None]  # (C, F, 2)
        u = (d[..., 0] * e2[:, 1] - d[..., 1] * e2[:, 0]) / det
        v = (e1[:, 0] * d[..., 1] - e1[:, 1] * d[..., 0]) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1)
        zs = np.sort(np.where(hit, z[:, 0] + u * (z[:, 1] - z[:, 0]) + v * (z[:, 2] - z[:, 0]), np.inf), axis=1)
        most = int(hit.sum(axis=1).max(initial=0))
        zs = zs[:, : most + most % 2]
        enter, leave = zs[:, 0::2], zs[:, 1::2]  # inside between each odd crossing and the next
        a, b = lo[start : start + len(c), None], hi[start : start + len(c), None]
        with np.errstate(invalid="ignore"):
            span = np.minimum(leave, b) - np.maximum(enter, a)
        total += float(np.where(np.isfinite(leave), np.clip(span, 0.0, None), 0.0).sum())
    return total * spacing**2
