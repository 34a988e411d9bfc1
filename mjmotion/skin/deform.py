"""Skin deformation: linear blend skinning (seed 000 Eq. 1) and dual-quaternion skinning.

Both take per-frame bone frames — world positions ``(T, N, 3)`` and rotations ``(T, N, 4)`` of
the bodies the skin is bound to — and their bind-pose frames, and return deformed vertices
``(T, V, 3)`` (and normals) for all frames at once.

**LBS** (vertex blending): ``v' = (Σᵢ wᵢ Mᵢ Bᵢ⁻¹) v`` with ``Mᵢ`` the bone's current frame and
``Bᵢ`` its bind frame. The sum is linear in the bone matrices, so each frame is one sparse matrix
product: a ``(V, 4N)`` matrix holding ``wᵢ·(v, 1)`` in bone ``i``'s columns (at most four bones
per row) times the frame's stacked ``[Rᵢ | tᵢ]ᵀ``. Normals go
through the inverse transpose of the blended 3×3 part, computed as its cofactor matrix times the
sign of its determinant (the inverse transpose up to a positive scale, which normalising removes),
so a collapsing joint cannot divide by zero.

**DQS** (Kavan et al. 2007): each bone's rigid motion as a unit dual quaternion, blended with the
same weights after flipping each to the hemisphere of the vertex's main bone, normalised, and
applied. A blend of rigid motions stays rigid: no candy-wrapper under twist, less collapse at a
bent elbow.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot

#: Frames per block where a per-vertex 3×3 (normals, DQS) is formed: bounds memory to ~50 MB for 20k vertices.
CHUNK = 32


def bone_transforms(
    positions: np.ndarray, rotations: np.ndarray, bind_positions: np.ndarray, bind_rotations: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each bone's motion from its bind frame, ``Mᵢ Bᵢ⁻¹`` = rotation ``q`` and translation ``t``.

    Args:
        positions, rotations: ``(T, N, 3)``, ``(T, N, 4)`` current bone frames.
        bind_positions, bind_rotations: ``(N, 3)``, ``(N, 4)`` bind frames.
    Returns:
        ``(T, N, 4)`` rotations and ``(T, N, 3)`` translations: ``v' = q·v + t``.
    """
    q = rot.normalize(rot.multiply(rotations, rot.conjugate(bind_rotations)[None]))
    t = positions - rot.rotate(q, np.broadcast_to(bind_positions, positions.shape))
    return q, t


def _inverse_transpose_times(a: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``A⁻ᵀ n`` up to a positive scale — ``sign(det A) · cof(A) · n``, no division — for
    ``a: (t, 3, 3, V)`` (component-first) and ``n: (3, V)``; returns ``(t, 3, V)``."""
    c0, c1, c2 = a[:, :, 0], a[:, :, 1], a[:, :, 2]  # the columns, each (t, 3, V)
    x12 = _cross(c1, c2)
    sign = np.where(np.einsum("tcv,tcv->tv", c0, x12) < 0, -1.0, 1.0)[:, None]
    return sign * (n[0] * x12 + n[1] * _cross(c2, c0) + n[2] * _cross(c0, c1))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along axis 1 of ``(t, 3, V)`` arrays (component-first: each component contiguous)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2], a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def _unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along axis 1 of ``(t, 3, V)``."""
    return v / np.maximum(np.sqrt(np.einsum("tcv,tcv->tv", v, v)), 1e-12)[:, None]


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate ``v: (t, 3, V)`` (or ``(3, V)``) by unit quaternions ``q: (t, 4, V)``, component-first."""
    w, u = q[:, :1], q[:, 1:]
    v = np.broadcast_to(v, u.shape)
    c = 2.0 * _cross(u, v)
    return v + w * c + _cross(u, c)


def lbs(
    vertices: np.ndarray,
    weights: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    normals: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Linear blend skinning of every frame.

    Args:
        vertices: ``(V, 3)`` bind-pose positions.
        weights: ``(V, N)`` dense weights (rows sum to 1).
        q, t: ``(T, N, 4)``, ``(T, N, 3)`` bone motions from :func:`bone_transforms`.
        normals: ``(V, 3)`` bind-pose normals, or ``None``.
    Returns:
        ``(T, V, 3)`` positions and, if ``normals`` was given, ``(T, V, 3)`` unit normals.
    """
    from scipy import sparse

    used = np.flatnonzero(np.any(weights > 0, axis=0))
    w = weights[:, used]  # (V, n)
    r = rot.to_matrix(q[:, used])  # (T, n, 3, 3)
    m = np.concatenate([r, t[:, used, :, None]], axis=3)  # (T, n, 3, 4): [R | t] per bone
    n_t, n_b = m.shape[:2]
    homog = np.hstack([vertices, np.ones((len(vertices), 1))])  # (V, 4)
    # Row v of s holds wᵢ·(v, 1) in the columns of bone i: v'ᵀ = s[v] @ (Mᵢ stacked); at most 4 bones per row.
    s = sparse.csr_matrix((w[:, :, None] * homog[:, None, :]).reshape(len(vertices), n_b * 4))
    mt = m.transpose(0, 1, 3, 2).reshape(n_t, n_b * 4, 3)
    out = np.empty((n_t, len(vertices), 3))
    for f in range(n_t):
        out[f] = s @ mt[f]
    if normals is None:
        return out, None
    nrm = np.empty_like(out)
    r_flat = r.transpose(0, 2, 3, 1).reshape(n_t * 9, n_b)
    n_cf = np.ascontiguousarray(normals.T)
    for a in range(0, n_t, CHUNK):
        b = min(a + CHUNK, n_t)
        blend = (r_flat[a * 9 : b * 9] @ w.T).reshape(b - a, 3, 3, -1)  # (t, 3, 3, V): Σ wᵢ Rᵢ per vertex
        nrm[a:b] = _unit(_inverse_transpose_times(blend, n_cf)).transpose(0, 2, 1)
    return out, nrm


def _hemisphere_signs(q: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """``(T, N)`` signs making every bone's quaternion agree (dot ≥ 0) with its parent bone's."""
    sign = np.ones(q.shape[:2])
    for j in range(q.shape[1]):
        p = parents[j]
        if p >= 0:
            sign[:, j] = sign[:, p] * np.where(np.sum(q[:, j] * q[:, p], axis=-1) < 0, -1.0, 1.0)
    return sign


def dqs(
    vertices: np.ndarray,
    bones: np.ndarray,
    values: np.ndarray,
    q: np.ndarray,
    t: np.ndarray,
    normals: np.ndarray | None = None,
    parents: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Dual-quaternion skinning of every frame.

    Each vertex blends its bones' dual quaternions flipped to the hemisphere of its main bone
    (the largest weight). Done as one matrix product: bones are first flipped to agree with their
    parent bone, which settles every vertex whose bones then agree with its main bone (nearly all);
    the few others are blended one by one with their own flips.

    Args:
        vertices: ``(V, 3)`` bind-pose positions.
        bones, values: ``(V, K)`` bone indices (``-1`` unused) and weights, the main bone first.
        q, t: ``(T, N, 4)``, ``(T, N, 3)`` bone motions from :func:`bone_transforms`.
        normals: ``(V, 3)`` bind-pose normals, or ``None``.
        parents: ``(N,)`` each bone's parent bone (``-1`` none), for the flips; default none.
    Returns:
        ``(T, V, 3)`` positions and, if ``normals`` was given, ``(T, V, 3)`` unit normals.
    """
    n_t, n_b = q.shape[:2]
    n_v = len(vertices)
    # Dual part d = ½ (0, t) ⊗ q of each bone's unit dual quaternion.
    tq = np.concatenate([np.zeros((*t.shape[:-1], 1)), t], axis=-1)
    dq = np.concatenate([q, 0.5 * rot.multiply(tq, q)], axis=-1)  # (T, N, 8)
    dq *= _hemisphere_signs(q, np.full(n_b, -1) if parents is None else parents)[..., None]
    dense = np.zeros((n_v, n_b))
    rows = np.repeat(np.arange(n_v), bones.shape[1])
    used = bones.ravel() >= 0
    dense[rows[used], bones.ravel()[used]] = values.ravel()[used]
    idx = np.maximum(bones, 0)
    # The (main bone, other bone) pairs that share a vertex: a vertex needs its own flips only
    # where one of its pairs disagrees after the parent flips.
    pairs, pair_of = np.unique(
        np.stack([np.repeat(idx[:, :1], idx.shape[1] - 1, axis=1), idx[:, 1:]], axis=-1).reshape(-1, 2), axis=0, return_inverse=True
    )
    pair_of = np.where(values[:, 1:] > 0, pair_of.reshape(n_v, -1), -1)
    out = np.empty((n_t, n_v, 3))
    nrm = np.empty_like(out) if normals is not None else None
    v_cf = np.ascontiguousarray(vertices.T)
    n_cf = None if normals is None else np.ascontiguousarray(normals.T)
    for a in range(0, n_t, CHUNK):
        b = min(a + CHUNK, n_t)
        blend = (dq[a:b].transpose(0, 2, 1).reshape(-1, n_b) @ dense.T).reshape(b - a, 8, n_v)  # (t, 8, V)
        bad = np.einsum("tpc,tpc->tp", dq[a:b][:, pairs[:, 0], :4], dq[a:b][:, pairs[:, 1], :4]) < 0  # (t, P)
        if bad.any():
            odd = np.any(np.where(pair_of >= 0, bad[:, np.maximum(pair_of, 0)], False), axis=-1)  # (t, V)
            for ti, vi in zip(*np.nonzero(odd)):
                g = dq[a + ti, idx[vi]]  # (K, 8)
                blend[ti, :, vi] = (np.where(g[:, :4] @ g[0, :4] < 0, -1.0, 1.0) * values[vi]) @ g
        br, bd = blend[:, :4], blend[:, 4:]
        norm = np.sqrt(np.einsum("tcv,tcv->tv", br, br))[:, None]
        br, bd = br / norm, bd / norm
        w, u, dw, du = br[:, :1], br[:, 1:], bd[:, :1], bd[:, 1:]
        trans = 2.0 * (w * du - dw * u + _cross(u, du))
        out[a:b] = (_rotate(br, v_cf) + trans).transpose(0, 2, 1)
        if nrm is not None and n_cf is not None:
            nrm[a:b] = _unit(_rotate(br, n_cf)).transpose(0, 2, 1)
    return out, nrm
