"""The PCA space of a clip and the style error between two clips (seed 003 §2.5.4–2.5.5, §3.2.1).

A pose is a parameter vector: the root translation (3) and every joint's local quaternion
(4 per joint, sign kept continuous over time). The source's parameters are standardised by
their means ``M`` and standard deviations ``D`` (parameters with zero deviation are dropped);
the principal components are the right singular vectors of the standardised data, the
columns of the loadings ``L``. A score vector ``S`` gives back a pose
``P = (L S)ᵀ ⊙ D + M`` (§3.2.1) with every quaternion renormalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .errors import MjmotionError
from .skeleton import Motion, Skeleton

#: Relative size below which a parameter's standard deviation counts as zero (constant channel).
ZERO_DEVIATION = 1e-9


def pose_parameters(motion: Motion, translations: bool = False) -> np.ndarray:
    """Per-frame pose parameters ``(T, N)``: root translation (3), then quaternions (4 J).

    Quaternions are made sign-continuous over time (``rotations.make_continuous``). With
    ``translations``, the local translations of inner joints that carry position channels are
    appended (3 each, in joint order) so that such skeletons round-trip exactly.
    """
    q = rot.make_continuous(motion.rotations, axis=0)
    parts = [motion.root_positions, q.reshape(motion.n_frames, -1)]
    if translations:
        moving = _moving_joints(motion.skeleton)
        if moving.size:
            parts.append(motion.local_translations()[:, moving].reshape(motion.n_frames, -1))
    return np.concatenate(parts, axis=1)


def _moving_joints(skeleton: Skeleton) -> np.ndarray:
    return np.array([j for j in range(1, skeleton.n_joints) if skeleton.has_positions(j)], dtype=int)


@dataclass(frozen=True, eq=False)
class PoseSpace:
    """The principal-component space of one source clip.

    Attributes:
        skeleton: the source's skeleton (clips projected into the space must share its topology).
        fps: the source's frame rate (given to reconstructed motions).
        means: ``M``, ``(N,)`` mean of every pose parameter over the source's frames.
        deviations: ``D``, ``(N,)`` standard deviation of every parameter (0 for dropped ones).
        kept: ``(N,) bool``, parameters with non-zero deviation (the PCA's variables).
        loadings: ``L``, ``(P, C)`` orthonormal columns, one principal component each, ``P`` =
            ``kept.sum()``; sign chosen so each column's largest-magnitude entry is positive.
        variances: ``(C,)`` variance of the source's scores along each component, descending.
        source_scores: ``(T, C)`` the source's own path through the space.
        translations: whether inner-joint translations are parameters (see ``pose_parameters``).
        template: a source motion the reconstructed motions copy non-pose fields from.
    """

    skeleton: Skeleton
    fps: float
    means: np.ndarray
    deviations: np.ndarray
    kept: np.ndarray
    loadings: np.ndarray
    variances: np.ndarray
    source_scores: np.ndarray
    translations: bool
    template: Motion

    def __repr__(self) -> str:
        """``PoseSpace('drive', 22 joints, components=12, parameters=66)``: no arrays."""
        from .summary import fields

        return fields(
            "PoseSpace",
            repr(self.template.name),
            f"{self.skeleton.n_joints} joints",
            components=int(self.loadings.shape[1]),
            parameters=int(self.kept.sum()),
        )

    # --- construction ----------------------------------------------------------------------
    @classmethod
    def fit(cls, source: Motion, translations: bool = False) -> PoseSpace:
        """PCA of ``source`` (seed 003 §2.5.4): standardise, then an SVD of the data matrix."""
        if source.n_frames < 2:
            raise MjmotionError(f"{source.name or 'clip'}: PCA needs at least 2 frames, got {source.n_frames}")
        x = pose_parameters(source, translations)
        if not np.all(np.isfinite(x)):
            raise MjmotionError(f"{source.name or 'clip'}: pose parameters contain NaN or infinity")
        means = x.mean(axis=0)
        dev = x.std(axis=0, ddof=1)
        kept = dev > ZERO_DEVIATION * np.maximum(1.0, np.abs(means))
        if not kept.any():
            raise MjmotionError(f"{source.name or 'clip'}: every pose parameter is constant; nothing to analyse")
        dev = np.where(kept, dev, 0.0)
        z = (x[:, kept] - means[kept]) / dev[kept]
        _, sing, vt = np.linalg.svd(z, full_matrices=False)
        loadings = vt.T
        # a deterministic sign per component: its largest loading positive
        big = np.argmax(np.abs(loadings), axis=0)
        loadings = loadings * np.sign(loadings[big, np.arange(loadings.shape[1])])
        variances = sing**2 / (source.n_frames - 1)
        return cls(
            skeleton=source.skeleton,
            fps=source.fps,
            means=means,
            deviations=dev,
            kept=kept,
            loadings=loadings,
            variances=variances,
            source_scores=z @ loadings,
            translations=translations,
            template=source[0:1],
        )

    # --- sizes -------------------------------------------------------------------------------
    @property
    def n_components(self) -> int:
        return int(self.loadings.shape[1])

    @property
    def explained(self) -> np.ndarray:
        """``(C,)`` fraction of the total variance along each component."""
        total = float(self.variances.sum())
        return self.variances / total

    @property
    def cumulative(self) -> np.ndarray:
        """``(C,)`` fraction of the variance captured by the first 1, 2, … components."""
        return np.cumsum(self.explained)

    def components_for(self, variance: float) -> int:
        """Smallest ``k`` whose first ``k`` components explain at least ``variance`` (0 < variance ≤ 1)."""
        if not (0.0 < variance <= 1.0):
            raise MjmotionError(f"variance fraction must be in (0, 1], got {variance}")
        k = int(np.searchsorted(self.cumulative, variance - 1e-12)) + 1
        return min(k, self.n_components)

    def _check_k(self, k: int | None) -> int:
        if k is None:
            return self.n_components
        if not (1 <= k <= self.n_components):
            raise MjmotionError(f"number of components must be 1…{self.n_components}, got {k}")
        return int(k)

    # --- projection and reconstruction -------------------------------------------------------
    def parameters(self, motion: Motion) -> np.ndarray:
        """Pose parameters ``(T, N)`` of ``motion``, quaternion signs matched to the source's.

        Each joint's sequence is made continuous, then flipped as a whole if that brings it
        closer to the source's mean quaternion (so a clip's sign choice does not change its scores).
        """
        self.skeleton.require_same_topology(motion.skeleton, "the clip and the PCA source")
        x = pose_parameters(motion, self.translations)
        j = self.skeleton.n_joints
        q = x[:, 3 : 3 + 4 * j].reshape(-1, j, 4)
        ref = self.means[3 : 3 + 4 * j].reshape(j, 4)
        flip = np.where(np.einsum("tjc,jc->j", q, ref) < 0, -1.0, 1.0)
        x[:, 3 : 3 + 4 * j] = (q * flip[None, :, None]).reshape(len(x), -1)
        return x

    def scores(self, motion: Motion, k: int | None = None) -> np.ndarray:
        """Scores ``(T, k)`` of ``motion`` in the first ``k`` components (all by default)."""
        k = self._check_k(k)
        return self.scores_of_parameters(self.parameters(motion), k)

    def scores_of_parameters(self, x: np.ndarray, k: int | None = None) -> np.ndarray:
        """Scores ``(T, k)`` of pose parameters ``x: (T, N)``."""
        k = self._check_k(k)
        z = (x[:, self.kept] - self.means[self.kept]) / self.deviations[self.kept]
        return z @ self.loadings[:, :k]

    def parameters_of_scores(self, scores: np.ndarray) -> np.ndarray:
        """``P = (L S)ᵀ ⊙ D + M`` (§3.2.1) for ``scores: (T, k)`` → raw parameters ``(T, N)``.

        Dropped (constant) parameters take their mean. Quaternions are not yet renormalised.
        """
        s = np.atleast_2d(np.asarray(scores, dtype=float))
        k = self._check_k(s.shape[1])
        out = np.broadcast_to(self.means, (s.shape[0], self.means.size)).copy()
        out[:, self.kept] += (s @ self.loadings[:, :k].T) * self.deviations[self.kept]
        return out

    def motion_of_parameters(self, x: np.ndarray, name: str = "") -> Motion:
        """A :class:`Motion` from raw parameters ``(T, N)``, quaternions renormalised."""
        j = self.skeleton.n_joints
        t = x.shape[0]
        q = rot.normalize(x[:, 3 : 3 + 4 * j].reshape(t, j, 4))
        tr = None
        if self.template.translations is not None:
            tr = np.broadcast_to(self.template.translations[0], (t, j, 3)).copy()
            moving = _moving_joints(self.skeleton)
            if self.translations and moving.size:
                tr[:, moving] = x[:, 3 + 4 * j :].reshape(t, moving.size, 3)
        return self.template.replace(
            root_positions=x[:, :3].copy(),
            rotations=q,
            translations=tr,
            fps=self.fps,
            name=name or self.template.name,
        )

    def motion(self, scores: np.ndarray, name: str = "") -> Motion:
        """The clip whose frame ``t`` is the pose of ``scores[t]`` (``(T, k)``)."""
        return self.motion_of_parameters(self.parameters_of_scores(scores), name)

    def reconstruct(self, motion: Motion, k: int | None = None) -> Motion:
        """``motion`` projected onto the first ``k`` components and back."""
        return self.motion(self.scores(motion, k), name=motion.name)


def reconstruction_errors(source: Motion, ks: list[int] | np.ndarray | None = None) -> dict[int, float]:
    """RMS joint-position error (metres, over frames and joints) of ``k``-component reconstructions.

    ``ks`` defaults to 1…C. Joint positions by MuJoCo forward kinematics.
    """
    from . import kinematics, mjcf

    space = PoseSpace.fit(source)
    ks = list(range(1, space.n_components + 1)) if ks is None else [int(k) for k in ks]
    compiled = mjcf.compile(source.skeleton)
    ref = kinematics.forward(compiled, source).joint_positions
    out: dict[int, float] = {}
    for k in ks:
        p = kinematics.forward(compiled, space.reconstruct(source, k)).joint_positions
        out[k] = float(np.sqrt(np.mean(np.sum((p - ref) ** 2, axis=-1))))
    return out


def style_rmse(source: Motion, adapted: Motion, variance: float = 0.7, space: PoseSpace | None = None) -> tuple[float, int]:
    """Style error of ``adapted`` against ``source`` (seed 003 §2.5.5; docs/METRICS.md "Style").

    PCA of ``source``; ``k`` = smallest number of components explaining ≥ ``variance``; both
    clips projected into the top-``k`` space, frames paired one to one;
    ``rmse = sqrt(mean_t |s_t − a_t|²)``. Returns ``(rmse, k)``. ``space``: ``PoseSpace.fit(source)``
    when the caller already has it.
    """
    if adapted.n_frames != source.n_frames:
        raise MjmotionError(
            f"style_rmse pairs frames one to one: source {source.name!r} has {source.n_frames} frames, "
            f"adapted {adapted.name!r} has {adapted.n_frames}"
        )
    space = space or PoseSpace.fit(source)
    k = space.components_for(variance)
    s = space.source_scores[:, :k]
    a = space.scores(adapted, k)
    return float(np.sqrt(np.mean(np.sum((s - a) ** 2, axis=1)))), k


def rotation_flips(motion: Motion, max_step: float = 2.5) -> list[tuple[int, str]]:
    """``(frame, joint)`` where a joint's local rotation turns more than ``max_step`` radians in one frame.

    Such jumps (a limb's twist solved on the other branch, e.g. upper arm and forearm both turned
    by 180°) leave world positions continuous but put two far-apart clusters into the quaternion
    parameters: the PCA then mixes branches and new paths through the space give distorted poses.
    """
    q = motion.rotations
    frames, joints = np.nonzero(rot.angle_between(q[:-1], q[1:]) > max_step)
    return [(int(f) + 1, motion.skeleton.names[j]) for f, j in zip(frames, joints)]
