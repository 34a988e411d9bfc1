"""Blending registered clips (seed 000 §3.2, seed 004 §5.4) and the linear baseline (seed 004 §6.2.2).

A blend is built from *tracks*: a clip sampled at a time per output frame, with a weight per
output frame (:class:`Track`). :func:`compose` turns any set of tracks into one motion:

* joint rotations (all but the root) are the weighted quaternion mean of the tracks'
  (``rotations.weighted_average``);
* the root is built incrementally (seed 000 §3.2, simplified): each track contributes its heading
  change and its floor displacement over the frame *expressed in its own heading at the frame's
  start*; the blend turns by the weighted heading change and steps by the weighted displacement
  rotated into its own heading at the frame's start (the seed expresses each step after the
  clip's turn; per frame the two differ by the product of two small increments). Height and the root's tilt (its rotation with the heading removed) are
  weighted means. A clip is thereby re-aligned to the blend at every frame, which is what Kovar &
  Gleicher's alignment curve achieves for whole frames; with weight 1 on one clip the result is
  that clip exactly, moved rigidly on the floor. Increments never cross a track's own time jump,
  so switching sources cannot make the character jump or spin (the "time blip" of seed 000 §4.1).

Weights are non-negative and must sum to 1 (within 1e-6): other sums are refused rather than
silently normalised, so that a typo (``0.5,0.6``) is caught; time-varying weights interpolate
between such vectors and keep the sum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .errors import MjmotionError
from .registration import Registration, register_many
from .skeleton import Motion, same_rate
from .transform import floor_transform

METHODS = ("registered", "linear")


# --------------------------------------------------------------------------------------------
# weights
# --------------------------------------------------------------------------------------------
def check_weights(weights: np.ndarray | list[float], n: int, what: str = "weights") -> np.ndarray:
    """Blend weights ``(n,)``: finite, non-negative, summing to 1 (else a clear error)."""
    try:
        w = np.asarray(weights, dtype=float)
    except (TypeError, ValueError):
        raise MjmotionError(f"{what}: expected {n} numbers (one per clip), got {weights!r}") from None
    if w.shape != (n,):  # (a nested list of 2 read "expected 2 weights, got 2")
        raise MjmotionError(f"{what}: expected {n} weights (one per clip, a flat list), got {weights!r}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise MjmotionError(f"{what}: weights must be non-negative numbers, got {w.tolist()}")
    if abs(w.sum() - 1.0) > 1e-6:
        raise MjmotionError(f"{what}: weights sum to {w.sum():g}; they must sum to 1 (e.g. 0.25,0.75)")
    return w


def bezier_ease(s: np.ndarray, p1: float = 0.0, p2: float = 1.0) -> np.ndarray:
    """Cubic Bezier ``B(s)`` with control values ``(0, p1, p2, 1)`` for ``s`` in [0, 1] (clamped).

    The defaults give ``3s² − 2s³``: zero slope at both ends, so a weight ramp starts and stops
    smoothly (seed 000 §3.2's weight curves).
    """
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return 3 * (1 - s) ** 2 * s * p1 + 3 * (1 - s) * s**2 * p2 + s**3


@dataclass(frozen=True)
class WeightCurve:
    """Time-varying blend weights: keys ``(time_s, ramp_s, weights (n,))`` sorted by time.

    From each key's time the weights move from their current value to the key's over ``ramp_s``
    seconds along :func:`bezier_ease`; before the first key they equal the first key's.
    """

    keys: tuple[tuple[float, float, np.ndarray], ...]

    def __post_init__(self) -> None:
        if not self.keys:
            raise MjmotionError("a weight curve needs at least one key")
        for k, (time_s, ramp, _) in enumerate(self.keys):
            if not (math.isfinite(time_s) and math.isfinite(ramp) and ramp >= 0):
                raise MjmotionError(f"weight key {k}: time {time_s} s, ramp {ramp} s; expected finite numbers and a ramp ≥ 0")
        times = [k[0] for k in self.keys]
        if any(b < a for a, b in zip(times, times[1:], strict=False)):
            raise MjmotionError("weight keys must be in time order")

    @staticmethod
    def constant(weights: np.ndarray) -> WeightCurve:
        return WeightCurve(((0.0, 0.0, np.asarray(weights, dtype=float)),))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Weights ``(len(t), n)`` at times ``t`` (seconds)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.broadcast_to(self.keys[0][2], (len(t), len(self.keys[0][2]))).copy()
        for time_s, ramp, w in self.keys[1:]:
            s = np.ones(len(t)) if ramp <= 0 else bezier_ease((t - time_s) / ramp)
            s = np.where(t < time_s, 0.0, s)[:, None]
            out = out * (1 - s) + np.asarray(w)[None] * s
        return out


# --------------------------------------------------------------------------------------------
# composition of tracks
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Track:
    """A clip played into a blend.

    Attributes:
        motion: the clip.
        times: ``(N,)`` fractional frame of ``motion`` shown at each output frame.
        steps: ``(N,)`` frames of ``motion`` elapsed since the previous output frame (≥ 0); the
            root increment of frame ``n`` compares the clip at ``times[n] − steps[n]`` and
            ``times[n]``, so a track may jump in time without moving the character.
        weights: ``(N,)`` non-negative weight of this track at each output frame.
    """

    motion: Motion
    times: np.ndarray
    steps: np.ndarray
    weights: np.ndarray


def yaw_of(q: np.ndarray) -> np.ndarray:
    """Heading ``(...)`` radians: the twist of ``q: (..., 4)`` about the world's vertical axis."""
    return 2.0 * np.arctan2(q[..., 3], q[..., 0])


def _rotate2(yaw: np.ndarray, v: np.ndarray) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def compose(
    tracks: list[Track],
    fps: float,
    name: str = "blend",
    origin: tuple[float, float, float] | None = None,
) -> Motion:
    """One motion ``(N frames)`` from weighted tracks, on the first track's skeleton.

    ``origin = (x, y, yaw)`` places the blend's first frame; by default it is where the track
    with the largest weight at frame 0 stands.
    """
    if not tracks:
        raise MjmotionError("nothing to blend: no tracks")
    skel = tracks[0].motion.skeleton
    for tr in tracks[1:]:
        skel.require_same_topology(tr.motion.skeleton, f"{tracks[0].motion.name or 'clip'} and {tr.motion.name or 'clip'}")
    n_out = len(tracks[0].times)
    w = np.stack([np.asarray(tr.weights, dtype=float) for tr in tracks], axis=1)  # (N, E)
    if w.shape[0] != n_out or np.any(w < -1e-12):
        raise MjmotionError("track weights must be non-negative and one per output frame")
    total = w.sum(axis=1, keepdims=True)
    if np.any(total <= 0):
        raise MjmotionError(f"no track has weight at output frame {int(np.argmax(total[:, 0] <= 0))}")
    w = w / total
    j = skel.n_joints
    quats, root, trans = [], [], []
    yaw, dyaw, disp, tilt = [], [], [], []
    for tr in tracks:
        p, q, t = tr.motion.sample(tr.times)
        pp, qp, _ = tr.motion.sample(np.asarray(tr.times) - np.asarray(tr.steps))
        y, yp = yaw_of(q[:, 0]), yaw_of(qp[:, 0])
        quats.append(q)
        root.append(p)
        trans.append(t if t is not None else np.broadcast_to(skel.offsets, (n_out, j, 3)))
        yaw.append(y)
        dyaw.append(_wrap(y - yp))
        disp.append(_rotate2(-yp, (p - pp)[:, :2]))  # the step in the clip's own heading
        tilt.append(rot.multiply(rot.about_z(-y), q[:, 0]))
    yaw_a, dyaw_a = np.stack(yaw, 1), np.stack(dyaw, 1)  # (N, E)
    disp_a = np.stack(disp, 1)  # (N, E, 2)
    root_a = np.stack(root, 1)  # (N, E, 3)
    if origin is None:
        k0 = int(np.argmax(w[0]))
        origin = (root_a[0, k0, 0], root_a[0, k0, 1], yaw_a[0, k0])
    # heading and floor position integrate the weighted increments (frame 0 has none)
    d_yaw = np.einsum("ne,ne->n", w, dyaw_a)
    d_yaw[0] = 0.0
    heading = origin[2] + np.cumsum(d_yaw)
    step = np.einsum("ne,nec->nc", w, disp_a)
    step[0] = 0.0
    prev_heading = np.r_[heading[0], heading[:-1]]
    xy = np.array(origin[:2]) + np.cumsum(_rotate2(prev_heading, step), axis=0)
    z = np.einsum("ne,ne->n", w, root_a[:, :, 2])
    # rotations: weighted quaternion mean per joint; the root's tilt likewise, under the heading
    q_all = np.stack(quats, axis=2)  # (N, J, E, 4)
    q_all[:, 0] = np.stack(tilt, axis=1)
    wq = np.broadcast_to(w[:, None, :], q_all.shape[:3])
    q_out = rot.weighted_average(q_all, wq, axis=2)
    q_out[:, 0] = rot.multiply(rot.about_z(heading), q_out[:, 0])
    q_out = rot.make_continuous(q_out)
    translations = None
    if any(tr.motion.translations is not None for tr in tracks):
        translations = np.einsum("ne,nejc->njc", w, np.stack(trans, axis=1))
    return Motion(
        skeleton=skel,
        fps=float(fps),
        root_positions=np.column_stack([xy, z]),
        rotations=q_out,
        translations=translations,
        name=name,
    )


# --------------------------------------------------------------------------------------------
# registered and linear blends
# --------------------------------------------------------------------------------------------
def common_rate(motions: list[Motion]) -> list[Motion]:
    """Clips of one topology at the first clip's frame rate (others resampled)."""
    first = motions[0]
    out = [first]
    for m in motions[1:]:
        first.skeleton.require_same_topology(m.skeleton, f"{first.name or 'clip 1'} and {m.name or 'another clip'}")
        out.append(m if same_rate(m.fps, first.fps) else m.resample(first.fps))
    return out


def segment_frames(registration: Registration, weights: np.ndarray) -> np.ndarray:
    """Output frames spent in each segment of the registration, ``(M−1,)`` for weights ``(M−1, n)``.

    Between two samples of the registration every clip's time is linear, so clip ``k`` alone
    spends ``Δt_k`` output frames there (one frame of clip ``k`` per output frame). The blend's
    parameter increment per frame is the weighted mean of the clips' (Kovar & Gleicher), hence
    ``1 / Σ_k w_k / Δt_k`` frames: a weighted harmonic mean of the clips' frame counts.
    """
    seg = np.diff(registration.times, axis=0)  # (M-1, n), all > 0
    return 1.0 / np.sum(np.asarray(weights) / seg, axis=1)


#: Frames by which a registered clock may fall short of its last whole frame and still end on it.
CLOCK_SLACK = 1e-4


def registered_clock(registration: Registration, weights: WeightCurve, fps: float) -> np.ndarray:
    """Reference times ``τ_n`` ``(N,)`` of the output frames (seed 000 §3.2's timing).

    Exact for constant weights (with weight 1 on one clip the clip plays frame by frame); for
    weights that change with output time the frame count is found by a few fixed-point passes,
    evaluating the weights at each segment's current output time.
    """
    ref = registration.times[:, registration.reference]
    n_seg = len(ref) - 1
    nodes = np.arange(n_seg + 1, dtype=float)  # first guess: one output frame per segment
    for _ in range(1 if len(weights.keys) == 1 else 6):
        mid = 0.5 * (nodes[:-1] + nodes[1:]) / fps
        nodes = np.r_[0.0, np.cumsum(segment_frames(registration, weights(mid)))]
    # the registration's spline meets its last node to ~1e-6 frames: a clock that short of a whole frame ends on it
    n_out = int(np.floor(nodes[-1] + CLOCK_SLACK)) + 1
    return np.interp(np.arange(n_out, dtype=float), nodes, ref)


def blend(
    motions: list[Motion],
    weights: np.ndarray | list[float] | WeightCurve,
    method: str = "registered",
    registration: Registration | None = None,
    name: str = "blend",
    joint_weights: dict[str, float] | None = None,
) -> Motion:
    """Blend clips of one skeleton topology on the first clip's skeleton.

    ``weights``: ``(n,)`` summing to 1, or a :class:`WeightCurve` over output time (seconds).
    ``registered``: timewarped, aligned, incrementally rooted (module docstring); runs over the
    span the registration covers (``registration``, or one :func:`mjmotion.registration.register_many`
    makes with ``joint_weights``). ``linear``: the baseline, frame ``n`` of every clip averaged.
    """
    if isinstance(motions, Motion) or not all(isinstance(m, Motion) for m in motions):  # (len() of a Motion: TypeError)
        raise MjmotionError("blend: expected a list of Motions, e.g. blend([walk, run], [0.5, 0.5])")
    if len(motions) < 1:
        raise MjmotionError("blend needs at least one clip")
    motions = common_rate(list(motions))
    n = len(motions)
    curve = weights if isinstance(weights, WeightCurve) else WeightCurve.constant(check_weights(weights, n))
    for _, _, w in curve.keys:
        check_weights(w, n, "weight key")
    if method == "linear":
        return linear_blend(motions, curve, name)
    if method != "registered":
        raise MjmotionError(f"unknown blend method {method!r}; expected registered or linear")
    fps = motions[0].fps
    reg = registration if registration is not None else register_many(motions, reference=0 if n <= 2 else None, weights=joint_weights)
    tau = registered_clock(reg, curve, fps)
    times = reg.at(tau)  # (N, n)
    steps = np.vstack([np.zeros((1, n)), np.diff(times, axis=0)])
    w = curve(np.arange(len(tau)) / fps)
    tracks = [Track(m, times[:, k], steps[:, k], w[:, k]) for k, m in enumerate(motions)]
    return compose(tracks, fps, name)


def linear_blend(motions: list[Motion], weights: WeightCurve, name: str = "linear_blend") -> Motion:
    """Frame-by-frame blend (seed 004 §6.2.2): frame ``n`` of every clip, no timewarp.

    For a fair baseline each clip is first moved on the floor so its first frame stands where
    the first clip's does, facing the same way; then root positions are averaged as they are
    and rotations as quaternions. Runs for the shortest clip's length.
    """
    motions = common_rate(list(motions))
    n_out = min(m.n_frames for m in motions)
    ref = motions[0]
    yaw0 = yaw_of(ref.rotations[0, 0])
    moved = []
    for m in motions:
        d = float(yaw0 - yaw_of(m.rotations[0, 0]))
        off = ref.root_positions[0, :2] - rot.rotate(rot.about_z(d), m.root_positions[0])[:2]
        moved.append(floor_transform(m[:n_out], d, (float(off[0]), float(off[1]))))
    w = weights(np.arange(n_out) / ref.fps)  # (N, n)
    q = np.stack([m.rotations for m in moved], axis=2)  # (N, J, n, 4)
    q_out = rot.make_continuous(rot.weighted_average(q, np.broadcast_to(w[:, None, :], q.shape[:3]), axis=2))
    root = np.einsum("nk,knc->nc", w, np.stack([m.root_positions for m in moved]))
    translations = None
    if any(m.translations is not None for m in moved):
        tr = np.stack([m.local_translations() for m in moved])
        translations = np.einsum("nk,knjc->njc", w, tr)
    return Motion(ref.skeleton, ref.fps, root, q_out, translations, name)
