"""Whether two clips can be blended at all (seed 004 §7.2 and Fig. 10).

Sako's "logical similarity": walks and runs blend, chopping wood and dancing do not, and their
grid shows it (Fig. 9 against Fig. 10). The score here puts a number on it: the mean cost of the
registration's path — how far apart the matched frames are — over the pair's self-similarity,
the mean distance between two frames of the same clip (same windows, weights and floor
alignment), of the clip whose frames differ least. A score of 1 means the best matches are no
closer than two frames of that clip picked at random: the path found no correspondence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .grid import DEFAULT_WINDOW, distance_grid

#: Scores above this are reported unblendable. Calibrated on the shared clips
#: (``python experiments/timewarp_blend.py``, ``blendability.md``): walk and run pairs 0.01–0.74,
#: a walk with the baseball pitch 124_01 or a golf swing 0.95–1.17.
THRESHOLD = 0.9
#: Frames of a clip (evenly spaced; every frame of a shorter clip) whose windows enter its self-similarity.
SELF_FRAMES = 200
#: A self-similarity (m²) at most this holds one pose: its frames differ by the rounding of a written file
#: (a still clip read back from BVH read 1e-15, and its blendability 6e13 instead of "cannot be measured").
STILL_M2 = 1e-10


@dataclass(frozen=True)
class Blendability:
    """How blendable two registered clips are.

    Attributes:
        score: ``mean_cost / min(self_similarity)``; lower is more alike, ≥ 1 no correspondence; inf (``null``
            in JSON) when a clip holds one pose (self-similarity at most ``STILL_M2``) and the other does not.
        mean_cost: the path's mean cell cost (m²).
        self_similarity: ``(A, B)`` mean distance between two frames of each clip (m²).
        threshold: the score above which the pair is called unblendable.
    """

    score: float
    mean_cost: float
    self_similarity: tuple[float, float]
    threshold: float = THRESHOLD

    @property
    def blendable(self) -> bool:
        return bool(self.score <= self.threshold)

    def to_json(self) -> dict:
        return {
            "score": self.score,
            "threshold": self.threshold,
            "blendable": self.blendable,
            "mean_cost": self.mean_cost,
            "self_similarity": list(self.self_similarity),
        }

    def warning(self, name_a: str, name_b: str) -> str | None:
        """One line for a pair above the threshold, else ``None``."""
        if self.blendable:
            return None
        still = [n for n, s in zip((name_a, name_b), self.self_similarity, strict=True) if not s > 0]
        if still and not np.isfinite(self.score):  # a clip whose frames are all alike has no spread to compare with
            return f"{' and '.join(still)} hold{'s' if len(still) == 1 else ''} one pose throughout: blendability (seed 004 §7.2) cannot be measured"
        return (
            f"{name_a} and {name_b} look unblendable: blendability {self.score:.2f} > {self.threshold:g} "
            f"(their matched frames are {self.score:.0%} as far apart as two frames of one clip; seed 004 §7.2)"
        )


def self_similarity(positions: np.ndarray, weights: np.ndarray | None = None, window: int = DEFAULT_WINDOW, max_frames: int = SELF_FRAMES) -> float:
    """Mean distance (m²) between two frames of one clip, ``positions: (T, J, 3)``: the mean of
    its own distance grid over at most ``max_frames`` evenly spaced frames."""
    frames = np.unique(np.linspace(0, len(positions) - 1, min(len(positions), max_frames)).round().astype(int))
    return float(distance_grid(positions, positions, weights, window, frames_a=frames, frames_b=frames).cost.mean())


def blendability(
    positions_a: np.ndarray, positions_b: np.ndarray, mean_cost: float, weights: np.ndarray | None = None, window: int = DEFAULT_WINDOW
) -> Blendability:
    """The :class:`Blendability` of clips A and B whose registration path has ``mean_cost``."""
    sa, sb = self_similarity(positions_a, weights, window), self_similarity(positions_b, weights, window)
    sa, sb = (s if s > STILL_M2 else 0.0 for s in (sa, sb))
    scale = min(sa, sb)
    score = float(mean_cost / scale) if scale > 0 else (0.0 if mean_cost <= STILL_M2 else float("inf"))
    return Blendability(score=score, mean_cost=float(mean_cost), self_similarity=(sa, sb))
