"""Physics-checked numbers for a clip: contacts, footskate, ground, limits, pops, hitting.

Every definition follows ``docs/METRICS.md``; every threshold is a parameter with the documented
default (:class:`~mjmotion.thresholds.Params`), and a :class:`Report` carries the values it used.
The world is MuJoCo's: Z up, metres. Ground metrics measure from one floor (:mod:`mjmotion.floor`):
given, taken from the source clip(s) a result is judged against, or detected from the clip's own
stance. Feet are calibrated sole points (:mod:`mjmotion.feet`).

Reusable building blocks (other modules import these; the feet and thresholds are re-exported
from :mod:`mjmotion.feet` and :mod:`mjmotion.thresholds`):

- :func:`foot_heights_speeds` ``(compiled, motion, pose=None, floor=None, soles=None) -> FootTrack``
- :func:`contacts` ``(track, h_c, v_c, hysteresis) -> (T, F) bool``: contact with hysteresis.
- :func:`planted_skate_mm_per_s` ``(motion | track)``: the headline footskate, over contact frames.
- :func:`skate_mm_per_s` ``(motion | track, h_c)``: the height-weighted variant.
- :func:`skating_ratio` (GMD), :func:`skate_sensitivity` (the ``h_c`` table).
- :func:`ground_metrics` ``(lowest_z, track) -> GroundMetrics`` (penetrate_mm, float_mm, phys_err_mm, floors).
- :func:`worst_joint_speed_ratio` ``(result, sources)``, :func:`pop_frames` ``(result, reference)``,
  :func:`max_joint_speed_ratio` (whole-body), :func:`root_jump_m`, :func:`limit_violation_ratio`,
  :func:`grip_error_m`.
- :func:`evaluate` ``(motion, props=(), ball=None, hit_frame=None, params, sources=(), floor=None) -> Report``
  runs everything (physics residuals from :mod:`mjmotion.physics`).
"""

from __future__ import annotations

import hashlib
import pickle
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import mujoco
import numpy as np

from . import floor as floors
from . import kinematics, mjcf, physics
from . import rotations as rot
from .errors import MjmotionError, is_whole
from .feet import (
    FootTrack,
    box_corners,
    check_sources,
    contacts,
    flight_frames,
    foot_heights_speeds,
    foot_track,
    geom_frames,
    judged_feet,
    level_motion,
    level_pose,
    low_both,
    lowest_body_point,
    lowest_points,
    planted_speeds,
)
from .filters import moving_mean
from .mjcf import CompiledModel
from .skeleton import Motion, Skeleton
from .thresholds import (
    ACCEL_FLOOR,
    DEFAULTS,
    FLOAT_TOL,
    H_C,
    H_C_SENSITIVITY,
    HYSTERESIS,
    MAX_JUDGED_FPS,
    MIN_FRAMES,
    PEAK_PERCENTILE,
    POP_FACTOR,
    SKATE_WINDOW,
    SPEED_FLOOR,
    V_C,
    Params,
)

__all__ = [
    "FLOAT_TOL", "H_C", "H_C_SENSITIVITY", "HYSTERESIS", "SKATE_WINDOW", "V_C", "FootTrack", "GroundMetrics", "MjmotionError",
    "Params", "Report", "box_corners", "contacts", "evaluate", "flight_frames", "foot_heights_speeds", "foot_track", "geom_frames",
    "grip_error_m", "ground_metrics", "joint_angular_accelerations", "joint_angular_speeds", "limit_violation_ratio",
    "low_both", "lowest_body_point", "lowest_points", "max_joint_speed_ratio", "planted_skate_mm_per_s", "pop_frames", "root_jump_m",
    "skate_mm_per_s", "skate_sensitivity", "skating_ratio", "worst_joint_speed_ratio",
]  # fmt: skip


def _track(x: Motion | FootTrack) -> FootTrack:
    return x if isinstance(x, FootTrack) else foot_heights_speeds(None, x)


# --------------------------------------------------------------------------- footskate


def planted_skate_mm_per_s(track: FootTrack | Motion, h_c: float = H_C, v_c: float = V_C, hysteresis: float = HYSTERESIS) -> float:
    """The headline footskate: mean horizontal speed (mm/s) of each foot's lowest sole point over
    its contact frames (:func:`contacts`), pooled over feet; NaN with no contact frame. The speed
    is measured from the plant's own frames (:func:`mjmotion.feet.planted_speeds`)."""
    tr = _track(track)
    con = contacts(tr, h_c, v_c, hysteresis)
    return float(1000.0 * planted_speeds(tr, con)[con].mean()) if con.any() else float("nan")


def skate_weights(heights: np.ndarray, h_c: float = H_C) -> np.ndarray:
    """Height weights ``w = 2 − 2^(h/h_c)`` clipped to [0, 1]: 1 on (or below) the floor, 0 at ``h_c``."""
    # (the exponent capped at 1, where the weight is already 0: a tiny h_c overflowed 2^x with a warning)
    return np.clip(2.0 - np.power(2.0, np.minimum(heights / h_c, 1.0)), 0.0, 1.0)


def skate_mm_per_s(track: FootTrack | Motion, h_c: float = H_C) -> float:
    """Height-weighted footskate (mm/s), for comparison with published numbers: over every frame
    and foot whose lowest sole point is below ``h_c``, the mean of its horizontal speed × the
    weight :func:`skate_weights` (a swing foot passing high counts little, a planted one fully).
    NaN when no foot is ever that low."""
    tr = _track(track)
    low = tr.heights < h_c
    if not low.any():
        return float("nan")
    return float(1000.0 * (tr.speeds * skate_weights(tr.heights, h_c))[low].mean())


def skating_ratio(track: FootTrack | Motion, h_c: float = H_C, v: float = V_C, window: int = SKATE_WINDOW) -> float:
    """GMD's skating ratio: fraction of frames where some foot is low (t, t-1) while its horizontal
    speed averaged over a centred ``window``-frame window exceeds ``v`` m/s."""
    tr = _track(track)
    avg = moving_mean(tr.speeds, window, axis=0)
    skating = low_both(tr, h_c) & (avg > v)
    return float(skating.any(axis=1).mean())


def skate_sensitivity(
    track: FootTrack | Motion,
    h_cs: Sequence[float] = H_C_SENSITIVITY,
    v_c: float = V_C,
    hysteresis: float = HYSTERESIS,
    window: int = SKATE_WINDOW,
) -> list[dict[str, float]]:
    """Rows ``{h_c, planted_skate_mm_per_s, skate_mm_per_s, skating_ratio, contact_fraction}`` for
    each contact height ``h_c`` (UnderPressure, 2022: contact labels from thresholds are fragile);
    ``window``: the skating ratio's, as the report's own."""
    tr = _track(track)
    return [
        {
            "h_c": float(h),
            "planted_skate_mm_per_s": planted_skate_mm_per_s(tr, h, v_c, hysteresis),
            "skate_mm_per_s": skate_mm_per_s(tr, h),
            "skating_ratio": skating_ratio(tr, h, v_c, window),
            "contact_fraction": float(contacts(tr, h, v_c, hysteresis).any(axis=1).mean()),
        }
        for h in h_cs
    ]


# --------------------------------------------------------------------------- ground


@dataclass(frozen=True)
class GroundMetrics:
    """PhysDiff ground metrics (per frame, averaged over frames), measured from ``floor_m``.

    ``floor_offset_m`` is the clip's own stance floor (:func:`mjmotion.floor.detect`), reported
    whatever floor was used; ``floor_m`` the floor the metrics used.
    """

    penetrate_mm: float
    float_mm: float
    skate_mm_per_frame: float
    phys_err_mm: float
    fps: float
    floor_offset_m: float
    max_penetrate_mm: float
    floor_m: float = 0.0


def ground_metrics(
    lowest_z: np.ndarray,
    track: FootTrack,
    h_c: float = H_C,
    v_c: float = V_C,
    float_tol: float = FLOAT_TOL,
    hysteresis: float = HYSTERESIS,
) -> GroundMetrics:
    """Ground metrics from ``lowest_z: (T,)``, the world height of the lowest body point per frame
    (:func:`lowest_body_point`), and the feet (their floor is the floor used).

    Skate displacement per frame: horizontal displacement (mm) of the feet in contact between
    frames (their planted speed / fps, :func:`mjmotion.feet.planted_speeds`), averaged over the feet in contact, 0 when none; then over all frames.
    """
    z = np.asarray(lowest_z, dtype=float) - track.floor
    pen = np.maximum(0.0, -z)
    flo = np.maximum(0.0, z - float_tol)
    con = contacts(track, h_c, v_c, hysteresis)
    disp = np.nan_to_num(planted_speeds(track, con)) / track.fps * 1000.0
    n = con.sum(axis=1)
    per_frame = np.where(n > 0, (disp * con).sum(axis=1) / np.maximum(n, 1), 0.0)
    p, f, s = float(pen.mean() * 1000), float(flo.mean() * 1000), float(per_frame.mean())
    return GroundMetrics(p, f, s, p + f + s, float(track.fps), track.detected_floor(), float(pen.max() * 1000), float(track.floor))


# --------------------------------------------------------------------------- smoothness and limits


def joint_angular_speeds(motion: Motion) -> np.ndarray:
    """``(T-1, J)`` angular speed (rad/s) of every joint's local rotation between frames."""
    q = motion.rotations
    d = rot.multiply(rot.conjugate(q[:-1]), q[1:])
    return 2.0 * np.arctan2(rot.norm(d[..., 1:]), np.abs(d[..., 0])) * motion.fps


def joint_angular_accelerations(motion: Motion) -> np.ndarray:
    """``(T, J)`` magnitude (rad/s²) of each joint's local angular acceleration: the change of the
    angular velocity vector ``log(q_t⁻¹ q_{t+1})·fps`` (:func:`mjmotion.rotations.log`: axis × angle)
    between the steps either side of frame t, times fps (0 at the first and last frame)."""
    out = np.zeros((motion.n_frames, motion.skeleton.n_joints))
    if motion.n_frames < 3:
        return out
    q = motion.rotations
    omega = rot.log(rot.multiply(rot.conjugate(q[:-1]), q[1:])) * motion.fps  # (T-1, J, 3) rad/s
    out[1:-1] = rot.norm(np.diff(omega, axis=0)) * motion.fps
    return out


def _as_list(sources: Motion | Sequence[Motion]) -> list[Motion]:
    return [sources] if isinstance(sources, Motion) else list(sources)


def _robust_peaks(values: Sequence[np.ndarray], percentile: float, floor: float) -> np.ndarray:
    """``(J,)`` per joint: the largest over clips of the ``percentile``-th percentile over frames, at least ``floor``."""
    return np.maximum(np.max([np.percentile(v, percentile, axis=0) for v in values], axis=0), floor)


def worst_joint_speed_ratio(result: Motion, sources: Motion | Sequence[Motion], floor: float = 1.0) -> tuple[float, str]:
    """Per-joint pops against the sources: the largest, over joints, of the joint's peak angular
    speed in ``result`` over the same joint's peak in the ``sources`` (at least ``floor`` rad/s);
    and that joint's name. 1 means no joint faster than in its sources.

    Per joint, so a glitchy finger in a source cannot hide a popping knee (the whole-body
    :func:`max_joint_speed_ratio` can). The peak is each joint's maximum, not a percentile: a
    clip against itself then reads exactly 1 and a glitch the result inherits from its source
    does not count (against their own 99th percentiles the shared clips read 1.5-44).
    """
    src = _as_list(sources)
    for s in src:
        result.skeleton.require_same_topology(s.skeleton, "the result and its source")
    if result.n_frames < 2:
        return float("nan"), ""
    ref = np.maximum(np.max([joint_angular_speeds(s).max(axis=0) for s in src if s.n_frames > 1], axis=0), floor)
    ratio = joint_angular_speeds(result).max(axis=0) / ref
    j = int(np.argmax(ratio))
    return float(ratio[j]), result.skeleton.names[j]


def pop_frames(
    result: Motion,
    reference: Motion | Sequence[Motion] | None = None,
    factor: float = POP_FACTOR,
    percentile: float = PEAK_PERCENTILE,
    floor: float = ACCEL_FLOOR,
) -> np.ndarray:
    """``(T,)`` bool: frames where some joint's angular acceleration (:func:`joint_angular_accelerations`)
    exceeds ``factor`` × that joint's robust peak (``percentile``-th percentile over frames, at
    least ``floor`` rad/s²) in ``reference`` (the sources; None: the clip itself)."""
    acc = joint_angular_accelerations(result)
    refs = [acc] if reference is None else [joint_angular_accelerations(m) for m in _as_list(reference)]
    return np.asarray((acc > factor * _robust_peaks(refs, percentile, floor)).any(axis=1))


def max_joint_speed_ratio(result: Motion, sources: Motion | Sequence[Motion], floor: float = SPEED_FLOOR) -> float:
    """Whole-body: max joint angular speed of ``result`` over the max in ``sources``, at least ``floor``
    rad/s as :func:`worst_joint_speed_ratio`'s (a still source's rounding noise read 0.00 → 3.67); kept for
    comparison: blind to a knee popping under a glitchy finger (:func:`worst_joint_speed_ratio` is not)."""
    src = max(float(joint_angular_speeds(s).max()) for s in _as_list(sources))
    return float(joint_angular_speeds(result).max() / max(src, floor))


def root_jump_m(result: Motion, sources: Motion | Sequence[Motion]) -> float:
    """Largest frame-to-frame root displacement (m) of ``result`` minus the largest in ``sources``."""

    def jump(m: Motion) -> float:
        return float(np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1).max()) if m.n_frames > 1 else 0.0

    return jump(result) - max(jump(s) for s in _as_list(sources))


def grip_error_m(result: Motion, source: Motion, first_hand: str | int, second_hand: str | int) -> float:
    """Two-handed props: max over frames of the distance between the second hand and where the
    source holds it relative to the first hand (position in the first hand's frame), metres.

    ``result`` and ``source`` are paired frame by frame (the shorter length is used).
    """
    skel = source.skeleton
    a = first_hand if isinstance(first_hand, int) else skel.index(first_hand)
    b = second_hand if isinstance(second_hand, int) else skel.index(second_hand)
    n = min(result.n_frames, source.n_frames)
    c = mjcf.compile(skel)
    ps = kinematics.forward(c, source[:n])
    pr = kinematics.forward(c if result.skeleton is skel else mjcf.compile(result.skeleton), result[:n])
    rel = rot.rotate(rot.conjugate(ps.joint_rotations[:, a]), ps.joint_positions[:, b] - ps.joint_positions[:, a])
    want = pr.joint_positions[:, a] + rot.rotate(pr.joint_rotations[:, a], rel)
    return float(np.linalg.norm(pr.joint_positions[:, b] - want, axis=1).max())


def limit_violation_ratio(compiled: CompiledModel, motion: Motion) -> tuple[float, int]:
    """Fraction of frames where a joint leaves its declared range, and the number of limited joints.

    Ball joints: rotation angle beyond ``range[1]`` (:mod:`mjmotion.limits` declares one on every
    ball joint); slide/hinge: outside ``[range[0], range[1]]``. A model without limits gives ``(0.0, 0)``.
    """
    m = compiled.model
    q = kinematics.qpos(compiled, motion)
    bad = np.zeros(motion.n_frames, dtype=bool)
    n = 0
    for j in range(m.njnt):
        if not m.jnt_limited[j]:
            continue
        n += 1
        a = int(m.jnt_qposadr[j])
        lo, hi = m.jnt_range[j]
        t = m.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_BALL:
            w = np.clip(np.abs(q[:, a]), 0.0, 1.0)
            bad |= 2.0 * np.arccos(w) > hi
        elif t in (mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE):
            bad |= (q[:, a] < lo) | (q[:, a] > hi)
    return float(bad.mean()), n


# --------------------------------------------------------------------------- the report


@dataclass(frozen=True)
class Report:
    """Every metric of one clip (``docs/METRICS.md`` says what each means); ``None``/NaN where it
    does not apply (the per-joint ratios need sources)."""

    name: str
    n_frames: int
    fps: float
    params: Params
    skate_mm_per_s: float
    planted_skate_mm_per_s: float
    skating_ratio: float
    contact_fraction: float
    flight_fraction: float
    sensitivity: tuple[dict[str, float], ...]
    penetrate_mm: float
    float_mm: float
    phys_err_mm: float
    max_penetrate_mm: float
    floor_offset_m: float
    root_force_ratio_mean: float
    flight_residual: float
    physics_violation_ratio: float
    limit_violation_ratio: float
    limited_joints: int
    max_joint_speed_rad_s: float
    max_root_step_m: float
    floor_m: float
    floor_from: str
    ground_residual_mean: float
    pop_frames: int
    sources: int
    worst_joint_speed_ratio: float | None
    worst_joint: str | None
    max_joint_speed_ratio: float | None
    root_jump_m: float | None
    soles_calibrated: bool
    hit: dict[str, Any] | None = field(default=None)
    floor_tilt_deg: float = 0.0
    floor_rise: tuple[float, float] = (0.0, 0.0)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["sensitivity"] = [dict(r) for r in self.sensitivity]
        return d

    def __repr__(self) -> str:
        """The clip and its headline metrics (:meth:`to_dict` has every one)."""
        from .summary import fields

        return fields(
            "Report",
            repr(self.name),
            frames=self.n_frames,
            fps=self.fps,
            planted_skate_mm_per_s=self.planted_skate_mm_per_s,
            penetrate_mm=self.penetrate_mm,
            float_mm=self.float_mm,
            physics_violation_ratio=self.physics_violation_ratio,
            pop_frames=self.pop_frames,
        )

    def to_markdown(self) -> str:
        """The report as a two-column Markdown table: :meth:`row`'s values, rounded for reading."""
        from .summary import markdown_table

        return markdown_table(self.row(), header=("metric", self.name or "value"))

    def notes(self) -> list[str]:
        """Lines worth telling the user (a detected floor far from z = 0 or tilted)."""
        level = floors.Level(tilt_deg=self.floor_tilt_deg, rise=self.floor_rise)
        note = floors.Floor(self.floor_m, self.floor_from, level).note(self.name)
        return [note] if note else []

    def row(self) -> dict[str, Any]:
        """The flat, table-friendly summary (one value per column)."""
        r: dict[str, Any] = {
            "clip": self.name,
            "frames": self.n_frames,
            "fps": round(self.fps, 2),
            "planted_mm_s": self.planted_skate_mm_per_s,
            "skate_mm_s": self.skate_mm_per_s,
            "skating_ratio": self.skating_ratio,
            "contact_frac": self.contact_fraction,
            "flight": self.flight_fraction,
            "penetrate_mm": self.penetrate_mm,
            "float_mm": self.float_mm,
            "phys_err_mm": self.phys_err_mm,
            "floor_m": self.floor_m,
            "floor_from": self.floor_from,
            "floor_tilt": self.floor_tilt_deg,
            "flight_resid": self.flight_residual,
            "phys_viol": self.physics_violation_ratio,
            "limit_viol": self.limit_violation_ratio,
            "pops": self.pop_frames,
        }
        if self.sources:
            r["worst_speed_ratio"] = self.worst_joint_speed_ratio
            r["worst_joint"] = self.worst_joint
        for s in self.sensitivity:
            r[f"planted@{s['h_c']:.2f}"] = s["planted_skate_mm_per_s"]
        if self.hit:
            for k in ("hit_error_m", "contact", "impact_speed", "launch_azimuth_deg", "launch_elevation_deg", "launch_speed"):
                if k in self.hit:
                    r[k] = self.hit[k]
        return r


#: Compiled models kept per process for the judge, by skeleton and props: a folder's clips often
#: share one skeleton (cgspeed puts every subject on one), and a compile costs 10-15 ms of each clip.
MODEL_CACHE = 16
_models: OrderedDict[bytes, CompiledModel] = OrderedDict()


def judge_model(skeleton: Skeleton, props: Sequence[mjcf.Prop] = ()) -> CompiledModel:
    """``mjmotion.mjcf.compile(skeleton, props)``, reused for an equal skeleton and props (the
    judge only reads the model: its kinematics and inverse dynamics run on their own ``MjData``)."""
    key = hashlib.blake2b(pickle.dumps((skeleton, tuple(props)), protocol=pickle.HIGHEST_PROTOCOL), digest_size=20).digest()
    hit = _models.get(key)
    if hit is not None:
        _models.move_to_end(key)
        return hit
    compiled = mjcf.compile(skeleton, tuple(props))
    _models[key] = compiled
    while len(_models) > MODEL_CACHE:
        _models.popitem(last=False)
    return compiled


def require_frames(n_frames: int) -> None:
    """One minimum, said once (a 1-frame clip failed on foot speeds, a 2-frame one on inverse dynamics)."""
    if n_frames < MIN_FRAMES:
        raise MjmotionError(
            f"{n_frames} frame(s); the judge needs at least {MIN_FRAMES} frames (speeds and accelerations are differences between frames)"
        )


def evaluate(
    motion: Motion,
    props: Sequence[mjcf.Prop] = (),
    ball: mjcf.Ball | None = None,
    hit_frame: int | None = None,
    params: Params = DEFAULTS,
    launch: bool = True,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    sources: Sequence[Motion] = (),
    floor: float | None = None,
) -> Report:
    """All metrics of ``motion``.

    ``sources``: the clip(s) it was made from (same skeleton and frame rate): they give the floor
    (unless ``floor`` is given) and the feet's calibration, and the per-joint speed and pop
    references. ``floor``: the floor height (m). With ``ball`` and ``hit_frame``: the hitting metrics
    too (effector: the first prop's sweet spot, else the foot or hand geom nearest the ball).
    """
    if not isinstance(motion, Motion):  # (a path gave "'str' object has no attribute 'fps'")
        raise MjmotionError(f"evaluate: expected a Motion (mjmotion.read(path) reads one), got {type(motion).__name__}")
    check_sources(motion, sources)  # (a list of Motions of its skeleton and rate, not itself)
    sources = list(sources)
    if motion.fps > MAX_JUDGED_FPS:
        raise MjmotionError(
            f"{motion.name or 'the clip'}: {motion.fps:g} fps; the judge takes clips up to {MAX_JUDGED_FPS:g} fps (its filter and "
            "speed windows grow with the rate: a million frames at 10,000 fps would need 30 GB); resample it first (mjmotion convert --fps 120)"
        )
    if hit_frame is not None and ball is None:
        raise MjmotionError(f"hit_frame={hit_frame} without a ball: the hit frame is where the effector meets ball=mjcf.Ball(...)")
    if ball is not None:
        if hit_frame is None:
            raise MjmotionError("a ball needs a hit frame (--frame H)")
        if not is_whole(hit_frame):
            raise MjmotionError(f"hit_frame={hit_frame!r}: expected a whole frame number")
        mjcf.check_vector("ball_velocity", ball_velocity, 3, "m/s")
    require_frames(motion.n_frames)
    compiled = judge_model(motion.skeleton, props)
    pose = kinematics.forward(compiled, motion)
    track, soles, fl = judged_feet(compiled, motion, pose, [(s, kinematics.forward(compiled, s)) for s in sources], floor, params.speed_window)
    # A tilted stance floor is levelled: the body and its dynamics are measured in that frame too.
    captured = motion  # the ball and its velocity are given in the captured frame
    pose, motion = level_pose(fl.level, pose), level_motion(fl.level, motion)
    lz = lowest_body_point(compiled, pose, track.heights.min(axis=1) + fl.height)
    g = ground_metrics(lz, track, params.h_c, params.v_c, params.float_tol, params.hysteresis)
    res = physics.residuals(compiled, motion, track, params, ground=lz - fl.height, pose=pose)
    lim, nlim = limit_violation_ratio(compiled, motion)
    speeds = joint_angular_speeds(motion) if motion.n_frames > 1 else np.zeros((1, 1))
    steps = rot.norm(np.diff(motion.root_positions, axis=0)) if motion.n_frames > 1 else np.zeros(1)
    pops = pop_frames(motion, sources or None, params.pop_factor, params.peak_percentile, params.accel_floor)
    worst, joint = (None, None)
    if sources:
        worst, joint = worst_joint_speed_ratio(motion, sources, params.speed_floor)
    hit = None
    if ball is not None:
        assert hit_frame is not None  # (checked above)
        hit = physics.hit_metrics(captured, ball, hit_frame, props=tuple(props), launch=launch, ball_velocity=ball_velocity)
    con = contacts(track, params.h_c, params.v_c, params.hysteresis)
    sens = skate_sensitivity(track, params.h_c_sensitivity, params.v_c, params.hysteresis, params.skate_window)
    # The headline footskate is the sensitivity row at the report's own h_c when there is one (same arguments).
    at_h_c = next((r for r in sens if r["h_c"] == float(params.h_c)), None)
    return Report(
        name=motion.name,
        n_frames=motion.n_frames,
        fps=float(motion.fps),
        params=params,
        skate_mm_per_s=at_h_c["skate_mm_per_s"] if at_h_c else skate_mm_per_s(track, params.h_c),
        planted_skate_mm_per_s=at_h_c["planted_skate_mm_per_s"]
        if at_h_c
        else planted_skate_mm_per_s(track, params.h_c, params.v_c, params.hysteresis),
        skating_ratio=skating_ratio(track, params.h_c, params.v_c, params.skate_window),
        contact_fraction=float(con.any(axis=1).mean()),
        flight_fraction=float((~con.any(axis=1)).mean()),
        sensitivity=tuple(sens),
        penetrate_mm=g.penetrate_mm,
        float_mm=g.float_mm,
        phys_err_mm=g.phys_err_mm,
        max_penetrate_mm=g.max_penetrate_mm,
        floor_offset_m=g.floor_offset_m,
        root_force_ratio_mean=float(np.mean(res.root_force_ratio)),
        flight_residual=res.flight_residual,
        physics_violation_ratio=res.physics_violation_ratio,
        limit_violation_ratio=lim,
        limited_joints=nlim,
        max_joint_speed_rad_s=float(speeds.max()),
        max_root_step_m=float(steps.max()),
        floor_m=fl.height,
        floor_from=fl.from_,
        floor_tilt_deg=fl.level.tilt_deg,
        floor_rise=fl.level.rise,
        ground_residual_mean=float(np.mean(res.residual)),
        pop_frames=int(pops.sum()),
        sources=len(sources),
        worst_joint_speed_ratio=worst,
        worst_joint=joint,
        max_joint_speed_ratio=max_joint_speed_ratio(motion, sources, params.speed_floor) if sources else None,
        root_jump_m=root_jump_m(motion, sources) if sources else None,
        soles_calibrated=soles.calibrated,
        hit=hit,
    )
