"""The floor every ground metric, the cleanup and renders measure from (``docs/METRICS.md``).

In order of precedence, the floor is *given* (``--floor METRES``), taken from the *source*
clip(s) a result is judged against (``--source``), or *detected* from the clip's own stance:
the median height of the lower foot's lowest sole point over the frames where that point stands
still (neither sliding nor rising or falling). Flight frames (no foot still) and a leading T-pose (a few frames) do not move a median.
A result lifted or sunk against its source keeps the source's floor, so it reads as floating or
penetrating; detected on its own it would just find its new floor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import MjmotionError

#: How the floor was found, in order of precedence.
FLOOR_FROM = ("given", "source", "detected")
#: A detected floor further than this from z = 0 (m) is worth a note to the user.
NOTE_M = 0.01
#: The lower foot "stands still" below this horizontal speed (m/s).
STILL = 0.2


@dataclass(frozen=True)
class Floor:
    """A floor height ``height`` (m, world z) and where it came from (``from_``: one of :data:`FLOOR_FROM`)."""

    height: float
    from_: str

    def __post_init__(self) -> None:
        if self.from_ not in FLOOR_FROM:
            raise MjmotionError(f"floor from {self.from_!r}: expected one of {', '.join(FLOOR_FROM)}")
        if not math.isfinite(self.height):
            raise MjmotionError(f"floor height {self.height!r}: expected a finite number of metres")

    def note(self, name: str = "") -> str | None:
        """One line for the user when a detected floor is more than :data:`NOTE_M` from z = 0."""
        if self.from_ != "detected" or abs(self.height) <= NOTE_M:
            return None
        where = "above" if self.height > 0 else "below"
        return (
            f"note: {name + ': ' if name else ''}detected floor {self.height:+.3f} m ({100 * abs(self.height):.1f} cm {where} z = 0); "
            "ground metrics measure from it (--floor 0 measures from z = 0)"
        )


def detect(z: np.ndarray, speeds: np.ndarray, still: float = STILL) -> float:
    """The stance floor of a clip (m).

    ``z: (T, F)`` world height of each foot's lowest sole point, ``speeds: (T, F)`` its speed
    (m/s; :class:`~mjmotion.feet.FootTrack` passes horizontal and vertical together). Per frame the lower foot; the median of its height over frames where it is
    slower than ``still``, or the 5th percentile of all its heights when fewer than 3 frames
    (or 2 % of the clip) stand still.
    """
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or z.shape != np.shape(speeds) or z.shape[0] == 0:
        raise MjmotionError(f"floor.detect: heights {z.shape} and speeds {np.shape(speeds)} must be the same (T, F), T ≥ 1")
    lower = np.argmin(z, axis=1)
    rows = np.arange(z.shape[0])
    zl, vl = z[rows, lower], np.asarray(speeds)[rows, lower]
    stance = vl < still
    if stance.sum() >= max(3, 0.02 * len(zl)):
        return float(np.median(zl[stance]))
    return float(np.percentile(zl, 5))


def resolve(given: float | None, source_floors: Sequence[float], detected: float) -> Floor:
    """The floor to use: ``given`` if not None, else the mean of ``source_floors`` (the floors
    detected on the sources), else ``detected`` (the clip's own)."""
    if given is not None:
        return Floor(float(given), "given")
    if len(source_floors):
        return Floor(float(np.mean(source_floors)), "source")
    return Floor(float(detected), "detected")
