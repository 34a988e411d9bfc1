"""Footskate cleanup after Kovar, Schreiner & Gleicher (2002), the constraint step seed 000 §2.1
planned and §4 left undone. Feet, floor and contacts are the judge's (:mod:`mjmotion.feet`,
:mod:`mjmotion.floor`): a cleaned clip is held still exactly where the judge looks.

1. **Plants**: runs of the judge's contact frames per foot (:func:`mjmotion.feet.contacts`, with
   hysteresis), gaps of up to ``max_gap`` frames closed, runs shorter than ``min_plant`` frames
   dropped. Then, up to ``refine`` times, the result is labelled again and every contact frame
   that is not held still grows the plant beside it or starts one (:func:`grow_plants`).
2. **Fix each plant**: the point that touches the floor — the lowest sole point, heel, ball or
   toe tip — stays where it is while the foot turns as captured (:func:`contact_paths`: the
   ankle rolls about it). ``hold_orientation`` holds one world orientation through each plant
   instead (its middle frame's; stiller feet, but the leg must then stretch at toe-off and the
   knee pops, measured). A plant below the floor is raised onto it.
3. **Blend**: outside plants the pinning offset fades with a smoothstep over ``blend`` seconds;
   between two close plants it moves smoothly from one offset to the next; for ``ease`` seconds
   beside each plant the foot leaves (reaches) it from rest, its touching point still at the
   edge (:func:`edge_paths`), so neither the knee nor the judge's smoothed foot speed sees a jump.
4. **Floor**: no sole below the floor: a foot in it is lifted out, smoothly (max filter and Hann
   window over ``lift_ramp`` seconds). Swing lifting (:func:`swing_lift`, ``clearance`` > 0) is an
   option, off by default: it raises a foot that moves within ``clearance`` of the floor outside
   plants, which fixes the old height-only footskate metric more than the motion.
5. **Root**: where a target is beyond the leg's reach (``reach`` × thigh + shin), the root moves
   towards it by the shortfall, smoothed with a finite Hann window so it stays local; where a
   knee would go lower than captured under the floor, the root rises.
6. **Legs**: analytic two-bone IK per frame (vectorised, :func:`mjmotion.ik.analytic.two_bone`):
   the knee bends in its captured plane — turning towards its own hinge where the captured knee
   is nearly straight (:data:`STRAIGHT_KNEE_DEG`), whose plane is marker noise — and the hip
   swings the ankle onto the target; the ankle's local rotation then gives the foot its
   orientation. Bone lengths are unchanged.

Frames outside every plant's blend window (and the root window) where no foot is lifted keep
their joint angles exactly; only hips, knees and ankles (and the root) ever change.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from . import feet as ft
from . import floor as floors
from . import kinematics, mjcf
from . import rotations as rot
from .errors import MjmotionError, require_number
from .ik import analytic
from .skeleton import Motion
from .thresholds import H_C, HYSTERESIS, V_C


@dataclass(frozen=True)
class CleanupParams:
    """Cleanup settings. ``h_c``/``v_c``/``hysteresis`` as the judge's contact; times in seconds.

    ``floor`` (m): the floor height plants stand on (None: from the sources given to
    :func:`cleanup`, else the clip's own stance floor, as :mod:`mjmotion.floor` decides).
    ``clearance`` (m): height a moving foot is lifted to outside plants (0, the default: never
    lift, swings stay as captured; None: ``h_c``); ``lift_ramp``: how quickly a lift rises.
    """

    h_c: float = H_C
    v_c: float = V_C
    hysteresis: float = HYSTERESIS
    min_plant: float = 0.05
    max_gap: float = 0.03
    blend: float = 0.2
    reach: float = 0.995
    root_window: float = 0.3
    refine: int = 8
    clearance: float | None = 0.0
    lift_ramp: float = 0.05
    floor: float | None = None
    hold_orientation: bool = False
    ease: float = 0.05

    def __post_init__(self) -> None:
        for name, low, strict in (("h_c", 0.0, True), ("v_c", 0.0, True), ("min_plant", 0.0, False), ("max_gap", 0.0, False),
                                  ("blend", 0.0, False), ("reach", 0.0, True), ("root_window", 0.0, False), ("lift_ramp", 0.0, False)):  # fmt: skip
            require_number(f"CleanupParams.{name} =", getattr(self, name), low, strict, 1.0 if name == "reach" else None)
        if self.clearance is not None:
            require_number("CleanupParams.clearance =", self.clearance, 0.0, False, None)
        if self.floor is not None and not (isinstance(self.floor, numbers.Real) and math.isfinite(self.floor)):
            raise MjmotionError(f"CleanupParams.floor = {self.floor!r}: expected a finite floor height in metres")
        require_number("CleanupParams.hysteresis =", self.hysteresis, 0.0, False, 0.999)
        if not isinstance(self.refine, numbers.Integral) or isinstance(self.refine, bool) or self.refine < 0:
            raise MjmotionError(f"CleanupParams.refine = {self.refine!r}: expected a whole number ≥ 0")

    @property
    def swing_clearance(self) -> float:
        """Height (m) a moving foot is lifted to: ``clearance``, by default ``h_c`` (0 turns lifting off)."""
        return self.h_c if self.clearance is None else float(self.clearance)


@dataclass(frozen=True)
class Plant:
    """A foot plant: ``side``, frames ``[start, stop)``, pinned ankle position ``(x, y)`` metres."""

    side: str
    start: int
    stop: int
    position: tuple[float, float]


@dataclass(frozen=True)
class CleanupResult:
    """The cleaned motion and what was done; ``lift: (T, F)`` how far step 4 raised each foot (m:
    out of the floor, and swing lifting when on);
    ``floor``: the floor used (m, world z, and where it came from)."""

    motion: Motion
    plants: tuple[Plant, ...]
    changed_frames: np.ndarray
    max_root_shift_m: float
    unreached_frames: int
    params: CleanupParams = field(default_factory=CleanupParams)
    lift: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    floor: floors.Floor = field(default_factory=lambda: floors.Floor(0.0, "given"))
    raised_plants: int = 0

    def to_dict(self) -> dict[str, object]:
        return {
            "plants": [{"side": p.side, "start": p.start, "stop": p.stop, "x": p.position[0], "y": p.position[1]} for p in self.plants],
            "changed_frames": int(self.changed_frames.sum()),
            "max_root_shift_m": self.max_root_shift_m,
            "unreached_frames": self.unreached_frames,
            "lifted_frames": int((self.lift > 0).any(axis=1).sum()) if self.lift.size else 0,
            "max_lift_m": float(self.lift.max()) if self.lift.size else 0.0,
            "raised_plants": self.raised_plants,
            "floor_m": self.floor.height,
            "floor_from": self.floor.from_,
            "params": self.params.__dict__,
        }

    def __repr__(self) -> str:
        """What the cleanup did, in a line (:meth:`to_dict` has the plants)."""
        from .summary import fields

        d = self.to_dict()
        keep = ("changed_frames", "max_root_shift_m", "unreached_frames", "raised_plants", "floor_m")
        return fields("CleanupResult", repr(self.motion.name), plants=len(self.plants), **{k: d[k] for k in keep})

    def to_markdown(self) -> str:
        """The result as a two-column Markdown table (plants counted, parameters as ``params.NAME``)."""
        from .summary import markdown_table

        d = self.to_dict()
        del d["params"]
        d["plants"] = len(self.plants)
        params = {f"params.{k}": v for k, v in vars(self.params).items()}
        return markdown_table({**d, **params}, header=("cleanup", self.motion.name or "value"))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` runs of True in a 1-D mask."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def find_plants(track: ft.FootTrack, ankles: np.ndarray, fps: float, params: CleanupParams = CleanupParams()) -> list[Plant]:
    """Plants from the judge's contact labels; ``ankles: (T, F, 3)`` world ankle positions."""
    con = ft.contacts(track, params.h_c, params.v_c, params.hysteresis)
    gap = round(params.max_gap * fps)
    shortest = max(2, round(params.min_plant * fps))
    plants = []
    for f, side in enumerate(track.sides):
        c = con[:, f].copy()
        for a, b in _runs(~c):
            if a > 0 and b < len(c) and b - a <= gap:
                c[a:b] = True
        for a, b in _runs(c):
            if b - a >= shortest:
                xy = ankles[a:b, f, :2].mean(axis=0)
                plants.append(Plant(side, a, b, (float(xy[0]), float(xy[1]))))
    return plants


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def pin_offsets(
    plants: list[Plant],
    ankles_xy: np.ndarray,
    fps: float,
    blend: float,
    paths: np.ndarray | None = None,
    edges: np.ndarray | None = None,
    ease: float = 0.1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How strongly and where to pin one foot.

    ``ankles_xy: (T, 2)`` the foot's captured ankle positions; ``plants`` of this foot;
    ``paths: (T, 2)`` where the ankle must be at each plant frame (default: the plant's fixed
    ``position``; :func:`contact_paths` lets the ankle roll so the touching point stays put).
    Returns the floor-plane offset ``(T, 2)`` onto the pinned positions, a weight ``(T,)`` in
    [0, 1] (1 inside plants, smoothstep ramps of ``blend`` seconds outside) and the index
    ``(T,)`` of the plant each frame is blended towards (-1 for none). ``edges: (T, 2)`` (NaN
    elsewhere): where the ankle would be beside each plant if its touching point stayed put
    (:func:`edge_paths`), what the foot leaves from and arrives on (default: the edge position).
    """
    t_count = len(ankles_xy)
    off = np.zeros((t_count, 2))
    w = np.zeros(t_count)
    owner = np.full(t_count, -1)
    n = max(1, round(blend * fps))
    plants = sorted(plants, key=lambda p: p.start)
    frames = np.arange(t_count)
    for i, p in enumerate(plants):
        goal = np.asarray(p.position) if paths is None else paths[p.start : p.stop]
        off[p.start : p.stop] = goal - ankles_xy[p.start : p.stop]
        w[p.start : p.stop] = 1.0
        owner[p.start : p.stop] = i
    for i, p in enumerate(plants):
        # Ramp in: from the previous plant's offset when it is close, else from zero.
        prev = plants[i - 1] if i > 0 else None
        if prev is not None and p.start - prev.stop <= 2 * n:
            a, b = prev.stop, p.start
            if b > a:
                s = _smoothstep((frames[a:b] - (a - 1)) / (b - a + 1))
                off[a:b] = (1 - s)[:, None] * off[a - 1] + s[:, None] * off[p.start]
                w[a:b] = 1.0
                owner[a:b] = np.where(s < 0.5, i - 1, i)
            continue
        lo = max(0, p.start - n)
        s = _smoothstep((frames[lo : p.start] - (p.start - n - 1)) / (n + 1))
        off[lo : p.start] = s[:, None] * off[p.start]
        w[lo : p.start] = s
        owner[lo : p.start] = i
    for i, p in enumerate(plants):
        nxt = plants[i + 1] if i + 1 < len(plants) else None
        if nxt is not None and nxt.start - p.stop <= 2 * n:
            continue
        hi = min(t_count, p.stop + n)
        s = _smoothstep((p.stop + n - frames[p.stop : hi]) / (n + 1))
        off[p.stop : hi] = s[:, None] * off[p.stop - 1]
        w[p.stop : hi] = s
        owner[p.stop : hi] = i
    _ease_off_plants(plants, off, ankles_xy, w, max(1, round(ease * fps)), edges)
    return off, w, owner


def _smootherstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


def _ease_off_plants(plants: list[Plant], off: np.ndarray, ankles_xy: np.ndarray, w: np.ndarray, m: int, edges: np.ndarray | None) -> None:
    """Make the pinned foot leave and reach each plant from rest (in place on ``off``).

    An offset faded in or out keeps the captured foot's velocity at the plant's edge, a jump
    from the held foot's zero (the knee pops, and the jump reads as footskate through the judge's
    smoothed speeds). For ``m`` frames beside each plant the ankle target moves from where the
    touching point would stay put (``edges``; else the edge position) to the faded path with a
    smootherstep (matching velocity and acceleration at both ends).
    """
    t_count = len(off)
    inside = np.zeros(t_count, dtype=bool)
    for p in plants:
        inside[p.start : p.stop] = True
    target = ankles_xy + off
    for p in plants:
        for edge, step in ((p.stop - 1, 1), (p.start, -1)):
            goal = np.broadcast_to(target[edge], target.shape).copy()
            if edges is not None:
                known = np.isfinite(edges[:, 0])
                goal[known] = edges[known]
            frames = edge + step * np.arange(1, m + 1)
            keep = (frames >= 0) & (frames < t_count)
            frames = frames[keep]
            free = frames[~inside[frames]] if len(frames) else frames
            # Stop at the next plant (or halfway to it when it is near).
            if len(free) < len(frames):
                free = free[: max(0, (np.flatnonzero(inside[frames])[0]) // 2)] if np.any(inside[frames]) else free
            g = _smootherstep(np.abs(free - edge) / (len(free) + 1)) if len(free) else free
            target[free] = (1 - g)[:, None] * goal[free] + g[:, None] * target[free]
            w[free] = np.maximum(w[free], 1e-3)
    off[:] = target - ankles_xy


def hold_orientations(plants: list[Plant], rotations: np.ndarray, fps: float, blend: float) -> tuple[np.ndarray, np.ndarray]:
    """The orientation one foot holds and how strongly, per frame.

    ``rotations: (T, 4)`` the foot's captured world rotations (wxyz). Through a plant the foot
    holds its middle frame's orientation; the weight ``(T,)`` ramps in and out over ``blend``
    seconds (smoothstep). Between two plants closer than twice that, the held orientation turns
    from one plant's to the next along the way (never switching at once) while the weight dips
    towards the captured swing and back. Returns held rotations ``(T, 4)`` and weights ``(T,)``.
    """
    t_count = len(rotations)
    n = max(1, round(blend * fps))
    frames = np.arange(t_count)
    held = rotations.copy()
    w = np.zeros(t_count)
    plants = sorted(plants, key=lambda p: p.start)
    mids = [rotations[(p.start + p.stop) // 2] for p in plants]
    ramp_in = lambda p, x: _smoothstep((x - (p.start - n - 1)) / (n + 1))
    ramp_out = lambda p, x: _smoothstep((p.stop + n - x) / (n + 1))
    for i, p in enumerate(plants):
        held[p.start : p.stop] = mids[i]
        w[p.start : p.stop] = 1.0
        prev = plants[i - 1] if i > 0 else None
        if prev is not None and p.start - prev.stop <= 2 * n:
            a, b = prev.stop, p.start
            if b > a:
                x = frames[a:b]
                s = _smoothstep((x - (a - 1)) / (b - a + 1))
                held[a:b] = rot.slerp(np.broadcast_to(mids[i - 1], (b - a, 4)), np.broadcast_to(mids[i], (b - a, 4)), s)
                w[a:b] = np.maximum(ramp_out(prev, x), ramp_in(p, x))
            continue
        lo = max(0, p.start - n)
        held[lo : p.start] = mids[i]
        w[lo : p.start] = ramp_in(p, frames[lo : p.start])
    for i, p in enumerate(plants):
        nxt = plants[i + 1] if i + 1 < len(plants) else None
        if nxt is not None and nxt.start - p.stop <= 2 * n:
            continue
        hi = min(t_count, p.stop + n)
        held[p.stop : hi] = mids[i]
        w[p.stop : hi] = ramp_out(p, frames[p.stop : hi])
    return held, w


def knee_hinge_axis(pose: kinematics.Pose, hip: int, knee: int, ankle: int) -> np.ndarray | None:
    """The knee's bend axis in the thigh's frame ``(3,)``: the mean over the frames where the
    captured knee is bent (over 3°) of ``(knee − hip) × (ankle − knee)``, or None if it never is.
    A straight captured leg has no bend plane; bending it about this axis keeps the knee bending
    the way it does in the rest of the clip (an axis picked from the target flips it).
    """
    jp = pose.joint_positions
    th, sh = jp[:, knee] - jp[:, hip], jp[:, ankle] - jp[:, knee]
    n = np.cross(th, sh)
    nn = np.linalg.norm(n, axis=1)
    bent = nn > math.sin(math.radians(3.0)) * np.linalg.norm(th, axis=1) * np.linalg.norm(sh, axis=1)
    if not bent.any():
        return None
    local = rot.rotate(rot.conjugate(pose.joint_rotations[bent, hip]), n[bent] / nn[bent, None]).mean(axis=0)
    size = np.linalg.norm(local)
    return local / size if size > 1e-9 else None


#: Below this knee bend (degrees) the captured bending plane is mostly marker noise: the IK's bend
#: axis turns smoothly towards the knee's own hinge (a straight knee's plane swivels from frame to frame).
STRAIGHT_KNEE_DEG = 15.0


def _knee_axes(hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray, hinge: np.ndarray) -> np.ndarray:
    """``(T, 3)`` unit bend axes: the captured bending plane's normal where the knee is bent, the
    knee's hinge ``(T, 3)`` (world) where it is straight, blended by a smoothstep of the bend angle."""
    u, v = knee - hip, ankle - knee
    n = np.cross(u, v)
    sine = np.linalg.norm(n, axis=-1) / np.maximum(np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1), 1e-12)
    bend = np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0)))
    w = _smoothstep(bend / STRAIGHT_KNEE_DEG)[:, None]
    plane = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    plane = np.where(np.sum(plane * hinge, axis=-1, keepdims=True) < 0, -plane, plane)  # the hinge's side
    axis = w * plane + (1 - w) * hinge
    return axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-12)


def _hann_smooth_max(x: np.ndarray, n: int) -> np.ndarray:
    """Smooth ``x: (T, 3)`` with a finite Hann window of ``2n+1`` frames (zero outside its support)."""
    if n < 1:
        return x
    k = np.hanning(2 * n + 3)[1:-1]
    k /= k.sum()
    # The centred T frames of the full convolution: np.convolve's "same" returns the longer of
    # the two inputs, so a clip shorter than the window would come back window-long.
    return np.stack([np.convolve(x[:, i], k, mode="full")[n : n + len(x)] for i in range(x.shape[1])], axis=1)


def swing_lift(heights: np.ndarray, speeds: np.ndarray, planted: np.ndarray, fps: float, clearance: float, v_c: float, ramp: float) -> np.ndarray:
    """How far to raise one foot at each frame so that it does not move over the floor.

    ``heights, speeds: (T,)`` the foot's lowest point above the floor (m) and its horizontal
    speed (m/s); ``planted: (T,)`` its plant frames. Outside plants a foot faster than ``v_c``
    with its lowest point under ``clearance`` scuffs the floor (METRICS counts it as footskate):
    it must rise to ``clearance`` (+1 mm). The need is spread with a max filter and a Hann window
    of ``ramp`` seconds either side, so the lift is smooth and covers it. A plant's foot rises
    (or comes down) in place over its last (first) ``ramp`` seconds, at most a quarter of the
    plant: it leaves the floor before it moves, and the rest of the plant stays on the floor.
    Returns ``(T,)`` ≥ 0.
    """
    from scipy.ndimage import distance_transform_edt, maximum_filter1d

    need = np.where((speeds > v_c) & ~planted, np.maximum(clearance + 1e-3 - heights, 0.0), 0.0)
    if not need.any():
        return need
    n = max(1, round(ramp * fps))
    # Hann(2n+1) of a (2n+1) max filter is ≥ the need at every frame (each tap sees that frame);
    # edge padding keeps that true at the clip's ends.
    padded = np.pad(maximum_filter1d(need, size=2 * n + 1, mode="nearest"), n, mode="edge")
    lift = _hann_smooth_max(padded[:, None], n)[n:-n, 0]
    # Zero on each plant's core (all but its first and last quarter, at most n frames each), rising
    # smoothly over n frames away from it: inside the plant when it is long enough, else beyond it.
    core = np.zeros_like(planted)
    for a, b in _runs(planted):
        m = min(n, (b - a) // 4)
        core[a + m * (a > 0) : b - m * (b < len(need))] = True
    if core.any():
        lift *= _smoothstep(distance_transform_edt(~core) / (n + 1))
    return np.where(lift > 1e-9, lift, 0.0)


def contact_paths(plants: list[Plant], ankles_xy: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Ankle floor-plane paths that keep the touching point of one foot still through its plants.

    ``reach: (T, P, 3)`` the foot's points relative to its ankle, in the world axes of the foot's
    target orientation (a rigid foot gives the same vectors every plant frame; a flexing toe does
    not). At each plant frame the lowest point — the one METRICS measures — is held where it was
    the frame before, so the ankle rolls about a heel or toe corner instead of that corner sliding.
    The path's mean over a plant is the plant's ``position``. Returns ``(T, 2)`` (``ankles_xy``
    outside plants).
    """
    out = ankles_xy.copy()
    k = np.argmin(reach[..., 2], axis=1)  # (T,)
    for p in plants:
        a, b = p.start, p.stop
        kk = k[a + 1 : b]
        step = -(reach[np.arange(a + 1, b), kk, :2] - reach[np.arange(a, b - 1), kk, :2])
        cum = np.concatenate([np.zeros((1, 2)), np.cumsum(step, axis=0)])
        out[a:b] = cum - cum.mean(axis=0) + np.asarray(p.position)
    return out


def edge_paths(plants: list[Plant], paths: np.ndarray, reach: np.ndarray, margin: int) -> np.ndarray:
    """``(T, 2)`` ankle positions for ``margin`` frames beside each plant that keep the plant's edge
    touching point (its lowest point at the first and last plant frame) where it is, the foot
    turning as captured; NaN elsewhere and inside plants. ``paths: (T, 2)`` from
    :func:`contact_paths`, ``reach: (T, P, 3)`` as there."""
    t_count = len(paths)
    out = np.full((t_count, 2), np.nan)
    inside = np.zeros(t_count, dtype=bool)
    for p in plants:
        inside[p.start : p.stop] = True
    for p in plants:
        for edge, frames in ((p.stop - 1, np.arange(p.stop, min(t_count, p.stop + margin))), (p.start, np.arange(max(0, p.start - margin), p.start))):
            frames = frames[~inside[frames]]
            if not len(frames):
                continue
            k = int(np.argmin(reach[edge, :, 2]))
            pivot = paths[edge] + reach[edge, k, :2]
            out[frames] = pivot - reach[frames, k, :2]
    return out


def _merge(plants: list[Plant], ankles_xy: np.ndarray, gap: int) -> list[Plant]:
    """One foot's plants sorted, those overlapping or closer than ``gap`` frames joined (positions re-averaged)."""
    spans: list[list[int]] = []
    for p in sorted(plants, key=lambda p: p.start):
        if spans and p.start - spans[-1][1] <= gap:
            spans[-1][1] = max(spans[-1][1], p.stop)
        else:
            spans.append([p.start, p.stop])
    side = plants[0].side if plants else ""
    means = [ankles_xy[a:b].mean(axis=0) for a, b in spans]
    return [Plant(side, a, b, (float(m[0]), float(m[1]))) for (a, b), m in zip(spans, means)]


def grow_plants(plants: list[Plant], residual: np.ndarray, ankles_xy: np.ndarray, gap: int, side: str | None = None) -> list[Plant]:
    """One foot's plants grown over ``residual: (T,)`` frames (contact in the result but not held still).

    A residual frame becomes a plant's inner frame (the plant covers it and one frame either side,
    so its central-difference speed is taken between held frames); residual frames within ``gap``
    of each other join one plant, and plants that come within ``gap`` frames merge.
    """
    t_count = len(residual)
    side = side if side is not None else plants[0].side if plants else ""  # a foot with no plant yet: the caller's side
    extra = [Plant(side, max(0, a - 1), min(t_count, b + 1), (0.0, 0.0)) for a, b in _runs(residual)]
    return _merge(list(plants) + extra, ankles_xy, gap)


def cleanup(motion: Motion, params: CleanupParams = CleanupParams(), sources: Sequence[Motion] = ()) -> CleanupResult:
    """Remove footskate from ``motion`` (see the module docstring).

    ``sources``: the clip(s) ``motion`` was made from (same skeleton), as for the judge: they
    calibrate the soles and give the floor unless ``params.floor`` is set.
    """
    skel = motion.skeleton
    feet = skel.feet()
    if not feet:
        raise MjmotionError(f"{motion.name}: no feet found by name; cleanup needs ankle joints")
    for s in sources:
        skel.require_same_topology(s.skeleton, "the clip and its source")
    compiled = mjcf.compile(skel)
    pose = kinematics.forward(compiled, motion)
    src_poses = [(kinematics.forward(compiled, s), s.fps) for s in sources]
    soles = ft.calibrate_soles(skel, src_poses or [(pose, motion.fps)])
    own = ft.foot_heights_speeds(compiled, motion, pose, floor=0.0, soles=soles)
    src_floors = [ft.foot_heights_speeds(compiled, s, p, floor=0.0, soles=soles).detected_floor() for s, (p, _) in zip(sources, src_poses)]
    fl = floors.resolve(params.floor, src_floors, own.detected_floor())
    track = own.at_floor(fl.height)
    legs = []
    for side in track.sides:
        ankle = feet[side][0]
        knee = int(skel.parents[ankle])
        hip = int(skel.parents[knee])
        if knee <= 0 or hip <= 0:
            raise MjmotionError(f"{motion.name}: the {side} foot {skel.names[ankle]!r} needs a knee and a hip above it")
        legs.append((hip, knee, ankle))
    ankles = pose.joint_positions[:, [a for _, _, a in legs]]
    # Every sole point in its ankle's frame (T, F, P, 3): constant for a rigid foot, moving with a toe joint.
    a_rot = pose.joint_rotations[:, [a for _, _, a in legs]]
    local = rot.rotate(rot.conjugate(a_rot)[:, :, None, :].repeat(track.points.shape[2], axis=2), track.points - ankles[:, :, None, :])
    plants = find_plants(track, ankles, motion.fps, params)
    gap = round(params.max_gap * motion.fps)
    ground = _Ground(fl.height, soles)
    old_low = np.minimum(ground.feet(pose), 0.0)
    for it in range(params.refine + 1):
        out, shift, unreached, lift, raised = _pin(compiled, motion, pose, legs, track.sides, ankles, local, plants, ground, old_low, params)
        if it == params.refine:
            break
        # Plants as the judge sees the result: any contact frame not held still grows or starts a plant.
        tr = ft.foot_heights_speeds(compiled, out, floor=fl.height, soles=soles)
        t_count = motion.n_frames
        held = np.zeros((t_count, len(legs)), dtype=bool)
        for p in plants:
            # A plant's end frames take their speed half from outside it (the clip's ends are one-sided).
            held[p.start + (p.start > 0) : p.stop - (p.stop < t_count), track.sides.index(p.side)] = True
        residual = ft.contacts(tr, params.h_c, params.v_c, params.hysteresis) & ~held
        grown = [
            q
            for f, side in enumerate(track.sides)
            for q in grow_plants([p for p in plants if p.side == side], residual[:, f], ankles[:, f, :2], gap, side)
        ]
        if sorted(grown, key=lambda p: (p.side, p.start)) == sorted(plants, key=lambda p: (p.side, p.start)):
            break
        plants = grown
    out = out.replace(name=motion.name)
    changed = (np.abs(out.rotations - motion.rotations).max(axis=(1, 2)) > 1e-9) | (np.linalg.norm(shift, axis=1) > 0)
    return CleanupResult(
        motion=out,
        plants=tuple(sorted(plants, key=lambda p: (p.start, p.side))),
        changed_frames=changed,
        max_root_shift_m=float(np.linalg.norm(shift, axis=1).max()),
        unreached_frames=unreached,
        params=params,
        lift=lift,
        floor=fl,
        raised_plants=raised,
    )


@dataclass(frozen=True, eq=False)
class _Ground:
    """The floor (m, world z) and the soles the cleanup measures feet and body with, as the judge does."""

    floor: float
    soles: ft.Soles

    def feet(self, pose: kinematics.Pose) -> np.ndarray:
        """``(T, F)`` lowest sole point of each foot above the floor."""
        return ft.sole_points(self.soles, pose)[..., 2].min(axis=2) - self.floor

    def body(self, compiled: mjcf.CompiledModel, pose: kinematics.Pose) -> np.ndarray:
        """``(T,)`` lowest point of the body (bone capsules and soles) above the floor."""
        return ft.lowest_body_point(compiled, pose, self.feet(pose).min(axis=1) + self.floor) - self.floor


def _pin(
    compiled: mjcf.CompiledModel,
    motion: Motion,
    pose: kinematics.Pose,
    legs: list[tuple[int, int, int]],
    sides: tuple[str, ...],
    ankles: np.ndarray,
    local: np.ndarray,
    plants: list[Plant],
    ground: _Ground,
    old_low: np.ndarray,
    params: CleanupParams,
) -> tuple[Motion, np.ndarray, int, np.ndarray, int]:
    """One pass of steps 2–6 for the given plants: the cleaned motion, root shift ``(T, 3)``,
    unreached frames, the swing lift ``(T, F)`` (m) and how many plants were raised onto the floor."""
    t_count = motion.n_frames
    targets = ankles.copy()
    lifts = np.zeros((t_count, len(legs)))
    support = np.zeros((t_count, len(legs)), dtype=bool)
    foot_rot = pose.joint_rotations[:, [a for _, _, a in legs]].copy()  # (T, F, 4) world
    # Where each foot must stay no lower than: on the floor (a captured foot in it is lifted out).
    floor_low = np.zeros_like(old_low)
    raised = 0
    for f, side in enumerate(sides):
        mine = sorted((p for p in plants if p.side == side), key=lambda p: p.start)
        _, w, owner = pin_offsets(mine, ankles[:, f, :2], motion.fps, params.blend)
        support[:, f] = w > 0
        # The foot holds one orientation through a plant (that of its middle frame), blended in/out.
        if params.hold_orientation:
            held, w_rot = hold_orientations(mine, foot_rot[:, f], motion.fps, params.blend)
            foot_rot[:, f] = rot.slerp(foot_rot[:, f], held, w_rot)
        # The point that touches the floor stays put (not the ankle): roll about it.
        reach = rot.rotate(foot_rot[:, f, None, :].repeat(local.shape[2], axis=1), local[:, f])
        paths = contact_paths(mine, ankles[:, f, :2], reach)
        edges = edge_paths(mine, paths, reach, max(1, round(params.ease * motion.fps)))
        off, _, _ = pin_offsets(mine, ankles[:, f, :2], motion.fps, params.blend, paths, edges, params.ease)
        targets[:, f, :2] += off
        # A plant under the floor is raised onto it, the raise blended in and out with the plant.
        low = targets[:, f, 2] + reach[..., 2].min(axis=1) - ground.floor  # (T,) lowest sole point
        deficit = np.array([max(0.0, -float(low[p.start : p.stop].min())) for p in mine])
        if deficit.size and deficit.max() > 0:
            raised += int((deficit > 0).sum())
            targets[:, f, 2] += np.where(owner >= 0, w * deficit[np.maximum(owner, 0)], 0.0)
        for p in mine:
            floor_low[p.start : p.stop, f] = 0.0
        if params.swing_clearance > 0:
            # A foot moving over the floor within h_c of it is what METRICS' footskate counts: lift it.
            planted = np.zeros(t_count, dtype=bool)
            for p in mine:
                planted[p.start : p.stop] = True
            pts = targets[:, f, None, :] + reach
            tr = ft.foot_track((side,), pts[:, None], motion.fps, ground.floor)
            lift = swing_lift(tr.heights[:, 0], tr.speeds[:, 0], planted, motion.fps, params.swing_clearance, params.v_c, params.lift_ramp)
            targets[:, f, 2] += lift
            support[:, f] |= lift > 0
            lifts[:, f] = lift
    # Root: move towards targets the legs cannot reach, smoothed so it does not pop.
    shift = np.zeros((t_count, 3))
    for f, (h, k, a) in enumerate(legs):
        hp = pose.joint_positions[:, h]
        reach_len = params.reach * (
            np.linalg.norm(pose.joint_positions[:, k] - hp, axis=1) + np.linalg.norm(pose.joint_positions[:, a] - pose.joint_positions[:, k], axis=1)
        )
        vec = targets[:, f] - hp
        dist = np.linalg.norm(vec, axis=1)
        excess = np.maximum(dist - reach_len, 0.0)
        need = vec / np.maximum(dist, 1e-12)[:, None] * excess[:, None]
        bigger = np.linalg.norm(need, axis=1) > np.linalg.norm(shift, axis=1)
        shift[bigger] = need[bigger]
    n_root = round(params.root_window * motion.fps / 2)
    if np.any(shift):
        # Smoothing spreads the shift; scale so the peak shortfall is still covered.
        raw_peak = np.linalg.norm(shift, axis=1)
        sm = _hann_smooth_max(shift, n_root)
        sm_norm = np.linalg.norm(sm, axis=1)
        hit = raw_peak > 0
        gain = float(np.max(raw_peak[hit] / np.maximum(sm_norm[hit], 1e-12))) if hit.any() else 1.0
        shift = sm * min(gain, 3.0)
    root = motion.root_positions + shift
    moved = motion.replace(root_positions=root)
    pose2 = kinematics.forward(compiled, moved) if np.any(shift) else pose
    out, unreached = _solve_legs(compiled, moved, pose2, pose, legs, targets, foot_rot, support, shift)
    # No sole below the floor (plants on it): lift those targets, spread smoothly over a few frames
    # (a max filter and a Hann window cover every frame's need), and re-solve.
    from scipy.ndimage import maximum_filter1d

    n_lift = max(1, round(params.lift_ramp * motion.fps))
    for _ in range(3):
        need = np.maximum(floor_low - ground.feet(kinematics.forward(compiled, out)), 0.0)
        if need.max() <= 1e-4:
            break
        need = need + 1e-4 * (need > 0)
        spread = np.pad(maximum_filter1d(need, size=2 * n_lift + 1, axis=0, mode="nearest"), ((n_lift, n_lift), (0, 0)), mode="edge")
        lift = _hann_smooth_max(spread, n_lift)[n_lift:-n_lift]
        targets[:, :, 2] += lift
        lifts += lift
        support |= lift > 1e-9
        out, unreached = _solve_legs(compiled, moved, pose2, pose, legs, targets, foot_rot, support, shift)
    # A knee bent lower (a pinned foot under a crouch) may go below the floor: raise the root there
    # (smoothed like the reach shift) and solve the legs again, the feet staying on their targets.
    low_src = np.minimum(ground.body(compiled, pose), 0.0)
    for _ in range(3):
        deficit = np.maximum(low_src - ground.body(compiled, kinematics.forward(compiled, out)), 0.0)
        if deficit.max() <= 5e-4:
            break
        up = _hann_smooth_max((deficit + 5e-4 * (deficit > 0))[:, None], n_root)[:, 0]
        hit = deficit > 0
        up *= min(float(np.max((deficit[hit] + 5e-4) / np.maximum(up[hit], 1e-12))), 3.0)
        shift[:, 2] += up
        moved = motion.replace(root_positions=motion.root_positions + shift)
        pose2 = kinematics.forward(compiled, moved)
        out, unreached = _solve_legs(compiled, moved, pose2, pose, legs, targets, foot_rot, support, shift)
    return out, shift, unreached, lifts, raised


def _solve_legs(
    compiled: mjcf.CompiledModel,
    moved: Motion,
    pose2: kinematics.Pose,
    pose: kinematics.Pose,
    legs: list[tuple[int, int, int]],
    targets: np.ndarray,
    foot_rot: np.ndarray,
    support: np.ndarray,
    shift: np.ndarray,
) -> tuple[Motion, int]:
    """Two-bone IK of every leg onto ``targets (T, F, 3)`` with feet at ``foot_rot (T, F, 4)``."""
    skel = moved.skeleton
    rots = moved.rotations.copy()
    wr = pose2.joint_rotations
    jp = pose2.joint_positions
    unreached = 0
    for f, (h, k, a) in enumerate(legs):
        act = support[:, f] | (np.linalg.norm(shift, axis=1) > 0)
        if not act.any():
            continue
        hinge = knee_hinge_axis(pose, h, k, a)
        top, mid, end = jp[act, h], jp[act, k], jp[act, a]
        if hinge is None:
            axis = analytic.bend_axes(top, mid, end, fallback=np.cross(mid - top, targets[act, f] - top))
        else:
            axis = _knee_axes(top, mid, end, rot.rotate(wr[act, h], np.broadcast_to(hinge, (int(act.sum()), 3))))
        r_hip, r_knee, short = analytic.two_bone(top, mid, end, targets[act, f], axis)
        ok = short <= 1e-9
        unreached += int((~ok).sum())
        w_hip = rot.multiply(r_hip, wr[act, h])
        w_knee = rot.multiply(r_hip, rot.multiply(r_knee, wr[act, k]))
        w_parent = wr[act, int(skel.parents[h])]
        for j, q in (
            (h, rot.multiply(rot.conjugate(w_parent), w_hip)),
            (k, rot.multiply(rot.conjugate(w_hip), w_knee)),
            (a, rot.multiply(rot.conjugate(w_knee), foot_rot[act, f])),
        ):
            q = rot.normalize(q)
            # Keep each quaternion in the captured one's hemisphere (same rotation, continuous signs).
            rots[act, j] = q * np.where(np.sum(q * moved.rotations[act, j], axis=-1) < 0, -1.0, 1.0)[:, None]
    return moved.replace(rotations=rots), unreached
