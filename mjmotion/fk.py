"""World joint positions of a clip in NumPy, for callers that need nothing else from MuJoCo.

The same kinematic tree :func:`mjmotion.mjcf.compile` builds (a free root at its position, every
other joint a ball at its ``OFFSET`` from the parent, plus a per-frame translation where the joint
has position channels), composed frame-batched down the tree. A fresh ``mjmotion register``
needs only joint positions: this spares it MuJoCo's import (~0.15 s) and the per-frame
``mj_kinematics`` loop. ``tests/test_fk.py`` checks it against MuJoCo (DESIGN: MuJoCo is the
reference FK; any other is checked against it).
"""

from __future__ import annotations

import numpy as np

from . import rotations as rot
from .skeleton import Motion


def joint_positions(motion: Motion) -> np.ndarray:
    """``(T, J, 3)`` world joint positions (metres), as :func:`mjmotion.kinematics.joint_positions`.

    Local rotations are normalised first, as MuJoCo normalises its quaternions.
    """
    skel = motion.skeleton
    t, n = motion.n_frames, skel.n_joints
    local = rot.normalize(motion.rotations)
    # a slide joint moves the body along its parent's axes: the translation replaces the offset
    slides = [j for j in range(1, n) if skel.has_positions(j)] if motion.translations is not None else []
    offsets: np.ndarray = np.broadcast_to(skel.offsets, (t, n, 3))
    if slides:
        offsets = offsets.copy()
        offsets[:, slides] = motion.translations[:, slides]  # type: ignore[index]
    pos = np.empty((t, n, 3))
    world = np.empty((t, n, 4))
    pos[:, 0] = motion.root_positions
    world[:, 0] = local[:, 0]
    depth = np.zeros(n, dtype=int)
    for j in range(1, n):  # parents come first (Skeleton's invariant)
        depth[j] = depth[skel.parents[j]] + 1
    for d in range(1, int(depth.max(initial=0)) + 1):  # one batch per tree level, not per joint
        js = np.flatnonzero(depth == d)
        ps = skel.parents[js]
        pos[:, js] = pos[:, ps] + rot.rotate(world[:, ps], offsets[:, js])
        world[:, js] = rot.multiply(world[:, ps], local[:, js])
    return pos
