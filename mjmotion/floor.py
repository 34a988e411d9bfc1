"""The floor every ground metric, the cleanup and renders measure from (``docs/METRICS.md``).

In order of precedence, the floor is *given* (``--floor METRES``), taken from the *source*
clip(s) a result is judged against (``--source``), or *detected* from the clip's own stance:
the median height of the lower foot's lowest sole point over the frames where that point stands
still (neither sliding nor rising or falling). Flight frames (no foot still) do not move a median; a leading T-pose (one frame or held over many) is skipped by
:mod:`mjmotion.trim` before the floor is sought.
A result lifted or sunk against its source keeps the source's floor, so it reads as floating or
penetrating; detected on its own it would just find its new floor.

A captured floor need not be level: the stance feet of CMU subjects 07 and 08 rise about 2 cm per
metre of walk (1.0-1.3°; the same trial in its daz and iClone conversions alike), so a flat floor
at their median height has one end of the walk in the floor and the other above it. When the
floor is not given, the plane through the stance points (:func:`fit_tilt`, the clip's or its
sources') is made level first (:class:`Level`: a rigid rotation about the stance centre; gravity
is taken to be normal to the floor the subject walked on) and every metric measures the levelled
clip; ``--floor`` means a level floor at that height.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .errors import MjmotionError

#: How the floor was found, in order of precedence.
FLOOR_FROM = ("given", "source", "detected")
#: A detected floor further than this from z = 0 (m) is worth a note to the user.
NOTE_M = 0.01
#: The lower foot "stands still" below this horizontal speed (m/s).
STILL = 0.2


#: A fitted tilt under this (degrees) is within the stance's own scatter: the floor stays as captured.
MIN_TILT_DEG = 0.5
#: A fitted tilt over this (degrees) is not believed: the floor stays as captured. The shared walks that
#: tilt read 0.9-1.4° (subjects 07, 08 and 10); 16_29's 90° turn reads 2.7°, from a path that leans into the turn.
MAX_TILT_DEG = 2.0
#: A slope is fitted only along directions the stance points spread over at least this much (m, standard deviation).
MIN_SPREAD = 0.3
#: Fewest stance points a tilt is fitted to.
MIN_TILT_POINTS = 20


@dataclass(frozen=True)
class Level:
    """The rigid rotation that makes a tilted stance floor level: ``quat`` (wxyz) about ``pivot``
    (m, world); ``tilt_deg`` the floor's tilt it removes, ``rise`` ``(2,)`` the floor's slope
    (metres of height per metre along world x and y) as captured."""

    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    pivot: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tilt_deg: float = 0.0
    rise: tuple[float, float] = (0.0, 0.0)

    @property
    def flat(self) -> bool:
        """True when nothing is rotated."""
        return self.tilt_deg == 0.0

    def positions(self, p: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` levelled."""
        if self.flat:
            return p
        c = np.asarray(self.pivot)
        return c + rot.rotate(np.broadcast_to(np.asarray(self.quat), p.shape[:-1] + (4,)), p - c)

    def rotations(self, q: np.ndarray) -> np.ndarray:
        """World orientations ``(..., 4)`` levelled."""
        if self.flat:
            return q
        return rot.multiply(np.broadcast_to(np.asarray(self.quat), q.shape), q)

    def inverse(self) -> Level:
        """The rotation back to the captured frame."""
        w, x, y, z = self.quat
        return Level((w, -x, -y, -z), self.pivot, self.tilt_deg, self.rise) if not self.flat else self


FLAT = Level()


def fit_tilt(xy: np.ndarray, z: np.ndarray) -> Level:
    """The :class:`Level` of the stance floor through points ``xy: (N, 2)``, ``z: (N,)`` (world m;
    :func:`stance_points`), or :data:`FLAT`.

    The least-squares plane, its slope fitted only along the principal directions in which the
    points spread at least :data:`MIN_SPREAD` (a straight walk fixes the slope along it, not
    across: there the two feet's own height difference would read as tilt); levelled only when
    the tilt lies between :data:`MIN_TILT_DEG` and :data:`MAX_TILT_DEG`, from at least
    :data:`MIN_TILT_POINTS` points. The pivot is the points' centre at their median height.
    """
    xy, z = np.asarray(xy, dtype=float).reshape(-1, 2), np.asarray(z, dtype=float).ravel()
    if len(z) < MIN_TILT_POINTS:
        return FLAT
    centre = xy.mean(axis=0)
    d = xy - centre
    spread, axes = np.linalg.eigh(np.cov(d.T))  # ascending; columns are the principal directions
    use = axes[:, np.sqrt(np.maximum(spread, 0.0)) >= MIN_SPREAD]  # (2, k)
    if use.shape[1] == 0:
        return FLAT
    basis = np.column_stack([np.ones(len(z)), d @ use])
    coef = np.linalg.lstsq(basis, z, rcond=None)[0]
    rise = use @ coef[1:]  # (2,) dz/dx, dz/dy
    tilt = math.degrees(math.atan(float(np.hypot(*rise))))
    if not MIN_TILT_DEG <= tilt <= MAX_TILT_DEG:
        return FLAT
    n = np.array([-rise[0], -rise[1], 1.0]) / math.sqrt(1.0 + float(rise @ rise))
    axis = np.cross(n, [0.0, 0.0, 1.0])
    angle = math.acos(float(np.clip(n[2], -1.0, 1.0)))
    q = np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * axis / np.linalg.norm(axis)])
    pivot = (float(centre[0]), float(centre[1]), float(np.median(z)))
    return Level(tuple(float(v) for v in q), pivot, tilt, (float(rise[0]), float(rise[1])))  # type: ignore[arg-type]


@dataclass(frozen=True)
class Floor:
    """A floor height ``height`` (m, world z, in the levelled frame) and where it came from
    (``from_``: one of :data:`FLOOR_FROM`); ``level``: the levelling of a tilted captured floor
    (:data:`FLAT` when given or level)."""

    height: float
    from_: str
    level: Level = FLAT

    def __post_init__(self) -> None:
        if self.from_ not in FLOOR_FROM:
            raise MjmotionError(f"floor from {self.from_!r}: expected one of {', '.join(FLOOR_FROM)}")
        if not math.isfinite(self.height):
            raise MjmotionError(f"floor height {self.height!r}: expected a finite number of metres")

    def text(self) -> str:
        """``"+0.031 m (detected)"``: the height to the millimetre (one that rounds to 0 as +0.000) and its origin."""
        return f"{(self.height if abs(self.height) >= 5e-4 else 0.0):+.3f} m ({self.from_})"

    def note(self, name: str = "") -> str | None:
        """One line for the user when a detected floor is more than :data:`NOTE_M` from z = 0 or tilted."""
        tilt = ""
        if not self.level.flat:
            rx, ry = self.level.rise
            tilt = (
                f"the stance floor tilts {self.level.tilt_deg:.1f}° (rising {100 * rx:+.1f} cm/m along x, {100 * ry:+.1f} along y) "
                "and is levelled before measuring; "
            )
        if self.from_ != "detected" or (abs(self.height) <= NOTE_M and not tilt):
            return None
        where = "above" if self.height > 0 else "below"
        return (
            f"note: {name + ': ' if name else ''}{tilt}detected floor {self.height:+.3f} m ({100 * abs(self.height):.1f} cm {where} z = 0); "
            "ground metrics measure from it (--floor 0 measures from a level z = 0)"
        )


def detect(z: np.ndarray, speeds: np.ndarray, still: float = STILL) -> float:
    """The stance floor of a clip (m).

    ``z: (T, F)`` world height of each foot's lowest sole point, ``speeds: (T, F)`` its speed
    (m/s; :class:`~mjmotion.feet.FootTrack` passes horizontal and vertical together). Per frame the lower foot; the median of its height over frames where it is
    slower than ``still``, or the 5th percentile of all its heights when fewer than 3 frames
    (or 2 % of the clip) stand still.
    """
    zl, stance = _lower_still(z, speeds, still)
    if stance.sum() >= max(3, 0.02 * len(zl)):
        return float(np.median(zl[stance]))
    return float(np.percentile(zl, 5))


def _lower_still(z: np.ndarray, speeds: np.ndarray, still: float) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the lower foot's height ``(T,)`` and whether it stands still ``(T,)``."""
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or z.shape != np.shape(speeds) or z.shape[0] == 0:
        raise MjmotionError(f"floor.detect: heights {z.shape} and speeds {np.shape(speeds)} must be the same (T, F), T ≥ 1")
    lower = np.argmin(z, axis=1)
    rows = np.arange(z.shape[0])
    return z[rows, lower], np.asarray(speeds)[rows, lower] < still


def stance_points(z: np.ndarray, speeds: np.ndarray, xy: np.ndarray, still: float = STILL) -> tuple[np.ndarray, np.ndarray]:
    """The points :func:`detect` takes its median of: ``xy (N, 2)`` and ``z (N,)`` of the lower
    foot's lowest sole point where it stands still (``z, speeds: (T, F)``, ``xy: (T, F, 2)``)."""
    zl, stance = _lower_still(z, speeds, still)
    lower = np.argmin(np.asarray(z, dtype=float), axis=1)
    pts = np.asarray(xy, dtype=float)[np.arange(len(zl)), lower]
    return pts[stance], zl[stance]


def resolve(given: float | None, source_floors: Sequence[float], detected: float, level: Level = FLAT) -> Floor:
    """The floor to use: ``given`` if not None (level), else the mean of ``source_floors`` (the floors
    detected on the sources), else ``detected`` (the clip's own); ``level`` the levelling the
    detected floors were measured after (from the sources when there are any, else the clip)."""
    if given is not None:
        return Floor(float(given), "given")
    if len(source_floors):
        return Floor(float(np.mean(source_floors)), "source", level)
    return Floor(float(detected), "detected", level)
