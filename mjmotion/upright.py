"""Which file axis a clip's body stands along: the check behind the ``--up`` note.

Nothing in a BVH file says which axis is up (the format's norm is Y; some exporters write Z). A
Z-up file read as Y-up lies on its side: its floor is detected half a metre up, and every ground
metric measures a body lying down. The body itself tells: in nearly every frame of a standing,
walking or running clip the head is above the feet, so the file axis closest to the feet-to-head
direction in most frames is its up axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import fk
from .skeleton import Motion, up_matrix

#: An axis is the body's when the feet-to-head direction is closest to it in at least this share of frames.
MAJORITY = 0.6
#: Frames looked at, evenly spread (forward kinematics of a long clip's every frame would add nothing).
SAMPLES = 240
_AXES = "xyz"


@dataclass(frozen=True)
class Standing:
    """The signed file axis (``"+y"``, ``"-z"``, …) the body stands along, and in what share of the frames looked at."""

    axis: str
    share: float


def standing_axis(motion: Motion) -> Standing | None:
    """The signed file axis the feet-to-head direction (the head joint minus the ankles' midpoint) is
    closest to in at least :data:`MAJORITY` of ``motion``'s frames (every k-th, at most :data:`SAMPLES`),
    or None: no head or foot found by name, or no axis holding a majority (a clip that changes
    posture, half of it lying). A body lying the same way throughout has an axis: the horizontal
    one its head points along, which no look at the poses alone tells from a standing body read
    with the wrong up axis."""
    skel = motion.skeleton
    head, feet = skel.head(), skel.feet()
    if head is None or not feet or motion.n_frames == 0:
        return None
    pos = fk.joint_positions(motion[:: -(-motion.n_frames // SAMPLES)])  # (S, J, 3), the Z-up world
    ankles = [a for a, _ in feet.values()]
    v = pos[:, head] - pos[:, ankles].mean(axis=1)  # (S, 3)
    v = v @ up_matrix(skel.up)  # back to the file's axes (the matrix is a rotation: its inverse is its transpose)
    i = np.abs(v).argmax(axis=1)
    sign = np.sign(v[np.arange(len(v)), i])
    labels = [("+" if s >= 0 else "-") + _AXES[k] for k, s in zip(i, sign)]
    best = max(set(labels), key=labels.count)
    share = labels.count(best) / len(labels)
    return Standing(best, share) if share >= MAJORITY else None


def up_note(motion: Motion, name: str | None = None, standing: Standing | None = None) -> list[str]:
    """One ``note:`` line when ``motion``'s body stands along another file axis than the up axis it was
    read with (``--up``), naming the option that reads it upright if there is one; else nothing.
    ``standing``: its :func:`standing_axis`, if known. The advice holds for a standing, walking or
    running body (a clip of a body lying down reads the same, and is told so)."""
    up = motion.skeleton.up
    standing = standing if standing is not None else standing_axis(motion)
    if standing is None or standing.axis == "+" + up:
        return []
    fix = f"read it with --up {standing.axis[1]}" if standing.axis in ("+y", "+z") else "no --up reads it upright (y and z only)"
    return [
        f"note: {name or motion.name or 'the clip'}: its head is above its feet along the file's {standing.axis.upper()} axis in "
        f"{standing.share:.0%} of the frames, not +{up.upper()} as --up {up} reads them: unless the body lies down in this clip, {fix}"
    ]
