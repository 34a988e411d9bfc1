"""The caps every input, option and result is held to (the README's "Limits" paragraph).

Each limit is far above what real motion capture needs and low enough that a refused input is
refused in seconds and in a bounded amount of memory: a file is measured before it is read, a
clip's size is computed from its header, a resample's from its duration and rate, before
anything is allocated. :func:`check_motion_size` is the one check of a clip's size.
"""

from __future__ import annotations

from .errors import MjmotionError

#: Largest BVH or score file read (bytes): 75x the largest shared clip (3.4 MB); about an hour
#: of a 31-joint CMU skeleton at 120 fps.
MAX_FILE_BYTES = 256 * 2**20
#: Largest JSON file read (bytes): stream scripts, joint weights.
MAX_JSON_BYTES = 2**20
#: Most joints a BVH file may declare, in any shape (a chain that deep, or one joint with that
#: many children). A human skeleton with fingers and face has a few hundred.
MAX_JOINTS = 10_000
#: Most joints compiled into one MuJoCo model (``mjcf.MAX_DEPTH`` caps the depth at 256):
#: measured 1.5 s to compile 1,000 joints, 6 s for 3,000.
MAX_MODEL_JOINTS = 1_000
#: Most frames of any clip read, resampled or made (2.3 hours at 120 fps).
MAX_FRAMES = 1_000_000
#: Most frames x joints of one clip: 2**25, 1 GiB of rotation quaternions (a 31-joint CMU
#: skeleton: the full MAX_FRAMES; a 100-joint one: 335,000 frames, 46 minutes at 120 fps).
MAX_JOINT_FRAMES = 2**25
#: Frame rates (frames per second) a file may declare or an option may ask for.
MIN_FPS, MAX_FPS = 0.1, 10_000.0
#: Largest coordinate of a position or offset, metres (after the unit conversion).
MAX_COORD_M = 1e5
#: Most characters in one render.
MAX_ACTORS = 16
#: Widest point cloud a registration takes, in frames (2L+1: ``register --window``; half-windows up to 500).
MAX_WINDOW = 1001
#: Video frame rates a render takes (``render --fps``, :func:`mjmotion.render.build_scene`).
MIN_VIDEO_FPS, MAX_VIDEO_FPS = 1.0, 240.0
#: Most principal-component scores per frame of a score file.
MAX_COMPONENTS = 4096


def check_motion_size(frames: int | float, joints: int, what: str) -> None:
    """Refuse a clip of ``frames`` frames of ``joints`` joints over :data:`MAX_FRAMES` or
    :data:`MAX_JOINT_FRAMES`; ``what`` begins the message (an option, a file and field)."""
    if not frames <= MAX_FRAMES:  # (NaN fails too)
        raise MjmotionError(f"{what}: {_count(frames)} frames, more than the limit of {MAX_FRAMES:,} frames per clip")
    if frames * max(joints, 1) > MAX_JOINT_FRAMES:
        raise MjmotionError(
            f"{what}: {_count(frames)} frames x {joints} joints, more than the limit of {MAX_JOINT_FRAMES:,} joint-frames per clip "
            f"(at most {MAX_JOINT_FRAMES // max(joints, 1):,} frames of this skeleton)"
        )


def _count(n: int | float) -> str:
    if isinstance(n, int) or (n == n and abs(n) < 1e15 and float(n).is_integer()):
        return f"{int(n):,}"
    return f"{n:.3g}"
