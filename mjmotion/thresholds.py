"""The judge's thresholds (``docs/METRICS.md`` defaults) and :class:`Params`, the record of the
values a report used.

Shared by :mod:`mjmotion.feet`, :mod:`mjmotion.floor`, :mod:`mjmotion.physics` and
:mod:`mjmotion.evaluate`; it imports nothing of theirs, so none of them imports another to get it.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from .errors import MjmotionError, require_number

#: The judge's revision: raised whenever a report value changes for the same clip and options (a
#: new definition, or a bound that decides frames differently), so ``audit --resume`` never keeps a
#: row an older judge computed beside rows of this one. 2: the ground-reaction segment bound (0.1.0).
#: 3: the bundled humanoid stands on the soles it was made with (its clips' floor 23 mm higher); a
#: foot whose quiet frames hold two stances is calibrated on the one it holds most (golf 64_0x's lead foot).
#: 4: angular accelerations in true rad/s² (the rows' params read accel_floor 30, was 60; no pop frame moves);
#: the rows' standing_axis column (the file axis the body stands along).
#: 5: max_joint_speed_ratio's source peak at least speed_floor (a still source read noise over noise); a
#: --source shorter than one period of the low-pass is an error row.
JUDGE_REVISION = 5
H_C = 0.05  #: contact height, m
V_C = 0.5  #: contact horizontal speed, m/s (GMD: 2.5 cm/frame at 20 fps)
#: Contact hysteresis: a foot enters contact below (1 - HYSTERESIS) × (h_c, v_c) and leaves it
#: above h_c or v_c, so a label does not flicker on a foot hovering at a threshold.
HYSTERESIS = 0.2
SKATE_WINDOW = 5  #: frames, GMD's averaging window for skating_ratio
FLOAT_TOL = 0.005  #: m, PhysDiff's float tolerance
H_C_SENSITIVITY = (0.03, 0.05, 0.08)
#: Low-pass cutoff (Hz) of the zero-lag 2nd-order Butterworth filter applied to positions before
#: they are differentiated (foot speeds, inverse dynamics): Winter's cutoff for walking marker data.
CUTOFF_HZ = 6.0
#: The shortest clip the judge takes, as the result or a source: speeds and accelerations are differences between frames.
MIN_FRAMES = 3
#: Foot speeds: the slope of a local quadratic fitted over this many seconds (Savitzky–Golay).
SPEED_WINDOW = 0.1
MU = 1.0  #: friction coefficient of the ground-reaction feasibility test
#: A frame fails the physics check when the ground cannot supply the wrench the motion needs to
#: within this fraction of body weight (see :func:`mjmotion.physics.residuals`).
RESIDUAL_TOL = 0.12
#: An airborne stretch fails when its centre of mass's fitted acceleration is further than this
#: from free fall (fraction of g; :func:`mjmotion.physics.ballistic_residual`): the centre of mass
#: comes from segment-mass fractions, which in a running flight's limb swing err by 0.1-0.5 g.
FLIGHT_TOL = 0.35
#: Sole points this close to the floor (m) can push on it, whatever the contact label says.
SUPPORT_HEIGHT = 0.025
#: A frame also fails when the body is deeper than this below the floor (m): no ground reaction
#: holds a foot inside the floor. Captured clips dip 2-3 cm below their stance floor at times
#: (one foot lower than the other, toes flexed into the floor).
PENETRATION_TOL = 0.04
#: Pops: a frame pops when a joint's angular acceleration exceeds POP_FACTOR × the joint's robust
#: peak (PEAK_PERCENTILE-th percentile over frames) in the reference clip(s).
POP_FACTOR = 4.0
PEAK_PERCENTILE = 99.0
#: Smallest reference peaks (worst_joint_speed_ratio, pops): a joint that barely moves in its
#: source (a finger held still) would otherwise turn any motion into a huge ratio.
SPEED_FLOOR = 1.0  #: rad/s
#: rad/s². Until 2026-12 the judge's angular accelerations read twice their value and this was 60:
#: the same floor, and the same pop frames.
ACCEL_FLOOR = 30.0


@dataclass(frozen=True)
class Params:
    """The thresholds a report used (``docs/METRICS.md`` defaults).

    Attributes:
        h_c, v_c: contact height (m) and horizontal speed (m/s).
        hysteresis: contact is entered below ``(1 - hysteresis)`` of both and left above them.
        skate_window: GMD's window for ``skating_ratio`` (frames).
        float_tol: PhysDiff's float tolerance (m).
        mu: friction coefficient of the ground-reaction test.
        cutoff_hz: low-pass cutoff before differentiating positions for inverse dynamics (Hz).
        speed_window: window of the local quadratic foot speeds are the slope of (s).
        residual_tol: ground-reaction residual (fraction of m·g) above which a frame fails.
        flight_tol: an airborne stretch's distance from free fall (fraction of g) above which it fails.
        support_height: sole points below this height (m) can push on the floor.
        penetration_tol: depth below the floor (m) beyond which a frame fails.
        pop_factor, peak_percentile: pops (see module constants).
        speed_floor, accel_floor: smallest reference peaks (rad/s, rad/s²).
        h_c_sensitivity: contact heights of the sensitivity table.
    """

    h_c: float = H_C
    v_c: float = V_C
    hysteresis: float = HYSTERESIS
    skate_window: int = SKATE_WINDOW
    float_tol: float = FLOAT_TOL
    mu: float = MU
    cutoff_hz: float = CUTOFF_HZ
    speed_window: float = SPEED_WINDOW
    residual_tol: float = RESIDUAL_TOL
    flight_tol: float = FLIGHT_TOL
    support_height: float = SUPPORT_HEIGHT
    penetration_tol: float = PENETRATION_TOL
    pop_factor: float = POP_FACTOR
    peak_percentile: float = PEAK_PERCENTILE
    speed_floor: float = SPEED_FLOOR
    accel_floor: float = ACCEL_FLOOR
    h_c_sensitivity: tuple[float, ...] = H_C_SENSITIVITY

    def __post_init__(self) -> None:
        positive = ("h_c", "v_c", "float_tol", "mu", "cutoff_hz", "speed_window", "residual_tol", "flight_tol", "pop_factor", "peak_percentile")
        for name in (*positive, "support_height", "penetration_tol", "speed_floor", "accel_floor"):
            require_number(f"Params.{name} =", getattr(self, name), strict=name in positive)
        require_number("Params.hysteresis =", self.hysteresis, 0.0, False, 1.0)
        if self.hysteresis >= 1.0:
            raise MjmotionError(f"Params.hysteresis = {self.hysteresis!r}: expected a fraction in [0, 1)")
        if self.peak_percentile > 100.0:
            raise MjmotionError(f"Params.peak_percentile = {self.peak_percentile!r}: expected a percentile in (0, 100]")
        if isinstance(self.skate_window, bool) or not isinstance(self.skate_window, numbers.Integral) or self.skate_window < 1:
            raise MjmotionError(f"Params.skate_window = {self.skate_window!r}: expected a whole number of frames ≥ 1")
        if not all(isinstance(h, numbers.Real) and math.isfinite(h) and h > 0 for h in self.h_c_sensitivity):
            raise MjmotionError(f"Params.h_c_sensitivity = {self.h_c_sensitivity!r}: expected finite contact heights > 0")


#: The defaults, one shared instance (a frozen value).
DEFAULTS = Params()

#: The highest frame rate the judge takes: its low-pass and speed windows are fixed durations, so their
#: frames (and the memory of the arrays built over them) grow with the rate; capture runs at 30-480 fps.
MAX_JUDGED_FPS = 1000.0
