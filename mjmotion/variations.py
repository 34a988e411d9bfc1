"""Shot variations along new paths through a clip's PCA space (seed 003 §3).

A :class:`ScorePath` is a sequence of score vectors in the source's PCA space (``style.PoseSpace``)
plus, for each of its frames, the source frames it stands for (used for the detail the top ``k``
components do not carry, and for where the feet and the second hand belong). From the source's
own path:

* :func:`scaled_path` — exaggerate (factor > 1) or mute (< 1) by scaling the path about its
  centre, or about the centre of a named segment with tapered ends (§3.2.3, Figure 3.7 red/green);
* :func:`aborted_path` — follow the source to frame ``f``, then leave for the rest pose's scores
  over ``N`` frames (§3.2.3, Figure 3.7 orange);
* :func:`explicit_path` — a user's own scores (CSV/NPY).

:func:`synthesise` turns a path into a motion with ``P = (L S)ᵀ ⊙ D + M``; :func:`clean_up` repairs
the artefacts §3.3 names: feet that slide or float (held to the source's foot placement with
two-bone leg IK) and a second hand that leaves the bat/club (returned to its source placement
relative to the first hand with two-bone arm IK).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import kinematics, mjcf
from . import rotations as rot
from .errors import MjmotionError
from .ik import analytic
from .skeleton import Motion, Skeleton
from .style import PoseSpace, rotation_flips, style_rmse

#: Variance the controlled components explain by default. The style error's 70 % (seed §2.5.4)
#: measures; for making variants more components keep the limbs coordinated (on the bundled
#: drive, scaling only the top two turns the bat against the arms).
DEFAULT_VARIANCE = 0.9
#: Fraction of a named segment (at each end) over which exaggeration fades in and out.
SEGMENT_TAPER = 0.25
#: Foot height (m) under which the source's foot placement is held (METRICS.md h_c = 0.05 plus margin).
PLANT_HEIGHT = 0.08
#: Seconds over which a foot or hand correction fades in and out at the ends of a plant.
FADE_S = 0.1
#: A foot whose footprint moves more than this (m) during an abort's return steps instead of sliding …
STEP_M = 0.05
#: … lifting its contact point this high (m) at mid-step.
STEP_LIFT = 0.12


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


@dataclass(frozen=True, eq=False)
class ScorePath:
    """A path through a PCA space.

    Attributes:
        scores: ``(T', C)`` scores on every component of the space; the first ``k`` are the
            path the user controls, the rest carry the source's detail (zero for pure paths).
        k: number of controlled components.
        frame_a, frame_b: ``(T',) int`` source frames each frame stands for …
        weight: ``(T',)`` … as ``(1 − w)·frame_a + w·frame_b``.
        label: a name for plots and reports.
        shift_b: ``(3,)`` metres added to the source's world positions at ``frame_b`` (an abort
            that returns to the rest pose where the character stands, not where the source ended).
    """

    scores: np.ndarray
    k: int
    frame_a: np.ndarray
    frame_b: np.ndarray
    weight: np.ndarray
    label: str = ""
    shift_b: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def n_frames(self) -> int:
        return int(self.scores.shape[0])

    @property
    def controlled(self) -> np.ndarray:
        """``(T', k)`` the scores of the controlled components."""
        return self.scores[:, : self.k]


def source_path(space: PoseSpace, k: int, detail: bool = True) -> ScorePath:
    """The source's own path with ``k`` controlled components (detail: the remaining scores kept)."""
    k = space._check_k(k)
    s = space.source_scores.copy()
    if not detail:
        s[:, k:] = 0.0
    t = np.arange(s.shape[0])
    return ScorePath(s, k, t, t, np.zeros(len(t)), "source")


def segment_weights(n_frames: int, segment: tuple[int, int] | None, taper: float = SEGMENT_TAPER) -> np.ndarray:
    """``(T,)`` 1 inside ``segment = (a, b)`` (half-open), cosine tapers of ``taper·(b−a)`` frames at its ends, 0 outside.

    ``None`` → 1 everywhere (the whole path is scaled, §3.2.3).
    """
    if segment is None:
        return np.ones(n_frames)
    a, b = _check_segment(segment, n_frames)
    w = np.zeros(n_frames)
    n = b - a
    ramp = max(1, round(taper * n))
    u = np.arange(n, dtype=float)
    up = np.clip((u + 1) / (ramp + 1), 0.0, 1.0)
    down = np.clip((n - u) / (ramp + 1), 0.0, 1.0)
    w[a:b] = np.sin(0.5 * np.pi * np.minimum(up, down)) ** 2
    return w


def _check_segment(segment: tuple[int, int], n_frames: int) -> tuple[int, int]:
    a, b = (int(x) for x in segment)
    if a < 0:
        a += n_frames
    if b < 0:
        b += n_frames
    if not (0 <= a < b <= n_frames) or b - a < 3:
        raise MjmotionError(f"segment {segment[0]}:{segment[1]} must select at least 3 of the clip's {n_frames} frames")
    return a, b


def scaled_path(path: ScorePath, factor: float, segment: tuple[int, int] | None = None) -> ScorePath:
    """Exaggerate (``factor`` > 1) or mute (< 1) ``path`` (§3.2.3, Figure 3.7).

    The controlled scores move away from (or toward) the centre ``c`` (mean over the segment,
    or the whole path): ``s' = s + w(t)(factor − 1)(s − c)`` with ``w`` from :func:`segment_weights`.
    """
    if not (np.isfinite(factor) and factor > 0):
        raise MjmotionError(f"scale factor must be a positive number, got {factor}")
    w = segment_weights(path.n_frames, segment)
    s = path.scores.copy()
    ctrl = s[:, : path.k]
    centre = ctrl[w > 0].mean(axis=0)  # the segment's centre (every frame of the segment has w > 0)
    s[:, : path.k] = ctrl + (w * (factor - 1.0))[:, None] * (ctrl - centre)
    return replace(path, scores=s, label=f"scale {factor:g}")


def default_abort_frames(path: ScorePath, frame: int, rest_frame: int, fps: float) -> int:
    """Frames to reach the rest pose: the source's mean speed through the space, at least 0.25 s.

    The return leg covers the distance ``|S_rest − S_f|`` at the average speed of the source's
    path, so joint speeds stay within those of the source (§3.2.3 "heads straight to the rest pose").
    """
    ctrl = path.controlled
    speed = np.linalg.norm(np.diff(ctrl, axis=0), axis=1)
    mean_speed = float(np.mean(speed)) if speed.size else 0.0
    dist = float(np.linalg.norm(ctrl[rest_frame] - ctrl[frame]))
    need = int(np.ceil(1.5 * dist / mean_speed)) if mean_speed > 0 else 0
    return max(need, round(0.25 * fps), 2)


def rest_in_place(space: PoseSpace, path: ScorePath, frame: int, rest_frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Scores ``(C,)`` of the rest pose moved over the floor to where the character stands at ``frame``, and that move ``(3,)``.

    "Where it stands" is its feet: the rest pose is shifted so that the foot that moves least
    between the two frames (the anchor: a golfer's either foot, a batsman's back foot) stays
    where it is at ``frame``; the other foot steps (a kick's run-up is not undone). The
    rest frame's parameters come back exactly from all its scores; the root moves by the shift
    and the result is projected again on every component, so nothing is lost.
    """
    x = space.parameters_of_scores(path.scores[[frame, rest_frame]])
    two = space.motion_of_parameters(x)
    feet = [a for a, _ in space.skeleton.feet().values()]
    if feet:
        p = kinematics.forward(mjcf.compile(space.skeleton), two).joint_positions[:, feet]
        moves = (p[0] - p[1])[:, :2]
        delta = moves[int(np.argmin(np.linalg.norm(moves, axis=-1)))]
    else:
        delta = x[0, :3] - x[1, :3]
    move = np.array([delta[0], delta[1], 0.0])
    x[1, :2] += move[:2]
    return space.scores_of_parameters(x[1:2])[0], move


def aborted_path(
    path: ScorePath,
    frame: int,
    n_frames: int | None = None,
    rest_frame: int = -1,
    fps: float = 120.0,
    space: PoseSpace | None = None,
) -> ScorePath:
    """Follow ``path`` up to ``frame``, then head for the rest pose's scores over ``n_frames`` (§3.2.3, Figure 3.7).

    The return leg is a cubic Hermite from the score (and score velocity) at ``frame`` to the
    rest pose's score at rest, so the motion neither jerks at ``frame`` nor at the end. The
    detail components fade from frame ``frame``'s to the rest frame's with the same timing.
    Output: ``frame + 1 + n_frames`` frames, the last one the rest pose. With ``space``, the
    rest pose is taken where the character stands at ``frame`` (:func:`rest_in_place`): a shot
    with a run-up or a step does not glide back to where the source ended.
    """
    t = path.n_frames
    if not (0 < frame < t - 1):
        raise MjmotionError(f"abort frame must be between 1 and {t - 2} for a {t}-frame clip, got {frame}")
    rest = rest_frame + t if rest_frame < 0 else rest_frame
    if not (0 <= rest < t):
        raise MjmotionError(f"rest frame {rest_frame} is outside the clip's {t} frames")
    p0 = path.scores[frame]
    p1, move = path.scores[rest], np.zeros(3)
    if space is not None:
        p1, move = rest_in_place(space, path, frame, rest)
    v0 = np.zeros_like(p0)
    v0[: path.k] = path.scores[frame, : path.k] - path.scores[frame - 1, : path.k]  # score velocity per frame

    def leg_of(n: int) -> tuple[np.ndarray, np.ndarray]:
        u = (np.arange(1, n + 1) / n)[:, None]
        h00, h10, h01 = (
            2 * u**3 - 3 * u**2 + 1,
            u**3 - 2 * u**2 + u,
            -2 * u**3 + 3 * u**2,
        )
        return h00 * p0 + h10 * (n * v0) + h01 * p1, h01

    if n_frames is None:
        n = default_abort_frames(path, frame, rest, fps)
        if space is not None:
            # slow the return until no joint turns faster than anywhere in the source path
            n = _abort_frames_within_speed(space, path, frame, n, leg_of)
    else:
        n = int(n_frames)
    if n < 1:
        raise MjmotionError(f"abort needs at least 1 frame to reach the rest pose, got {n_frames}")
    leg, h01 = leg_of(n)
    scores = np.vstack([path.scores[: frame + 1], leg])
    w = np.concatenate([np.zeros(frame + 1), h01[:, 0]])
    fa = np.concatenate([path.frame_a[: frame + 1], np.full(n, path.frame_a[frame])])
    fb = np.concatenate([path.frame_b[: frame + 1], np.full(n, path.frame_b[rest])])
    return ScorePath(scores, path.k, fa, fb, w, f"abort at {frame}", path.shift_b + move)


def _local_speeds(q: np.ndarray) -> np.ndarray:
    """``(T-1, J)`` radians per frame turned by every joint's local rotation ``q: (T, J, 4)``."""
    d = rot.multiply(rot.conjugate(q[:-1]), q[1:])
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def _abort_frames_within_speed(space: PoseSpace, path: ScorePath, frame: int, n: int, leg_of) -> int:
    """Frames for the return leg so its peak joint speed stays within the source path's (a few refinements)."""
    limit = _local_speeds(space.motion(path.scores).rotations).max()
    for _ in range(6):
        leg, _ = leg_of(n)
        q = space.motion(np.vstack([path.scores[frame : frame + 1], leg])).rotations
        ratio = _local_speeds(q).max() / max(limit, 1e-12)
        if ratio <= 1.0:
            break
        n = int(np.ceil(n * min(ratio, 3.0) * 1.05))
    return n


def explicit_path(space: PoseSpace, scores: np.ndarray, detail: bool = True) -> ScorePath:
    """A user's path ``scores: (T', k)``; ``k`` = its number of columns.

    The source frames it stands for are spread proportionally over the source; when it has the
    source's length and ``detail``, the source's detail components are kept frame by frame.
    """
    s = np.asarray(scores, dtype=float)
    if s.ndim == 1:
        s = s[:, None]
    if s.ndim != 2 or s.shape[0] < 2:
        raise MjmotionError(f"a score path must be a (frames, components) array with at least 2 frames, got shape {s.shape}")
    if not np.all(np.isfinite(s)):
        raise MjmotionError("the score path contains NaN or infinity")
    k = space._check_k(s.shape[1])
    t_src = space.source_scores.shape[0]
    full = np.zeros((s.shape[0], space.n_components))
    full[:, :k] = s
    if detail and s.shape[0] == t_src:
        full[:, k:] = space.source_scores[:, k:]
    pos = np.linspace(0.0, t_src - 1, s.shape[0])
    fa = np.floor(pos).astype(int)
    fb = np.minimum(fa + 1, t_src - 1)
    return ScorePath(full, k, fa, fb, pos - fa, "scores")


#: Largest score a score file may hold (standard deviations of the pose space: a shot's own
#: path stays within a few tens).
MAX_SCORE = 1e4


def read_scores(path: str | Path) -> np.ndarray:
    """A score path from ``.npy`` (a ``(T, k)`` array) or ``.csv`` (one row per frame, commas; a header row is skipped).

    The file is read through :func:`mjmotion.inputs.open_input` (a regular file within
    :data:`mjmotion.limits.MAX_FILE_BYTES`); an ``.npy`` header is read first (``allow_pickle``
    off) and its dtype and shape checked before any data is; every value must be finite and
    within ±:data:`MAX_SCORE`. Returns ``(T, k)`` float64 with 2 ≤ T ≤ MAX_FRAMES, k ≤ MAX_COMPONENTS.
    """
    from .inputs import read_text
    from .limits import MAX_FILE_BYTES

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".npy":
        arr = _read_npy(p)
    elif suffix in (".csv", ".txt"):
        text = read_text(p, MAX_FILE_BYTES, "a score file (.csv)").splitlines()
        rows = [(i, r) for i, r in enumerate(text, 1) if r.strip() and not r.lstrip().startswith("#")]
        try:
            float(rows[0][1].split(",")[0])
        except (ValueError, IndexError):
            rows = rows[1:]
        _check_score_shape(p, (len(rows), len(rows[0][1].split(",")) if rows else 0))
        values = []
        for i, r in rows:
            try:
                values.append([float(v) for v in r.split(",")])
            except ValueError:
                raise MjmotionError(f"{p}:{i}: cannot read scores ({_short(r)}); expected numbers separated by commas") from None
            if len(values[-1]) != len(values[0]):
                raise MjmotionError(f"{p}:{i}: {len(values[-1])} scores; expected {len(values[0])} like the first row")
        arr = np.array(values, dtype=float)
    else:
        raise MjmotionError(f"{p}: expected a .npy or .csv score path")
    if arr.ndim == 1:
        arr = arr[:, None]
    _check_score_shape(p, arr.shape)
    bad = ~(np.abs(arr) <= MAX_SCORE)  # NaN is bad too
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        raise MjmotionError(f"{p}: score at frame {row}, component {col + 1} is {arr[row, col]:g}; expected a finite score within ±{MAX_SCORE:g}")
    return arr


def _short(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:40] + "…")


def _check_score_shape(p: Path, shape: tuple[int, ...]) -> None:
    from .limits import MAX_COMPONENTS, MAX_FRAMES

    if len(shape) not in (1, 2) or shape[0] < 2:
        raise MjmotionError(f"{p}: expected a (frames, components) table with at least 2 rows, got shape {shape}")
    if shape[0] > MAX_FRAMES or (len(shape) == 2 and not 1 <= shape[1] <= MAX_COMPONENTS):
        raise MjmotionError(f"{p}: a score path of shape {shape}; expected at most {MAX_FRAMES:,} frames and 1 to {MAX_COMPONENTS} components")


def _read_npy(p: Path) -> np.ndarray:
    """An ``.npy`` array of real numbers, its header checked before its data is read."""
    from numpy.lib import format as npy

    from .inputs import open_input
    from .limits import MAX_FILE_BYTES

    with open_input(p, MAX_FILE_BYTES, "a score file (.npy)") as (fh, size):
        head = fh.read(6)
        if head != b"\x93NUMPY":
            kind = "a zip archive (an .npz saved as .npy?)" if head.startswith(b"PK") else "not an .npy file"
            raise MjmotionError(f"{p}: {kind}; expected an .npy array (numpy.save) of frames × components")
        fh.seek(0)
        try:
            version = npy.read_magic(fh)
            if version == (1, 0):
                shape, fortran, dtype = npy.read_array_header_1_0(fh)
            elif version == (2, 0):
                shape, fortran, dtype = npy.read_array_header_2_0(fh)
            else:
                raise MjmotionError(f"{p}: .npy format version {version[0]}.{version[1]}; expected 1.0 or 2.0")
        except ValueError as e:
            raise MjmotionError(f"{p}: a damaged .npy header ({e})") from None
        if dtype.kind not in "fiu" or dtype.hasobject or dtype.fields is not None or dtype.subdtype is not None:
            raise MjmotionError(f"{p}: an array of {dtype}; expected real numbers (float or int)")
        _check_score_shape(p, tuple(shape))
        need = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if need > size - fh.tell():
            raise MjmotionError(f"{p}: its header says shape {tuple(shape)} ({need} bytes) but the file holds {size - fh.tell()}; truncated?")
        data = fh.read(need)
    if len(data) != need:
        raise MjmotionError(f"{p}: shorter than its header says (truncated while read?)")
    arr = np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")
    return arr.astype(float)


def synthesise(space: PoseSpace, path: ScorePath, name: str = "") -> Motion:
    """The motion of ``path``: frame ``t`` is the pose ``P = (L S_t)ᵀ ⊙ D + M`` (§3.2.1)."""
    return space.motion(path.scores, name=name or f"{space.template.name} {path.label}".strip())


# --- cleanup (§3.3) ----------------------------------------------------------------------------
def _source_at(source_values: np.ndarray, path: ScorePath) -> np.ndarray:
    """Per path frame, the source's ``values`` at the frames it stands for (linear blend)."""
    w = path.weight.reshape(-1, *([1] * (source_values.ndim - 1)))
    return (1.0 - w) * source_values[path.frame_a] + w * source_values[path.frame_b]


def _source_positions_at(source_positions: np.ndarray, path: ScorePath) -> np.ndarray:
    """Like :func:`_source_at` for world positions ``(T, ..., 3)``: frame_b's are moved by ``path.shift_b``."""
    w = path.weight.reshape(-1, *([1] * (source_positions.ndim - 1)))
    return (1.0 - w) * source_positions[path.frame_a] + w * (source_positions[path.frame_b] + path.shift_b)


def _quat_source_at(source_q: np.ndarray, path: ScorePath) -> np.ndarray:
    w = np.broadcast_to(
        path.weight.reshape(-1, *([1] * (source_q.ndim - 2))),
        source_q[path.frame_a].shape[:-1],
    )
    return rot.slerp(source_q[path.frame_a], source_q[path.frame_b], w)


def _fade(mask: np.ndarray, n_fade: int) -> np.ndarray:
    """``(T,)`` 1 where ``mask`` holds, easing to 0 over ``n_fade`` frames either side."""
    if not mask.any():
        return np.zeros(mask.shape)
    idx = np.flatnonzero(mask)
    t = np.arange(mask.size)
    # distance in frames to the nearest masked frame
    pos = np.searchsorted(idx, t)
    left = np.abs(t - idx[np.clip(pos - 1, 0, idx.size - 1)])
    right = np.abs(idx[np.clip(pos, 0, idx.size - 1)] - t)
    d = np.minimum(left, right)
    u = np.clip(1.0 - d / (n_fade + 1), 0.0, 1.0)
    return np.sin(0.5 * np.pi * u) ** 2


def two_bone_ik(
    skeleton: Skeleton,
    world_pos: np.ndarray,
    world_rot: np.ndarray,
    local_rot: np.ndarray,
    end: int,
    target_pos: np.ndarray,
    target_rot: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Analytic IK placing joint ``end`` (ankle, wrist) at ``target_pos`` with world orientation ``target_rot``.

    The middle joint (knee, elbow) bends in its current plane to get the right reach, then the
    upper joint (hip, shoulder) swings the limb onto the target; the end joint's local rotation
    gives it the target orientation. Reach is clamped to the limb's length.

    Args:
        world_pos: ``(T, J, 3)`` and ``world_rot: (T, J, 4)``, forward kinematics of the pose.
        local_rot: ``(T, J, 4)`` the pose's local rotations (a modified copy is returned).
        target_pos: ``(T, 3)``; target_rot: ``(T, 4)`` world.
    Returns:
        ``(local_rot, reach_error)``: updated rotations and ``(T,)`` metres the target stays out of reach.
    """
    mid = int(skeleton.parents[end])
    top = int(skeleton.parents[mid])
    above = int(skeleton.parents[top])
    h, k, a = world_pos[:, top], world_pos[:, mid], world_pos[:, end]
    l1 = np.linalg.norm(k - h, axis=-1)
    l2 = np.linalg.norm(a - k, axis=-1)
    u, v = k - h, a - k
    n = np.cross(u, v)
    nn = np.linalg.norm(n, axis=-1)
    # the bend axis in the upper bone's frame, borrowed from bent frames where the limb is straight
    q_top = world_rot[:, top]
    n_local = rot.rotate(rot.conjugate(q_top), n / np.maximum(nn, 1e-12)[:, None])
    good = nn > analytic.STRAIGHT_SINE * l1 * l2
    if good.any():
        ref = n_local[good].mean(axis=0)
    else:
        ref = np.array([1.0, 0.0, 0.0])
    ref = ref / max(np.linalg.norm(ref), 1e-12)
    n_unit = np.where(good[:, None], n / np.maximum(nn, 1e-12)[:, None], rot.rotate(q_top, ref))
    r_hip, r_knee, reach_error = analytic.two_bone(h, k, a, target_pos, n_unit)
    q_top_new = rot.multiply(r_hip, q_top)
    q_mid_new = rot.multiply(r_hip, rot.multiply(r_knee, world_rot[:, mid]))
    out = local_rot.copy()
    q_above = world_rot[:, above] if above >= 0 else np.broadcast_to(rot.IDENTITY, q_top.shape)
    out[:, top] = rot.multiply(rot.conjugate(q_above), q_top_new)
    out[:, mid] = rot.multiply(rot.conjugate(q_top_new), q_mid_new)
    out[:, end] = rot.multiply(rot.conjugate(q_mid_new), target_rot)
    return out, reach_error


def _blend_local(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    return rot.slerp(a, b, np.broadcast_to(w[:, None], a.shape[:2]))


def _is_below(skeleton: Skeleton, c: int, j: int) -> bool:
    while c > j:
        c = int(skeleton.parents[c])
    return c == j


@dataclass(frozen=True)
class CleanupReport:
    """What :func:`clean_up` did: the frames it held per foot and the leftover errors (metres)."""

    held_frames: dict[str, int]
    foot_reach_error_m: float
    grip_hands: tuple[str, str] | None
    grip_reach_error_m: float


def hold_source_feet(source: Motion, motion: Motion, path: ScorePath, plant_height: float = PLANT_HEIGHT) -> tuple[Motion, dict[str, int], float]:
    """Feet that slide or float (§3.3) put back on the source's footprints with two-bone leg IK.

    Where the source's foot (its lowest point, METRICS.md) is within ``plant_height`` of the floor at the
    frames a path frame stands for, the ankle follows the source's ankle (position and world
    orientation, toes as in the source) shifted by the variant's mean horizontal offset over
    that plant; corrections fade in and out over ``FADE_S``. Returns the motion, frames held per
    foot and the largest distance a target stayed out of reach.
    """
    skel = source.skeleton
    feet = skel.feet()
    if not feet:
        return motion, {}, 0.0
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    from .evaluate import foot_heights_speeds

    track = foot_heights_speeds(compiled, source, src)
    lowest = track.lowest  # (T, F, 3) each foot's lowest point (METRICS.md foot points)
    held: dict[str, int] = {}
    n_fade = max(1, round(FADE_S * motion.fps))
    # (the feet keep their plant's shift at an abort's end, so only the frames before it count)
    copies = copied_frames(source, motion, path)
    copied = copies & (path.weight <= 0)
    plans = []
    for side, (ankle, toe) in feet.items():
        low_src = track.heights[:, track.sides.index(side)] < plant_height
        # between two source frames a foot down at either end stays held (released, it would
        # swing to wherever the blended pose puts it)
        low_a, low_b = low_src[path.frame_a], low_src[path.frame_b]
        low = np.where(path.weight <= 0, low_a, np.where(path.weight >= 1, low_b, low_a | low_b))
        if not low.any() or skel.parents[skel.parents[ankle]] < 0:
            continue
        target = _source_positions_at(src.joint_positions[:, ankle], path)
        target_rot = _quat_source_at(src.joint_rotations[:, ankle], path)
        between = (path.weight > 0) & (path.weight < 1)
        if between.any():
            # between two source frames (an abort's return) the foot pivots about the point it
            # stands on at the end, instead of sliding the ankle from one footprint to the other
            fb, fa, w = (
                path.frame_b[between],
                path.frame_a[between],
                path.weight[between, None],
            )
            low_pt = lowest[:, track.sides.index(side)]
            c = rot.rotate(
                rot.conjugate(src.joint_rotations[fb, ankle]),
                low_pt[fb] - src.joint_positions[fb, ankle],
            )
            p_a = src.joint_positions[fa, ankle] + rot.rotate(src.joint_rotations[fa, ankle], c)
            p_b = low_pt[fb] + path.shift_b
            pivot = (1.0 - w) * p_a + w * p_b
            # a foot whose footprint moves must step: lift, carry, put down (not slide)
            stepping = np.linalg.norm((p_b - p_a)[:, :2], axis=-1) > STEP_M
            if stepping.any():
                # lift first, then carry and turn the foot in the air, then put it down
                u = w[:, 0]
                carry = _smoothstep((u - 0.3) / 0.4)
                lift = STEP_LIFT * np.sin(np.pi * np.clip((u - 0.1) / 0.8, 0.0, 1.0))
                step = p_a + carry[:, None] * (p_b - p_a)
                step[:, 2] += lift
                pivot = np.where(stepping[:, None], step, pivot)
                q_a, q_b = (
                    src.joint_rotations[fa, ankle],
                    src.joint_rotations[fb, ankle],
                )
                turned = rot.slerp(q_a, q_b, carry)
                target_rot[between] = np.where(stepping[:, None], turned, target_rot[between])
            target[between] = pivot - rot.rotate(target_rot[between], c)
        # one horizontal shift per plant, where the variant's foot touched down; frames between
        # plants (fading in and out) take the nearest plant's shift so the target does not jump
        runs = _runs(low)
        starts = np.array([a for a, _ in runs])
        shifts = var.joint_positions[starts, ankle, :2] - target[starts, :2]
        centres = np.array([0.5 * (a + b - 1) for a, b in runs])
        t = np.arange(len(low))
        dist = np.array([np.where(t < a, a - t, np.where(t >= b, t - b + 1, 0)) for a, b in runs])
        nearest = np.argmin(dist + 1e-6 * np.abs(t[None] - centres[:, None]), axis=0)
        target[:, :2] += shifts[nearest]
        # frames that are the source's own poses (before an abort, outside a scaled segment) stay so
        target[copied] = var.joint_positions[copied, ankle]
        target_rot[copied] = var.joint_rotations[copied, ankle]
        plans.append((side, ankle, toe, low, target, target_rot, _fade(low, n_fade)))
    if not plans:
        return motion, {}, 0.0
    # an exaggerated pose can lift the hips beyond the legs' reach: lower/move the root first
    shift = _root_shift_for_reach(skel, var, [(a, tg, w) for _, a, _, _, tg, _, w in plans], motion.fps)
    shift *= 1.0 - _fade(copies, max(1, round(0.5 * ROOT_WINDOW_S * motion.fps)))[:, None]
    if np.any(shift):
        motion = motion.replace(root_positions=motion.root_positions + shift)
        var = kinematics.forward(compiled, motion)
    local = motion.rotations.copy()
    worst = 0.0
    for side, ankle, toe, low, target, target_rot, w in plans:
        solved, err = two_bone_ik(
            skel,
            var.joint_positions,
            var.joint_rotations,
            local,
            ankle,
            target,
            target_rot,
        )
        if toe is not None:
            for j in [toe, *skel.descendants(toe)]:
                solved[:, j] = _quat_source_at(source.rotations[:, j], path)
        chain = [
            int(skel.parents[skel.parents[ankle]]),
            int(skel.parents[ankle]),
            ankle,
        ]
        chain += [j for j in ([toe, *skel.descendants(toe)] if toe is not None else [])]
        local[:, chain] = _blend_local(local[:, chain], solved[:, chain], w)
        held[side] = int(low.sum())
        worst = max(worst, float(np.max(err[low])))
    return motion.replace(rotations=local), held, worst


def copied_frames(source: Motion, motion: Motion, path: ScorePath, tol: float = 1e-9) -> np.ndarray:
    """``(T',) bool``: frames of ``motion`` that are exactly a source frame (moved by ``path.shift_b`` at frame_b)."""
    out = np.zeros(path.n_frames, dtype=bool)
    for sel, frames, move in (
        (path.weight <= 0, path.frame_a, 0.0),
        (path.weight >= 1, path.frame_b, path.shift_b),
    ):
        f = frames[sel]
        same_q = np.all(
            np.abs(np.abs(np.sum(motion.rotations[sel] * source.rotations[f], axis=-1)) - 1.0) < tol,
            axis=1,
        )
        same_r = np.all(
            np.abs(motion.root_positions[sel] - (source.root_positions[f] + move)) < 1e-7,
            axis=1,
        )
        out[sel] = same_q & same_r
    return out


#: Fraction of a leg's full length the root shift aims for (a straight knee is a singular pose).
REACH = 0.995
#: Seconds of the Hann window that spreads a root shift over neighbouring frames.
ROOT_WINDOW_S = 0.3


def _root_shift_for_reach(
    skel: Skeleton,
    pose: kinematics.Pose,
    legs: list[tuple[int, np.ndarray, np.ndarray]],
    fps: float,
) -> np.ndarray:
    """``(T, 3)`` root translation bringing every held ankle target within ``REACH`` of its leg.

    Per frame, the largest shortfall (weighted by the hold's fade) along the hip→target line;
    then a Hann-window smoothing (``ROOT_WINDOW_S``) rescaled so the peak is still covered.
    """
    t = pose.joint_positions.shape[0]
    need = np.zeros((t, 3))
    for ankle, target, w in legs:
        knee = int(skel.parents[ankle])
        hip = int(skel.parents[knee])
        p = pose.joint_positions
        length = np.linalg.norm(p[:, knee] - p[:, hip], axis=-1) + np.linalg.norm(p[:, ankle] - p[:, knee], axis=-1)
        vec = target - p[:, hip]
        dist = np.linalg.norm(vec, axis=-1)
        # only targets truly out of reach move the root (a captured straight leg stays as it is)
        short = np.where(dist > length * (1.0 - 1e-9), dist - REACH * length, 0.0)
        n = vec / np.maximum(dist, 1e-12)[:, None] * (w * short)[:, None]
        bigger = np.linalg.norm(n, axis=-1) > np.linalg.norm(need, axis=-1)
        need[bigger] = n[bigger]
    peak = np.linalg.norm(need, axis=-1)
    if not peak.any():
        return need
    half = max(0, min(round(0.5 * ROOT_WINDOW_S * fps), (t - 1) // 2))  # np.convolve 'same' keeps the longer length
    kernel = np.hanning(2 * half + 3)[1:-1]
    kernel /= kernel.sum()
    smooth = np.stack([np.convolve(need[:, i], kernel, mode="same") for i in range(3)], axis=1)
    norm = np.linalg.norm(smooth, axis=-1)
    hit = peak > 0
    gain = float(np.max(peak[hit] / np.maximum(norm[hit], 1e-12)))
    return smooth * min(gain, 3.0)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def grip_joints(skeleton: Skeleton) -> dict[str, int]:
    """``{"left": j, "right": j}``: the joints whose relative placement is the grip.

    The hand joint proper as the hit-point module picks it (``hitpoint.hand_joints``: CMU's
    ``lhand`` below the ``lwrist`` roll bone), so grip errors here and there measure the same thing.
    """
    from .hitpoint import hand_joints

    return hand_joints(skeleton)


def restore_grip_minimal(source: Motion, motion: Motion, path: ScorePath, first_hand: str = "left") -> tuple[Motion, float]:
    """The second hand back at its source placement relative to the first hand (§3.3), two-bone arm IK.

    For each path frame, the second hand's world pose is the first hand's (in the variant)
    times the source's relative transform at the frames it stands for (hands from
    :func:`grip_joints`). The arm's end joint (the wrist, or the hand itself when it has no wrist
    bone) is solved so that the hand lands there exactly, the collarbone helping when the target
    is beyond the arm's reach; the hand's subtree keeps the source's local rotations. Returns the
    motion and the largest out-of-reach distance (m).
    """
    skel = source.skeleton
    hands = grip_joints(skel)
    if set(hands) != {"left", "right"}:
        raise MjmotionError("restoring the grip needs a left and a right hand in the skeleton")
    if first_hand not in hands:
        raise MjmotionError(f"first hand must be 'left' or 'right', got {first_hand!r}")
    h1, h2 = hands[first_hand], hands["right" if first_hand == "left" else "left"]
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    q1s, q2s = src.joint_rotations[:, h1], src.joint_rotations[:, h2]
    rel_pos = rot.rotate(rot.conjugate(q1s), src.joint_positions[:, h2] - src.joint_positions[:, h1])
    rel_rot = rot.multiply(rot.conjugate(q1s), q2s)
    q1 = var.joint_rotations[:, h1]
    hand_pos = var.joint_positions[:, h1] + rot.rotate(q1, _source_at(rel_pos, path))
    hand_rot = rot.multiply(q1, _quat_source_at(rel_rot, path))
    # the arm's end: the wrist above a hand joint (kept at the source's local rotation), else the hand
    wrist = skel.hands().get("right" if first_hand == "left" else "left", h2)
    end = wrist if wrist != h2 and _is_below(skel, h2, wrist) else h2
    keep = [end, *skel.descendants(end)]
    src_local = {j: _quat_source_at(source.rotations[:, j], path) for j in keep}
    target_rot, target = hand_rot, hand_pos
    if end != h2:
        # from the hand's target pose back to the end joint's, through the source's joints between
        chain = [h2]
        while chain[-1] != end:
            chain.append(int(skel.parents[chain[-1]]))
        for child in chain[:-1]:
            local_c = src_local[child]
            off = skel.offsets[child]
            target_rot = rot.multiply(target_rot, rot.conjugate(local_c))
            target = target - rot.rotate(target_rot, off)
    local = motion.rotations
    for _ in range(4):  # the shoulder moves on a sphere about the collarbone: a few passes close the gap
        turned = _reach_with_shoulder(skel, motion.replace(rotations=local), var, end, target)
        if turned is local:
            break
        local = turned
        var = kinematics.forward(compiled, motion.replace(rotations=local))
    local, err = two_bone_ik(skel, var.joint_positions, var.joint_rotations, local, end, target, target_rot)
    for j in keep[1:]:
        local[:, j] = src_local[j]
    return motion.replace(rotations=local), float(np.max(err))


def _reach_with_shoulder(skel: Skeleton, motion: Motion, pose: kinematics.Pose, end: int, target: np.ndarray) -> np.ndarray:
    """Local rotations with the collarbone turned so a too-distant ``target`` comes within the arm's reach.

    Where the wrist target lies beyond upper arm + forearm, the joint above the shoulder
    (the clavicle) swings the shoulder toward the target by the missing length. Returns
    ``motion.rotations`` itself when nothing is out of reach.
    """
    mid = int(skel.parents[end])
    top = int(skel.parents[mid])
    clav = int(skel.parents[top])
    above = int(skel.parents[clav]) if clav >= 0 else -1
    if clav <= 0:
        return motion.rotations
    p = pose.joint_positions
    reach = np.linalg.norm(p[:, mid] - p[:, top], axis=-1) + np.linalg.norm(p[:, end] - p[:, mid], axis=-1)
    to_target = target - p[:, top]
    dist = np.linalg.norm(to_target, axis=-1)
    short = dist > reach * (1.0 - 1e-9)
    if not short.any():
        return motion.rotations
    # move the shoulder by the missing length plus 1 % so the elbow keeps a little bend
    wanted = p[:, top] + to_target * ((dist - 0.99 * reach) / np.maximum(dist, 1e-12))[:, None]
    r = analytic.shortest_arc(p[:, top] - p[:, clav], wanted - p[:, clav])
    r[~short] = rot.IDENTITY
    q_clav = rot.multiply(r, pose.joint_rotations[:, clav])
    q_above = pose.joint_rotations[:, above] if above >= 0 else np.broadcast_to(rot.IDENTITY, q_clav.shape)
    out = motion.rotations.copy()
    out[:, clav] = rot.multiply(rot.conjugate(q_above), q_clav)
    return out


#: Ways to repair the feet: the source's footprints (default), the footskate cleanup's plants, both, none.
FEET_METHODS = ("source", "plants", "both", "none")


def clean_up(
    source: Motion,
    motion: Motion,
    path: ScorePath,
    first_hand: str | None = "left",
    feet: str = "source",
) -> tuple[Motion, CleanupReport]:
    """Repair §3.3's artefacts: the feet, then the second hand on the grip.

    ``feet``: ``"source"`` holds each foot on the source's footprint (:func:`hold_source_feet`:
    where and when the source's foot is down, at its height and orientation, so floating and
    sliding both go); ``"plants"`` runs the general footskate cleanup on the variant alone
    (:func:`mjmotion.cleanup.cleanup`, Kovar et al. 2002: plants found in the variant, ankles pinned,
    foot orientation held); ``"both"`` the first then the second; ``"none"``.
    ``first_hand=None`` leaves the hands alone (a one-handed shot, a kick).
    """
    if feet not in FEET_METHODS:
        raise MjmotionError(f"feet cleanup must be one of {', '.join(FEET_METHODS)}, got {feet!r}")
    out, foot_err = motion, 0.0
    held: dict[str, int] = {}
    if feet in ("source", "both"):
        out, held, foot_err = hold_source_feet(source, out, path)
    if feet in ("plants", "both"):
        from .cleanup import cleanup

        res = cleanup(out)
        out = res.motion
        for plant in res.plants:
            held[f"{plant.side} (plants)"] = held.get(f"{plant.side} (plants)", 0) + plant.stop - plant.start
    grip_err = 0.0
    pair = None
    if first_hand is not None:
        out, grip_err = restore_grip_minimal(source, out, path, first_hand)
        pair = (first_hand, "right" if first_hand == "left" else "left")
    return out, CleanupReport(held, foot_err, pair, grip_err)


# --- plots (Figures 3.1, 3.4, 3.7) -------------------------------------------------------------
def plot_score_paths(paths: dict[str, np.ndarray], out_png: str | Path, dims: int = 2) -> None:
    """Score paths ``{label: (T, ≥dims)}`` drawn in the first ``dims`` (2 or 3) components, saved as PNG.

    The first path is drawn as the reference (thicker); each path's start is marked with a
    circle and its end with a square.
    """
    if dims not in (2, 3):
        raise MjmotionError(f"score paths can be drawn in 2 or 3 dimensions, not {dims}")
    if not paths:
        raise MjmotionError("no score paths to plot")
    for label, s in paths.items():
        if np.asarray(s).ndim != 2 or np.asarray(s).shape[1] < dims:
            raise MjmotionError(f"path {label!r} needs at least {dims} score columns, has shape {np.shape(s)}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .outputs import write_with

    fig = plt.figure(figsize=(6.4, 5.2), dpi=110)
    ax: Any = fig.add_subplot(111, projection="3d" if dims == 3 else None)
    for i, (label, s) in enumerate(paths.items()):
        s = np.asarray(s, dtype=float)
        cols = [s[:, d] for d in range(dims)]
        line = ax.plot(*cols, lw=2.4 if i == 0 else 1.4, label=label)[0]
        ax.scatter(*[c[:1] for c in cols], color=line.get_color(), marker="o", s=18)
        ax.scatter(*[c[-1:] for c in cols], color=line.get_color(), marker="s", s=18)
    ax.set_xlabel("PC 1")
    ax.set_ylabel("PC 2")
    if dims == 3:
        ax.set_zlabel("PC 3")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("scores in principal-component space")
    fig.tight_layout()
    write_with(out_png, lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)


# --- measurements ------------------------------------------------------------------------------
#: Median distance (m) between the hands under which a clip counts as two-handed (golf: 4–10 cm).
TWO_HANDED_M = 0.2


def first_hand_for(source: Motion) -> str | None:
    """The hand the other is held to: the club's hand when ``hitpoint.fit_club`` fits one, else left.

    ``None`` when the skeleton does not have two hands or they are not together (median distance
    over ``TWO_HANDED_M``): a walk or a kick has no grip to keep.
    """
    hands = source.skeleton.hands()
    if set(hands) != {"left", "right"}:
        return None
    p = kinematics.forward(mjcf.compile(source.skeleton), source).joint_positions
    if np.median(np.linalg.norm(p[:, hands["left"]] - p[:, hands["right"]], axis=-1)) > TWO_HANDED_M:
        return None  # the hands are not holding one thing
    from .skeleton import side_of

    prop = fitted_club(source)
    return (side_of(prop.joint) if prop is not None else None) or "left"


def grip_error_m(source: Motion, motion: Motion, path: ScorePath, first_hand: str = "left") -> float:
    """METRICS.md ``grip_error_m``: distance of the second hand from where the source holds it
    relative to the first hand (at the source frames each frame stands for), max over frames."""
    skel = source.skeleton
    hands = grip_joints(skel)
    h1, h2 = hands[first_hand], hands["right" if first_hand == "left" else "left"]
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    rel = rot.rotate(
        rot.conjugate(src.joint_rotations[:, h1]),
        src.joint_positions[:, h2] - src.joint_positions[:, h1],
    )
    want = var.joint_positions[:, h1] + rot.rotate(var.joint_rotations[:, h1], _source_at(rel, path))
    return float(np.max(np.linalg.norm(want - var.joint_positions[:, h2], axis=-1)))


def effector_path_length(
    motion: Motion,
    joint: int | None = None,
    frames: tuple[int, int] | None = None,
    prop: mjcf.Prop | None = None,
) -> float:
    """Length (m) of the path of ``joint`` — or of ``prop``'s sweet spot — over ``frames`` (half-open; all by default)."""
    if prop is not None:
        pose = kinematics.forward(mjcf.compile(motion.skeleton, (prop,)), motion)
        p = pose.site(f"{prop.name}/sweet_spot")
    elif joint is not None:
        p = kinematics.forward(mjcf.compile(motion.skeleton), motion).joint_positions[:, joint]
    else:
        raise MjmotionError("effector_path_length needs a joint or a prop")
    if frames is not None:
        p = p[frames[0] : frames[1]]
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=-1)))


def fitted_club(source: Motion) -> mjcf.Prop | None:
    """The club ``hitpoint.fit_club`` fits to a two-handed swing, or ``None`` (one hand, or no fit)."""
    if set(source.skeleton.hands()) != {"left", "right"}:
        return None
    from .hitpoint import fit_club

    try:
        return fit_club(source)
    except MjmotionError:
        return None


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def report(
    source: Motion,
    raw: Motion,
    result: Motion,
    path: ScorePath,
    space: PoseSpace,
    first_hand: str | None = "left",
) -> dict[str, Any]:
    """Numbers for a variant: ``k``, variance explained, footskate (mm/s, METRICS.md) of source, raw
    and result, joint-speed ratio, grip error and the first hand's path length."""
    from . import evaluate

    out: dict[str, Any] = {
        "variant": path.label,
        "n_frames": result.n_frames,
        "k": path.k,
        "variance_explained": float(space.cumulative[path.k - 1]),
        "explained_per_component": [float(x) for x in space.explained[: max(path.k, 5)]],
    }
    flips = rotation_flips(source)
    if flips:
        out["warnings"] = [
            (
                f"local rotations jump by more than {np.degrees(2.5):.0f} degrees in one frame at {len(flips)} places "
                f"(first: frame {flips[0][0]}, {flips[0][1]}); the PCA mixes the two branches and variants may be distorted"
            )
        ]
    if result.n_frames == source.n_frames:
        rmse, k_style = style_rmse(source, result)
        out["style_rmse"] = {"rmse": rmse, "k": k_style}
    try:
        compiled = mjcf.compile(source.skeleton)  # one model for the three clips' foot tracks
        out["footskate_mm_per_s"] = {
            "source": _finite(evaluate.skate_mm_per_s(evaluate.foot_heights_speeds(compiled, source))),
            "raw": _finite(evaluate.skate_mm_per_s(evaluate.foot_heights_speeds(compiled, raw))),
            "result": _finite(evaluate.skate_mm_per_s(evaluate.foot_heights_speeds(compiled, result))),
            "h_c": evaluate.H_C,
        }
    except MjmotionError as exc:  # no feet in the skeleton
        out["footskate_mm_per_s"] = {
            "source": None,
            "raw": None,
            "result": None,
            "note": str(exc),
        }
    out["max_joint_speed_ratio"] = {
        "raw": float(evaluate.max_joint_speed_ratio(raw, source)),
        "result": float(evaluate.max_joint_speed_ratio(result, source)),
    }
    if first_hand is not None:
        out["first_hand"] = first_hand
        out["grip_error_m"] = {
            "raw": grip_error_m(source, raw, path, first_hand),
            "result": grip_error_m(source, result, path, first_hand),
        }
        j = source.skeleton.hands()[first_hand]
        out["effector_path_m"] = {
            "effector": source.skeleton.names[j],
            "source": effector_path_length(source, j),
            "result": effector_path_length(result, j),
        }
        club = fitted_club(source)
        if club is not None:
            out["club_path_m"] = {
                "effector": f"{club.name}/sweet_spot",
                "source": effector_path_length(source, prop=club),
                "result": effector_path_length(result, prop=club),
            }
    return out
