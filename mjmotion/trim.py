"""A clip's leading transient: a T-pose and the frames interpolating out of it, found once when reading.

cgspeed's daz conversions open with a T-pose frame and three frames interpolating into the
capture (mocap/SOURCES.md: start at frame 4); a few CMU files open with a glitch (16_15's left
arm zeroed in frames 0–1, iClone 007_04's rest pose at another place in frame 0). Every verb
reads clips through :func:`mjmotion.commands._common.load`, which skips these frames by the rule
here unless ``--keep-start`` is given or a frame range is chosen, so a registration grid, a
blend, a stream and a render start in the capture, like ``evaluate``.
"""

from __future__ import annotations

import numpy as np

from . import rotations as rot
from .skeleton import Motion

#: Only this many leading frames can be a transient (after a held pose).
MAX_FRAMES = 10
#: A step in which no joint turns more than this (radians) holds the pose: capture always moves a
#: little, so leading frames of exactly one pose are a T-pose (or rest pose) held by the exporter.
HOLD = 1e-6
#: A step whose fastest joint turns faster than this many times the clip's 99th-percentile step
#: is a spike (daz frames 0→3: 4–7×; steady captures: under 2×) ...
SPIKE_FACTOR = 4.0
#: ... and the steps right after the last spike stay in the transient while they are above this
#: factor (daz step 3→4: 2.5–4.7×; the first captured step 4→5: at most 1.9× on the shared clips).
TAIL_FACTOR = 2.2


def peak_joint_speeds(motion: Motion) -> np.ndarray:
    """``(T-1,)`` the fastest joint's angular speed (rad/s) in each step between frames."""
    q = motion.rotations
    return rot.angle_between(q[:-1], q[1:]).max(axis=1) * motion.fps


def leading_transient(motion: Motion, max_frames: int = MAX_FRAMES, factor: float = SPIKE_FACTOR, tail: float = TAIL_FACTOR) -> int:
    """Frames to skip at the start: a T-pose frame (or a T-pose held over several frames: steps that
    turn no joint more than :data:`HOLD`) and the frames interpolating out of it.

    After the held frames, the last of the next ``max_frames`` steps whose fastest joint exceeds
    ``factor`` × the clip's 99th-percentile step marks the transient; the steps right after it that
    still exceed ``tail`` × that percentile belong to it too. 0 when nothing stands out (a held pose
    that the motion leaves smoothly is kept: a subject standing still), and for clips shorter than
    ``4 · max_frames`` frames after the hold (too short to tell a transient from the motion).
    """
    if motion.n_frames < 4 * max_frames:
        return 0
    peak = peak_joint_speeds(motion)
    moving = np.flatnonzero(peak > HOLD * motion.fps)
    held = int(moving[0]) if moving.size else len(peak)
    if motion.n_frames - held < 4 * max_frames:
        return 0
    ref = max(float(np.percentile(peak[held + max_frames :], 99)), 1e-9)
    big = np.flatnonzero(peak[held : held + max_frames] > factor * ref)
    if not big.size:
        return 0
    end = held + max_frames
    k = held + int(big[-1]) + 1
    while k < end and peak[k] > tail * ref:
        k += 1
    return k


def skip_leading_transient(motion: Motion, keep_start: bool = False) -> tuple[Motion, int]:
    """``(motion without its leading transient, frames skipped)``; ``keep_start`` (the verbs'
    and the studio's ``--keep-start``) keeps every frame."""
    if keep_start:
        return motion, 0
    k = leading_transient(motion)
    return (motion[k:] if k else motion), k
