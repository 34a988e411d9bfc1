"""A delivered ball: released, bouncing on the floor in MuJoCo, met by the bat (seed 003 §2.3.2).

The seed's launch simulation takes "a small amount of the initial ball trajectory (as it bounces
up from the floor)". Here a ball is released from a point with a velocity, flies under gravity
and bounces on a floor plane whose contact is set for a coefficient of restitution (no friction:
the ball keeps its pace along the pitch and gets no spin, as in the seed's simulation); its
state where its path passes a hit point is the incoming ball of
:func:`mjmotion.physics.simulate_launch` (``ball_velocity``).

- :class:`Delivery` — release point, velocity and the ball; :func:`fly` — its :class:`Flight`.
- :func:`Flight.nearest` — the state where the path passes nearest a point (the seed's §2.5.1
  target: "the point on the ball's path which is closest to the FK hit point").
- :data:`PRESETS` and :func:`aimed` — a delivery of a named pace from the bowler's end that
  pitches and then passes through a hit point.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import MjmotionError

GRAVITY = 9.81
#: Cricket ball (radius m, mass kg) and a pitch's coefficient of restitution.
CRICKET_BALL = (0.036, 0.16)
PITCH_RESTITUTION = 0.5

#: Named deliveries: release speed (m/s), release height (m) and distance from the hit point (m,
#: along the pitch); the release angle is found so the ball passes through the hit point.
PRESETS: dict[str, dict[str, float]] = {
    "fast": dict(speed=38.0, height=2.2, distance=18.5),
    "medium": dict(speed=30.0, height=2.1, distance=18.0),
    "slow": dict(speed=22.0, height=2.0, distance=17.5),
}


@dataclass(frozen=True)
class Delivery:
    """A ball released at ``release`` (m, world) with ``velocity`` (m/s).

    Attributes:
        radius, mass: the ball (cricket: 0.036 m, 0.16 kg).
        restitution: of the bounce (vertical speed out / in).
        floor: height (m) of the floor it bounces on.
    """

    release: tuple[float, float, float]
    velocity: tuple[float, float, float]
    radius: float = CRICKET_BALL[0]
    mass: float = CRICKET_BALL[1]
    restitution: float = PITCH_RESTITUTION
    floor: float = 0.0

    def __post_init__(self) -> None:
        for name, v in (("release point", self.release), ("release velocity", self.velocity)):
            a = np.asarray(v, dtype=float)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise MjmotionError(f"the ball's {name} must be three finite numbers, got {v}")
        if not (self.radius > 0 and self.mass > 0 and 0 < self.restitution <= 1):
            raise MjmotionError(f"a delivered ball needs a positive radius and mass and a restitution in (0, 1], got {self}")
        if self.release[2] - self.floor < self.radius:
            raise MjmotionError(f"the ball is released {self.release[2] - self.floor:.3f} m above the floor, below its radius {self.radius} m")


@dataclass(frozen=True, eq=False)
class Flight:
    """A delivery's path, sampled every ``dt`` seconds from its release.

    Attributes:
        times: ``(N,)`` seconds; positions, velocities: ``(N, 3)`` the ball's centre.
        bounce: ``(3,)`` where the ball first touched the floor (its centre then), or ``None``.
        bounce_time: seconds, or ``None``.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    bounce: np.ndarray | None
    bounce_time: float | None

    def nearest(self, point: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, float]:
        """``(time, position (3,), velocity (3,), distance)``: where the path passes nearest ``point``
        (between samples, on the straight segment joining them)."""
        p = np.asarray(point, dtype=float)
        a, b = self.positions[:-1], self.positions[1:]
        ab = b - a
        s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0.0, 1.0)
        near = a + s[:, None] * ab
        i = int(np.argmin(np.linalg.norm(near - p, axis=1)))
        w = s[i]
        vel = (1 - w) * self.velocities[i] + w * self.velocities[i + 1]
        t = (1 - w) * self.times[i] + w * self.times[i + 1]
        return float(t), near[i], vel, float(np.linalg.norm(near[i] - p))


def fly(delivery: Delivery, duration: float = 2.0, dt: float = 5e-4, sample: int = 2) -> Flight:
    """Simulate ``delivery`` for ``duration`` seconds in MuJoCo (time step ``dt``, one sample every
    ``sample`` steps): a free sphere, gravity, and a floor plane whose contact damping gives the
    delivery's restitution (``physics.damping_ratio``), frictionless (``condim`` 1)."""
    import mujoco

    from .physics import damping_ratio

    spec = mujoco.MjSpec()
    spec.option.timestep = dt
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4  # exact in free flight (constant acceleration)
    # a contact a few milliseconds long, damped for the restitution
    solref = [max(8 * dt, 2e-3), damping_ratio(delivery.restitution)]
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, delivery.floor], condim=1, solref=solref)
    body = spec.worldbody.add_body(name="ball", pos=list(delivery.release))
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[delivery.radius, 0, 0], mass=delivery.mass, condim=1, solref=solref)
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qvel[:3] = delivery.velocity
    steps = int(np.ceil(duration / dt))
    n = steps // sample + 1
    times, pos, vel = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    bounce, bounce_t = None, None
    k = 0
    for i in range(steps + 1):
        if i % sample == 0 and k < n:
            times[k], pos[k], vel[k] = d.time, d.qpos[:3], d.qvel[:3]
            k += 1
        if bounce is None and d.ncon:
            bounce, bounce_t = d.qpos[:3].copy(), float(d.time)
        if i < steps:
            mujoco.mj_step(m, d)
    return Flight(times[:k], pos[:k], vel[:k], bounce, bounce_t)


def aimed(
    point: np.ndarray,
    bowler: np.ndarray | Sequence[float] = (0.0, 1.0),
    preset: str = "medium",
    floor: float = 0.0,
    restitution: float = PITCH_RESTITUTION,
) -> Delivery:
    """A delivery of ``preset``'s pace toward ``point`` (3,) from the ``bowler`` side (a horizontal
    direction (2,) from the point to the bowler): released ``distance`` m away at ``height`` m and
    ``speed`` m/s, pitching on the floor and passing through the point.

    The release angle is the root (``scipy.optimize.brentq``, bracketed by a scan from 25° down to
    10° up) of the height at which the simulated ball (:func:`fly`) crosses the point, after its
    bounce, minus the point's height. No angle gets there (a point too high or too low for that
    pace after a bounce): an error saying the range that can be reached.
    """
    from scipy.optimize import brentq

    if preset not in PRESETS:
        raise MjmotionError(f"unknown delivery {preset!r}; expected one of {', '.join(PRESETS)}")
    c = PRESETS[preset]
    p = np.asarray(point, dtype=float)
    u = np.asarray(bowler, dtype=float)[:2]
    if not np.linalg.norm(u) > 0:
        raise MjmotionError(f"the bowler's direction must be a non-zero horizontal vector, got {bowler}")
    u = np.array([u[0], u[1], 0.0]) / np.linalg.norm(u)
    release = p + c["distance"] * u
    release[2] = floor + c["height"]
    duration = 1.5 * c["distance"] / c["speed"] + 0.5
    ahead = -u

    def velocity(angle: float) -> np.ndarray:
        return c["speed"] * (np.cos(angle) * ahead + np.sin(angle) * np.array([0.0, 0.0, 1.0]))

    def miss(angle: float) -> float:
        f = fly(Delivery(tuple(release), tuple(velocity(angle)), restitution=restitution, floor=floor), duration=duration, sample=1)
        along = (f.positions - release) @ ahead
        if f.bounce is None or (f.bounce - release) @ ahead >= c["distance"]:
            return np.nan  # on the full: it does not pitch before the point
        after = np.flatnonzero((along >= c["distance"]) & (f.times > f.bounce_time))
        if not after.size:
            return np.nan
        i = int(after[0])
        w = (c["distance"] - along[i - 1]) / max(along[i] - along[i - 1], 1e-12)
        return float((1 - w) * f.positions[i - 1, 2] + w * f.positions[i, 2] - p[2])

    angles = list(np.radians(np.linspace(-25.0, 10.0, 15)))
    values = [miss(a) for a in angles]
    # where the ball stops pitching before the point (flatter releases reach it on the full), the
    # lowest bounce-then-arrive heights are at the edge: find the edge so the root is bracketed
    for i in range(len(angles) - 1):
        if np.isfinite(values[i]) and not np.isfinite(values[i + 1]):
            lo, hi = angles[i], angles[i + 1]
            for _ in range(20):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if np.isfinite(miss(mid)) else (lo, mid)
            angles.insert(i + 1, lo)
            values.insert(i + 1, miss(lo))
            break
    for a0, a1, m0, m1 in zip(angles[:-1], angles[1:], values[:-1], values[1:]):
        if np.isfinite(m0) and np.isfinite(m1) and m0 * m1 <= 0:
            angle = brentq(miss, a0, a1, xtol=1e-9)
            v = velocity(angle)
            return Delivery(_xyz(release), _xyz(v), restitution=restitution, floor=floor)
    found = np.array(values)
    ok = found[np.isfinite(found)] + p[2]
    span = f"{ok.min():.2f}–{ok.max():.2f} m" if ok.size else "nowhere"
    raise MjmotionError(
        f"no {preset} delivery ({c['speed']:g} m/s from {c['height']:g} m) reaches the hit point at {p[2]:.2f} m after pitching; it can reach {span}"
    )


def _xyz(v: np.ndarray) -> tuple[float, float, float]:
    """A (3,) array as a tuple of three floats."""
    return float(v[0]), float(v[1]), float(v[2])
