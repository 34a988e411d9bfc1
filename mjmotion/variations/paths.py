"""Score paths through a clip's PCA space, and the motion they stand for (seed 003 §3.1-§3.2).

A :class:`ScorePath` is a sequence of score vectors in the source's PCA space (``style.PoseSpace``)
plus, for each of its frames, the source frames it stands for (used for the detail the top ``k``
components do not carry, and for where the feet and the second hand belong). From the source's
own path:

* :func:`scaled_path` — exaggerate (factor > 1) or mute (< 1) by scaling the path about its
  centre, fading to none at the first and last frames (:func:`end_weights`, the common start and
  end poses of §2.2.5), or about the centre of a named segment with tapered ends (§3.2.3,
  Figure 3.7 red/green);
* :func:`aborted_path` — follow the source to frame ``f``, then leave for the rest pose's scores
  over ``N`` frames (§3.2.3, Figure 3.7 orange);
* :func:`explicit_path` — a user's own scores (CSV/NPY).

:func:`synthesise` turns a path into a motion with ``P = (L S)ᵀ ⊙ D + M``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import filters, kinematics, limits, mjcf, thresholds
from .. import rotations as rot
from ..caps import MAX_FPS, check_motion_size
from ..errors import MjmotionError, is_real, is_whole
from ..skeleton import Motion
from ..style import PoseSpace

#: Variance the controlled components explain by default. The style error's 70 % (seed §2.5.4)
#: measures; for making variants more components keep the limbs coordinated (on the bundled
#: drive, scaling only the top two turns the bat against the arms).
DEFAULT_VARIANCE = 0.9
#: Fraction of a named segment (at each end) over which exaggeration fades in and out.
SEGMENT_TAPER = 0.25
#: Fraction of a path's farthest distance from its start (end) pose at which scaling is at full strength.
END_FADE = 0.5
#: Seconds over which the scaling also fades in and out at the path's first and last frames: a
#: clip still moving in its last frames (a kick's recovery) reached its end pose in 4 frames, the
#: root 15 cm in them (10_01 ×1.3: 3.8x the source's fastest root).
END_RAMP_S = 0.25
#: Hz: what scaling adds is low-passed at the judge's cutoff (``thresholds.CUTOFF_HZ``), so a capture's
#: one-frame glitch, which the controlled components carry to every joint and the root, is not scaled with
#: the motion (10_01's hand glitch moved the ×1.3 kick's root 3.8x as fast as the source's fastest).
SCALE_CUTOFF_HZ = thresholds.CUTOFF_HZ


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

    def __repr__(self) -> str:
        """``ScorePath('scale 1.3', frames=166, k=5, components=12)``: no arrays."""
        from ..summary import fields

        return fields("ScorePath", repr(self.label), frames=self.n_frames, k=self.k, components=int(self.scores.shape[1]))

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


def end_weights(controlled: np.ndarray, fade: float = END_FADE, ramp: int = 0) -> np.ndarray:
    """``(T,)`` 0 at the first and last frames of a path ``controlled: (T, k)``, 1 once it has left
    its start pose (and before it settles into its end pose) by ``fade`` of its farthest distance
    from it (seed 003 §2.2.5: the shots share common start and end poses, so their variants keep them).

    ``w = smoothstep(m₀(t)/(fade·max m₀)) · smoothstep(m₁(t)/(fade·max m₁))`` with ``m₀(t)`` the
    farthest the path has been from its first pose up to ``t`` and ``m₁(t)`` the farthest it will
    be from its last pose after ``t``: still frames at either end (an address, a finish) stay at 0,
    and a swing passing near its start pose again (a golf impact) keeps its full weight.
    ``ramp`` frames: ``w`` is then lowered to the largest weight below it that changes by at most
    ``1 / ramp`` a frame, so a path still moving at its ends reaches its end poses over at least that
    time, not in its last few frames.
    """
    c = np.asarray(controlled, dtype=float)
    d0 = np.maximum.accumulate(np.linalg.norm(c - c[0], axis=1))
    d1 = np.maximum.accumulate(np.linalg.norm(c - c[-1], axis=1)[::-1])[::-1]
    w0 = _smoothstep(d0 / max(fade * float(d0[-1]), 1e-12))
    w1 = _smoothstep(d1 / max(fade * float(d1[0]), 1e-12))
    w = w0 * w1
    if ramp > 0:
        # The largest weight below w that rises by at most 1/ramp a frame, forwards then backwards:
        # v_i = min(w_i, v_{i-1} + 1/ramp) is v_i − i/ramp = the running minimum of w_i − i/ramp.
        slope = np.arange(len(w)) / ramp
        w = np.minimum.accumulate(w - slope) + slope
        w = (np.minimum.accumulate(w[::-1] - slope) + slope)[::-1]
    return w


def scaled_path(path: ScorePath, factor: float, segment: tuple[int, int] | None = None, fps: float | None = None) -> ScorePath:
    """Exaggerate (``factor`` > 1) or mute (< 1) ``path`` (§3.2.3, Figure 3.7).

    The controlled scores move away from (or toward) the centre ``c`` (mean over the segment,
    or the whole path): ``s' = s + w(t)(factor − 1)(s − c)`` with ``w`` from :func:`segment_weights`
    for a segment, else :func:`end_weights`: the first and last frames are the source's (the
    common start and end poses of §2.2.5). ``fps``: the clip's rate; with it the scaling also
    fades no faster than over :data:`END_RAMP_S` (:func:`end_weights`' ``ramp``), and what it adds,
    ``s − c``, is first low-passed at :data:`SCALE_CUTOFF_HZ`: the motion is exaggerated, the
    capture's frame-to-frame jitter (kept as captured in ``s``) is not.
    """
    if not (np.isfinite(factor) and factor > 0):
        raise MjmotionError(f"scale factor must be a positive number, got {factor}")
    ramp = round(END_RAMP_S * fps) if fps else 0
    w = segment_weights(path.n_frames, segment) if segment is not None else end_weights(path.controlled, ramp=ramp)
    s = path.scores.copy()
    ctrl = s[:, : path.k]
    # The segment's centre (every frame of the segment has w > 0); a clip too short to weight any frame keeps its scores.
    centre = ctrl[w > 0].mean(axis=0) if (w > 0).any() else np.zeros(path.k)
    away = ctrl - centre
    if fps:
        away = filters.lowpass(away, fps, SCALE_CUTOFF_HZ)
    s[:, : path.k] = ctrl + (w * (factor - 1.0))[:, None] * away
    return replace(path, scores=s, label=f"scale {factor:g}")


def default_abort_frames(path: ScorePath, frame: int, rest_frame: int, fps: float) -> int:
    """Frames to reach the rest pose, at least 0.25 s: the return's peak speed through the space is the source's mean.

    The return leg covers the distance ``|S_rest − S_f|`` along a Hermite curve whose peak speed is 1.5× its
    average, so 1.5·distance / mean speed frames make its peak the source's mean speed (its average 2/3 of it)
    and joint speeds stay within those of the source (§3.2.3 "heads straight to the rest pose").
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
    for label, value in (("abort frame", frame), ("rest frame", rest_frame)):
        if not is_whole(value):
            raise MjmotionError(f"{label} {value!r}: expected a whole frame number")
    if not (is_real(fps) and 0 < fps <= MAX_FPS):
        raise MjmotionError(f"fps {fps!r}: expected a frame rate in (0, {MAX_FPS:g}]")
    if n_frames is not None:
        if not is_whole(n_frames):
            raise MjmotionError(f"abort frames {n_frames!r}: expected a whole number of frames")
        # (before anything is allocated: 10**9 frames got the process killed for its memory)
        joints = space.template.skeleton.n_joints if space is not None else 1
        check_motion_size(frame + 1 + int(n_frames), joints, f"an abort at {frame} over {n_frames} frames")
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
    :data:`mjmotion.caps.MAX_FILE_BYTES`); an ``.npy`` header is read first (``allow_pickle``
    off) and its dtype and shape checked before any data is; every value must be finite and
    within ±:data:`MAX_SCORE`. Returns ``(T, k)`` float64 with 2 ≤ T ≤ MAX_FRAMES, k ≤ MAX_COMPONENTS.
    """
    from ..caps import MAX_FILE_BYTES
    from ..inputs import read_text

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
    from ..caps import MAX_COMPONENTS, MAX_FRAMES

    if len(shape) not in (1, 2) or shape[0] < 2:
        raise MjmotionError(f"{p}: expected a (frames, components) table with at least 2 rows, got shape {shape}")
    if shape[0] > MAX_FRAMES or (len(shape) == 2 and not 1 <= shape[1] <= MAX_COMPONENTS):
        raise MjmotionError(f"{p}: a score path of shape {shape}; expected at most {MAX_FRAMES:,} frames and 1 to {MAX_COMPONENTS} components")


def _read_npy(p: Path) -> np.ndarray:
    """An ``.npy`` array of real numbers, its header checked before its data is read."""
    from numpy.lib import format as npy

    from ..caps import MAX_FILE_BYTES
    from ..inputs import open_input

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
    """The motion of ``path``: frame ``t`` is the pose ``P = (L S_t)ᵀ ⊙ D + M`` (§3.2.1), with every joint
    inside the judge's ranges (:func:`mjmotion.limits.within`: a scaled path turned wrists and shoulders
    past them)."""
    m = space.motion(path.scores, name=name or f"{space.template.name} {path.label}".strip())
    return m.replace(rotations=limits.within(m.skeleton, m.rotations))
