"""Re-timing and rigid floor-plane moves of a clip: the ground truth that registration recovers."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from . import rotations as rot
from .errors import MjmotionError
from .skeleton import Motion


def floor_transform(motion: Motion, theta: float, translation: tuple[float, float] = (0.0, 0.0)) -> Motion:
    """Rotate ``motion`` by ``theta`` radians about the vertical axis through the world origin,
    then translate it by ``translation = (tx, ty)`` metres on the floor.

    A point ``p`` goes to ``Rz(theta) p + (tx, ty, 0)``; the root's orientation is turned by
    the same ``Rz``.
    """
    qz = rot.about_z(theta)
    root = rot.rotate(qz, motion.root_positions) + np.array([translation[0], translation[1], 0.0])
    q = motion.rotations.copy()
    q[:, 0] = rot.multiply(qz, q[:, 0])
    return motion.replace(root_positions=root, rotations=q)


def timewarp(motion: Motion, w: Callable[[np.ndarray], np.ndarray], n_frames: int) -> Motion:
    """The clip re-timed: frame ``i`` of the result shows ``motion`` at fractional frame ``w(i)``.

    ``w`` maps result frame indices ``(n,)`` to source frame indices and must be strictly
    increasing over ``0 … n_frames-1`` and stay inside the source clip.
    """
    if int(n_frames) < 1:
        raise MjmotionError(f"timewarp: n_frames {n_frames}; expected at least one frame")
    i = np.arange(n_frames, dtype=float)
    src = np.asarray(w(i), dtype=float)
    if src.shape != i.shape or not np.all(np.isfinite(src)):
        raise MjmotionError("a timewarp function must return one finite source frame per frame")
    if np.any(np.diff(src) <= 0):
        raise MjmotionError("a timewarp function must be strictly increasing")
    if src[0] < -1e-9 or src[-1] > motion.n_frames - 1 + 1e-9:
        raise MjmotionError(f"the timewarp reaches frames {src[0]:.2f}…{src[-1]:.2f} outside the clip (0…{motion.n_frames - 1})")
    root, q, tr = motion.sample(src)
    return motion.replace(root_positions=root, rotations=q, translations=tr)
