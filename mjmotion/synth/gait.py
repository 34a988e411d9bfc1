"""Locomotion from a footstep plan: walk, run (with flight), sneak and limp, straight or turning.

The plan comes first: a path (constant speed, constant turning rate, starting at the origin
heading +X), a gait cycle per foot (touch-down time, stance duration) and one footprint per
stance, placed on the path where the body is at mid-stance. Everything else follows from it:
a planted foot's ball (toe joint) stays exactly on its footprint while the heel rolls up, a
swinging foot travels between footprints on a minimum-jerk curve, the pelvis follows the path
with bob, sway, rotation and list, and the legs reach their feet by analytic two-bone IK
(the pelvis is lowered wherever a straight leg would not reach). Last, the pelvis sways within
each stride so that the ground can carry the motion (:mod:`mjmotion.synth.balance`: the centre of
pressure it needs lies under the standing feet) and the legs reach their feet again.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import rotations as rot
from ..errors import MjmotionError
from ..humanoid import SHIN, THIGH
from ..skeleton import Motion
from . import balance
from .body import (
    PoseBuilder,
    axis_angle,
    compose,
    foot_geometry,
    joint,
    lower_pelvis,
    min_jerk,
    reach_need,
    skeleton,
    yaw,
)

FPS = 60.0
SIDES = ("Left", "Right")


@dataclass(frozen=True)
class Footprint:
    """One planned stance: the ball of the foot (toe joint) rests at ``position`` from frame
    ``start`` to ``end`` inclusive, the foot heading ``heading`` radians (0 = +X).

    ``position``: ``(x, y, z)`` world metres of the toe joint (``z`` its height over a flat sole).
    ``flat_end``: last frame of the flat-foot part (after it the heel rolls up about the toe);
    ``start - 1`` when the heel is already up at ``start``.
    Frames are clipped to the clip: a stance that began before frame 0 starts at 0.
    """

    side: str
    start: int
    end: int
    flat_end: int
    position: tuple[float, float, float]
    heading: float


@dataclass(frozen=True)
class GaitStyle:
    """Parameters of one gait (times in seconds, lengths in metres, angles in radians)."""

    name: str
    speed: float
    step_length: float  # at ``speed``; scales with sqrt(speed / this speed)
    speed_range: tuple[float, float]
    duty: tuple[float, float]  # stance fraction of the cycle, left and right
    right_offset: float = 0.5  # right touch-down, as a fraction of the cycle after the left one
    heel_off: float = 0.55  # fraction of stance after which the heel rolls up
    roll: float = np.radians(30.0)  # heel-rise angle at toe-off
    clearance: tuple[float, float] = (0.09, 0.09)  # swing height of the toe joint, per foot
    push_off: float = 0.0  # run: the toe leaves the floor already rising (fraction of a sine lift)
    step_width: float = 0.10  # half the lateral distance between the feet's centres
    toe_out: float = np.radians(6.0)
    extension: float = 0.97  # desired hip–ankle distance at mid-stance / leg length
    bob: float = 0.018  # pelvis vertical amplitude
    bob_sign: float = 1.0  # +1 highest at mid-stance (walk), -1 lowest (run)
    sway: float = 0.025
    pelvis_yaw: float = np.radians(5.0)
    pelvis_list: float = np.radians(4.0)
    lean: float = np.radians(3.0)
    arm_swing: tuple[float, float] = (np.radians(22.0), np.radians(22.0))
    elbow: float = np.radians(18.0)
    elbow_swing: float = np.radians(15.0)
    limp_drop: float = 0.0  # extra pelvis drop over the right stance
    limp_lean: float = 0.0  # trunk lean toward the right over the right stance


STYLES: dict[str, GaitStyle] = {
    "walk": GaitStyle("walk", 1.3, 0.70, (0.3, 2.2), (0.62, 0.62)),
    "run": GaitStyle(
        "run",
        3.2,
        1.15,
        (1.8, 6.0),
        (0.33, 0.33),
        heel_off=0.35,
        roll=np.radians(25.0),
        push_off=1.0,
        clearance=(0.22, 0.22),
        step_width=0.06,
        extension=0.93,
        bob=0.03,
        bob_sign=-1.0,
        sway=0.01,
        pelvis_yaw=np.radians(7.0),
        pelvis_list=np.radians(3.0),
        lean=np.radians(9.0),
        arm_swing=(np.radians(32.0), np.radians(32.0)),
        elbow=np.radians(85.0),
        elbow_swing=np.radians(15.0),
    ),
    "sneak": GaitStyle(
        "sneak",
        0.6,
        0.45,
        (0.2, 1.2),
        (0.72, 0.72),
        heel_off=0.6,
        roll=np.radians(20.0),
        clearance=(0.07, 0.07),
        step_width=0.12,
        extension=0.80,
        bob=0.01,
        sway=0.03,
        pelvis_yaw=np.radians(4.0),
        pelvis_list=np.radians(2.0),
        lean=np.radians(22.0),
        arm_swing=(np.radians(10.0), np.radians(10.0)),
        elbow=np.radians(60.0),
        elbow_swing=np.radians(5.0),
    ),
    "limp": GaitStyle(
        "limp",
        0.9,
        0.55,
        (0.3, 1.5),
        (0.72, 0.50),
        right_offset=0.55,
        heel_off=0.6,
        clearance=(0.10, 0.06),
        extension=0.96,
        bob=0.012,
        sway=0.035,
        arm_swing=(np.radians(20.0), np.radians(12.0)),
        limp_drop=0.035,
        limp_lean=np.radians(7.0),
    ),
}


@dataclass(frozen=True)
class Gait:
    """A generated locomotion clip and its plan (see :class:`Footprint`)."""

    motion: Motion
    contacts: np.ndarray  # (T, 2) bool, left and right
    footprints: tuple[Footprint, ...]
    style: GaitStyle


def check_seed(seed: int) -> int:
    """``seed`` as a non-negative int, or a clear error."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise MjmotionError(f"--seed {seed!r}: expected a whole number ≥ 0")
    return int(seed)


def _path(t: np.ndarray, speed: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """Path points ``(N, 2)`` and headings ``(N,)`` at times ``t``: constant speed and turning rate
    from the origin heading +X (negative times extend it backwards)."""
    heading = omega * t
    if abs(omega) < 1e-9:
        xy = np.stack([speed * t, np.zeros_like(t)], axis=-1)
    else:
        r = speed / omega
        xy = np.stack([r * np.sin(heading), r * (1.0 - np.cos(heading))], axis=-1)
    return xy, heading


def _dir(heading: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)], axis=-1)


def _normal(heading: np.ndarray) -> np.ndarray:
    return np.stack([-np.sin(heading), np.cos(heading), np.zeros_like(heading)], axis=-1)


def generate(
    style_name: str,
    speed: float | None = None,
    seconds: float = 4.0,
    turn_deg_per_s: float = 0.0,
    seed: int = 0,
    step_length: float | None = None,
    fps: float = FPS,
) -> Gait:
    """Generate a locomotion clip of the named gait (``walk``, ``run``, ``sneak``, ``limp``).

    Args:
        speed: m/s along the path (default: the style's).
        seconds: clip duration.
        turn_deg_per_s: turning rate, positive to the left.
        seed: small deterministic variations of width, swing and bob (0 = the nominal gait).
        step_length: metres per step (default: the style's, scaled with sqrt(speed)).
    """
    if style_name not in STYLES:
        raise MjmotionError(f"unknown gait {style_name!r}; expected one of {', '.join(STYLES)}")
    base = STYLES[style_name]
    v = base.speed if speed is None else float(speed)
    lo, hi = base.speed_range
    if not (lo <= v <= hi):
        raise MjmotionError(f"--speed {v:g}: a {style_name} needs a speed between {lo:g} and {hi:g} m/s")
    if not (0.5 <= seconds <= 120.0):
        raise MjmotionError(f"--seconds {seconds:g}: expected a duration between 0.5 and 120 s")
    omega = np.radians(float(turn_deg_per_s))
    if abs(turn_deg_per_s) > 90.0 or (abs(omega) > 1e-9 and v / abs(omega) < 1.0):
        raise MjmotionError(f"--turn {turn_deg_per_s:g}: expected at most 90 deg/s and a turning radius (speed/rate) of at least 1 m")
    step = base.step_length * np.sqrt(v / base.speed) if step_length is None else float(step_length)
    if not (0.15 <= step <= 2.5):  # (NaN fails too)
        raise MjmotionError(f"step length {step:g} m: expected 0.15–2.5 m")
    rng = np.random.default_rng(check_seed(seed))
    jitter = (lambda: 1.0) if seed == 0 else (lambda: float(1.0 + rng.uniform(-0.12, 0.12)))
    style = replace(
        base,
        speed=v,
        step_length=step,
        step_width=base.step_width * jitter(),
        bob=base.bob * jitter(),
        sway=base.sway * jitter(),
        arm_swing=(base.arm_swing[0] * jitter(), base.arm_swing[1] * jitter()),
        pelvis_yaw=base.pelvis_yaw * jitter(),
    )
    return _build(style, step, float(seconds), omega, fps)


def _build(style: GaitStyle, step: float, seconds: float, omega: float, fps: float) -> Gait:
    fg = foot_geometry()
    n = round(seconds * fps) + 1
    t = np.arange(n) / fps
    period = 2.0 * step / style.speed
    # Touch-down times per foot (a few cycles before and after the clip so every frame is covered).
    cycles = np.arange(-3, int(np.ceil(seconds / period)) + 3)
    offsets = (0.0, style.right_offset)
    xy, heading = _path(t, style.speed, omega)
    normal = _normal(heading)

    # Gait phases, radians, with 0 at each foot's touch-down.
    phase = {s: 2 * np.pi * (t / period - offsets[i]) for i, s in enumerate(SIDES)}
    mid_l = phase["Left"] - np.pi * style.duty[0]  # 0 at left mid-stance

    # Pelvis: path + sway toward the stance foot + bob; yaw, list, forward lean.
    root = np.zeros((n, 3))
    root[:, :2] = xy + (style.sway * np.cos(mid_l))[:, None] * normal[:, :2]
    leg = THIGH + SHIN
    hip_drop = 0.06  # Hips joint above the hip joints (the skeleton's UpLeg offset)
    base = fg.ankle_height + style.extension * leg + hip_drop  # the desired pelvis height; bob and reach below
    flight = period / 2 - style.duty[0] * period
    ballistic = style.bob_sign < 0 and flight > 0 and style.duty[0] == style.duty[1] and style.right_offset == 0.5
    right_stance = _stance_bump(t, period, offsets[1], style.duty[1])
    p_yaw = -style.pelvis_yaw * np.cos(phase["Left"])
    p_list = style.pelvis_list * np.cos(mid_l)
    # Into a turn the body leans (banks) so that gravity and the push of the feet give the
    # centripetal force: tan(bank) = v·ω/g; the spine keeps it (it undoes only the pelvis's list).
    bank = -np.arctan(style.speed * omega / 9.81)
    hips = compose(yaw(heading + p_yaw), axis_angle("x", p_list + bank), axis_angle("y", style.lean * 0.5))

    # Feet from the plan.
    feet: dict[str, dict[str, np.ndarray]] = {}
    footprints: list[Footprint] = []
    contacts = np.zeros((n, 2), dtype=bool)
    for i, side in enumerate(SIDES):
        sgn = 1.0 if side == "Left" else -1.0
        td = (cycles + offsets[i]) * period
        lo_t = td + style.duty[i] * period
        mid = 0.5 * (td + lo_t)
        pxy, ph = _path(mid, style.speed, omega)
        toe_xy = pxy + (0.10 * _dir(ph) + sgn * style.step_width * _normal(ph))[:, :2]
        heads = ph + sgn * style.toe_out
        feet[side] = _foot_track(t, td, lo_t, toe_xy, heads, style, i, fg.toe_height)
        for k in range(len(td)):
            a = int(np.ceil(td[k] * fps - 1e-9))
            b = int(np.floor(lo_t[k] * fps + 1e-9))
            if b < 0 or a > n - 1 or b < a:
                continue
            a_c, b_c = max(a, 0), min(b, n - 1)
            contacts[a_c : b_c + 1, i] = True
            heel = td[k] + style.heel_off * (lo_t[k] - td[k])
            footprints.append(
                Footprint(
                    side=side.lower(),
                    start=a_c,
                    end=b_c,
                    flat_end=int(np.clip(np.floor(heel * fps + 1e-9), a_c - 1, b_c)),  # start-1: rolling already
                    position=(float(toe_xy[k, 0]), float(toe_xy[k, 1]), float(fg.toe_height)),
                    heading=float(heads[k]),
                )
            )
    footprints.sort(key=lambda f: (f.start, f.side))

    pb = PoseBuilder(n, root)
    pb.set_local("Hips", hips)
    _torso(pb, style, heading, p_yaw, p_list, right_stance)
    _arms(pb, style, phase)
    ankles = {side: feet[side]["ankle"] for side in SIDES}
    pelvis_fwd = _dir(heading + p_yaw)
    _fit_pelvis_height(pb, style, ankles, base, mid_l, right_stance, ballistic, fps)

    def place_legs() -> None:
        for i, side in enumerate(SIDES):
            f = feet[side]
            reached = pb.leg(side, f["ankle"], f["foot"], f["toe"], _dir(f["heading"]) + pelvis_fwd, contacts[:, i])
            miss = np.linalg.norm(reached - f["ankle"], axis=1)[contacts[:, i]]
            if miss.size and miss.max() > 1e-6:
                raise MjmotionError(
                    f"a {style.name} with {step:.2f} m steps at {style.speed:g} m/s cannot keep its feet planted "
                    "(the legs are too short for it); choose a shorter step length"
                )

    place_legs()
    # Sway the pelvis within each stride until the ground can carry the motion, then reach the feet again.
    balance.rebalance(pb, ankles, place_legs, fps, stride=round(period * fps))
    motion = pb.motion(fps, style.name)
    return Gait(motion=motion, contacts=contacts, footprints=tuple(footprints), style=style)


def _fit_pelvis_height(
    pb: PoseBuilder,
    style: GaitStyle,
    ankles: dict[str, np.ndarray],
    base: float,
    mid_l: np.ndarray,
    right_stance: np.ndarray,
    ballistic: bool,
    fps: float,
) -> None:
    """Set the root height so every leg reaches its ankle goal.

    Walks keep a pure bob (smooth, vaulting over the stance leg): the amplitude is chosen so
    the reachable pelvis is high without a large vertical acceleration. A run's flight stays
    ballistic: its whole curve is lowered by one constant.
    """
    if ballistic:
        t = np.arange(pb.t) / fps
        period = 2 * style.step_length / style.speed
        pb.root[:, 2] = base + _ballistic_bob(t, period / 2, style.duty[0] * period)
        lower_pelvis(pb, ankles, fps, constant=True)
        return
    pb.root[:, 2] = 0.0
    ceiling = -reach_need(pb, ankles)
    shape = style.bob_sign * np.cos(2 * mid_l)
    other = -style.limp_drop * right_stance
    amps = np.linspace(style.bob, 1.5 * style.bob, 11)
    bases = np.minimum(np.min(ceiling[None] - amps[:, None] * shape[None] - other[None], axis=1), base)
    k = int(np.argmax(bases - 0.25 * amps))
    pb.root[:, 2] = bases[k] + amps[k] * shape + other
    pb.update()


def _ballistic_bob(t: np.ndarray, step_time: float, stance: float, g: float = 9.81) -> np.ndarray:
    """``(N,)`` pelvis height offsets of a run: a free fall (−g) in each flight and a sine dip in
    each stance that meets the flight with the same speed (C¹), starting at a touch-down at t = 0."""
    tau = np.mod(t, step_time)
    fly = step_time - stance
    v0 = g * fly / 2  # vertical speed at lift-off and touch-down
    dip = v0 * stance / np.pi
    in_flight = tau >= stance
    tf = tau - stance
    return np.where(in_flight, v0 * tf - 0.5 * g * tf**2, -dip * np.sin(np.pi * np.clip(tau / stance, 0.0, 1.0)))


def _stance_bump(t: np.ndarray, period: float, offset: float, duty: float) -> np.ndarray:
    """``(N,)`` sin² bump over each stance of the foot touching down at ``offset`` of the cycle."""
    s = np.mod(t / period - offset, 1.0) / duty
    return np.where(s < 1.0, np.sin(np.pi * np.clip(s, 0, 1)) ** 2, 0.0)


def _foot_track(
    t: np.ndarray,
    td: np.ndarray,
    lo_t: np.ndarray,
    toe_xy: np.ndarray,
    heads: np.ndarray,
    style: GaitStyle,
    i: int,
    toe_height: float,
) -> dict[str, np.ndarray]:
    """Ankle positions, foot and toe world rotations of one foot over the frames ``t``.

    Stance: the toe joint stays on its footprint; flat, then the heel rolls up about it.
    Swing: the toe joint lifts first, travels on a minimum-jerk curve, and sets down flat.
    """
    k = np.searchsorted(td, t, side="right") - 1  # the last touch-down at or before t
    in_stance = t <= lo_t[k]
    heel = td[k] + style.heel_off * (lo_t[k] - td[k])
    roll_s = np.clip((t - heel) / np.maximum(lo_t[k] - heel, 1e-9), 0.0, 1.0)
    # Swing from footprint k (lift-off at lo_t[k]) to footprint k+1 (touch-down at td[k+1]).
    s = np.clip((t - lo_t[k]) / (td[k + 1] - lo_t[k]), 0.0, 1.0)
    travel = min_jerk((s - 0.08) / 0.84)
    # Lift first, travel, set down: a walking toe leaves and lands at rest; a running toe leaves
    # rising (push-off), blending a quarter-sine lift into the minimum-jerk one.
    up = (1.0 - style.push_off) * min_jerk(s / 0.3) + style.push_off * np.sin(0.5 * np.pi * np.clip(s / 0.3, 0.0, 1.0))
    lift = np.where(s < 0.5, up, min_jerk((1.0 - s) / 0.3))
    dpsi = np.angle(np.exp(1j * (heads[k + 1] - heads[k])))
    xy = np.where(in_stance[:, None], toe_xy[k], toe_xy[k] + (toe_xy[k + 1] - toe_xy[k]) * travel[:, None])
    z = toe_height + np.where(in_stance, 0.0, style.clearance[i] * lift)
    psi = np.where(in_stance, heads[k], heads[k] + dpsi * travel)
    pitch = np.where(in_stance, style.roll * roll_s**2, style.roll * (1.0 - min_jerk(s / 0.6)))
    toe_world = yaw(psi)
    foot_world = compose(toe_world, axis_angle("y", pitch))
    toe_pos = np.column_stack([xy, z])
    ankle = toe_pos - rot.rotate(foot_world, skeleton().offsets[joint("LeftToe")])
    return {"ankle": ankle, "foot": foot_world, "toe": toe_world, "heading": psi}


def _torso(pb: PoseBuilder, style: GaitStyle, heading: np.ndarray, p_yaw: np.ndarray, p_list: np.ndarray, right_stance: np.ndarray) -> None:
    """Spine counter-rotates the pelvis and undoes its list; the head looks along the path."""
    lean_r = style.limp_lean * right_stance
    for name in ("Spine", "Spine1", "Spine2"):
        pb.set_local(name, compose(yaw(-0.6 * p_yaw), axis_angle("x", -p_list / 3 - lean_r / 3), axis_angle("y", style.lean / 6)))
    pb.update()
    head_world = compose(yaw(heading), axis_angle("y", np.radians(4.0)))
    neck = pb.wrot("Spine2")
    half = rot.slerp(neck, head_world, 0.5)
    pb.set_local("Neck", rot.multiply(rot.conjugate(neck), half))
    pb.set_local("Head", rot.multiply(rot.conjugate(half), head_world))


def _arms(pb: PoseBuilder, style: GaitStyle, phase: dict[str, np.ndarray]) -> None:
    """Arms hang and swing against the same-side leg (forward when that leg is back)."""
    hang = np.radians(82.0)
    for i, side in enumerate(SIDES):
        sgn = 1.0 if side == "Left" else -1.0
        fwd = -style.arm_swing[i] * np.cos(phase[side])  # back at this foot's touch-down
        pb.set_local(f"{side}Arm", compose(axis_angle("y", -fwd), axis_angle("x", -sgn * hang)))
        bend = style.elbow + style.elbow_swing * np.maximum(fwd, 0.0) / max(style.arm_swing[i], 1e-9)
        pb.set_local(f"{side}ForeArm", axis_angle("z", -sgn * bend))
