"""Skinning weights from bind-pose distance (seed 000 §1.1.2).

"The weights are typically assigned according to the vertex distance from the joint in the bind
pose position. The number of weights per vertex is usually limited to an upper bound value
(usually 1 to 4) and an upper bound may be set on the distance between vertex and joint where a
weight may be assigned. The weights for each vertex are then normalised to sum up to 1."

Distance here is to each body's own geometry (its bone capsules and foot boxes), not to a joint
point: a vertex on the heel is nearest the foot's box even though the ankle joint is as close as
the toe. Per vertex, with ``d₀`` its distance to the nearest body, a body at distance ``d``
gets ``(1 − (d − d₀)/falloff)²`` if ``d − d₀ < falloff`` (the distance bound) — the nearest body
1, bodies about as near (a vertex at the elbow) nearly as much. A smoothing pass averages each
vertex's weights with its mesh neighbours' so weights change gradually across the surface; then
the four largest are kept and normalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Most bones that may move one vertex.
MAX_INFLUENCES = 4


@dataclass(frozen=True, eq=False)
class Weights:
    """Per-vertex bone weights.

    Attributes:
        bones: ``(V, 4)`` indices into the body list the weights were made for (``-1``: unused slot).
        values: ``(V, 4)`` weights, each row summing to 1, unused slots 0, largest first.
    """

    bones: np.ndarray
    values: np.ndarray

    def dense(self, n_bones: int) -> np.ndarray:
        """``(V, n_bones)`` weight matrix."""
        out = np.zeros((len(self.bones), n_bones))
        rows = np.repeat(np.arange(len(self.bones)), self.bones.shape[1])
        used = self.bones.ravel() >= 0
        out[rows[used], self.bones.ravel()[used]] = self.values.ravel()[used]
        return out

    @property
    def counts(self) -> np.ndarray:
        """``(V,)`` number of bones moving each vertex (1–4)."""
        return (self.bones >= 0).sum(axis=1)


def neighbours(faces: np.ndarray, n_vertices: int):
    """Row-normalised vertex adjacency of a triangle mesh (a ``scipy.sparse`` CSR matrix)."""
    from scipy import sparse

    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    a = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n_vertices, n_vertices)).tocsr()
    a.data[:] = 1.0  # duplicate edges count once
    deg = np.asarray(a.sum(axis=1)).ravel()
    return sparse.diags(1.0 / np.maximum(deg, 1.0)) @ a


def top_k(dense: np.ndarray, k: int = MAX_INFLUENCES) -> Weights:
    """The ``k`` largest weights of each row of ``dense: (V, N)``, normalised to sum to 1."""
    k = min(k, dense.shape[1])
    idx = np.argsort(-dense, axis=1, kind="stable")[:, :k]
    val = np.take_along_axis(dense, idx, axis=1)
    val = np.where(val > 1e-6, val, 0.0)
    val[:, 0] = np.where(val[:, 0] > 0, val[:, 0], 1.0)  # every vertex follows at least its nearest bone
    val /= val.sum(axis=1, keepdims=True)
    bones = np.where(val > 0, idx, -1)
    pad = MAX_INFLUENCES - k
    if pad:
        bones = np.hstack([bones, np.full((len(bones), pad), -1)])
        val = np.hstack([val, np.zeros((len(val), pad))])
    return Weights(bones=bones.astype(np.int64), values=val)


def from_distances(distances: np.ndarray, faces: np.ndarray, falloff: float, smoothing: int = 3, k: int = MAX_INFLUENCES) -> Weights:
    """Weights from ``distances: (V, N)`` (each vertex to each body) on the mesh ``faces``.

    Args:
        falloff: the distance bound: a body more than this much farther than the nearest gets no weight, metres.
        smoothing: passes of neighbour averaging (each moves a weight about one edge further).
        k: most influences per vertex (1–4).
    """
    if not 1 <= k <= MAX_INFLUENCES:
        raise ValueError(f"influences per vertex must be 1 to {MAX_INFLUENCES}, got {k}")
    excess = distances - distances.min(axis=1, keepdims=True)
    raw = np.clip(1.0 - excess / falloff, 0.0, None) ** 2
    raw /= raw.sum(axis=1, keepdims=True)
    if smoothing:
        adj = neighbours(faces, len(distances))
        allowed = excess < 1.5 * falloff  # smoothing never carries a weight past the bound
        for _ in range(smoothing):
            raw = np.where(allowed, 0.5 * raw + 0.5 * (adj @ raw), 0.0)
            raw /= raw.sum(axis=1, keepdims=True)
    return top_k(raw, k)
