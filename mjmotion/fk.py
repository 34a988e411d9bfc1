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
    pos = np.empty((t, n, 3))
    world = np.empty((t, n, 4))
    pos[:, 0] = motion.root_positions
    world[:, 0] = local[:, 0]
    for j in range(1, n):
        p = int(skel.parents[j])
        # a slide joint moves the body along its parent's axes: the translation replaces the offset
        offset = motion.translations[:, j] if motion.translations is not None and skel.has_positions(j) else skel.offsets[j]
        pos[:, j] = pos[:, p] + rot.rotate(world[:, p], offset)
        world[:, j] = rot.multiply(world[:, p], local[:, j])
    return pos
