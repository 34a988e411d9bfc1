"""n-way registration: n clips registered to a reference clip (seed 000 §3.1, last paragraphs)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MjmotionError
from ..skeleton import Motion
from .curves import TimewarpCurve
from .grid import DEFAULT_WINDOW, distance_grid, joint_weights
from .pairs import positions_of, prepare, register
from .paths import SlopeLimit, auto_start, dp_path


@dataclass(frozen=True)
class Registration:
    """n clips registered to a reference (seed 000 §3.1, last paragraphs).

    Attributes:
        times: ``(N, n)`` float frames, column ``k`` the time of clip ``k``; every column strictly
            increasing. Row ``m`` is one instant of the registration.
        alignment: ``(N, n, 3)`` ``[theta, tx, ty]`` moving clip ``k`` onto the reference.
        reference: index of the reference clip (its column is sampled once per frame).
        mean_costs: ``(n,)`` mean path cost of each clip against the reference (0 for itself).
    """

    times: np.ndarray
    alignment: np.ndarray
    reference: int
    mean_costs: np.ndarray

    @property
    def n_clips(self) -> int:
        return self.times.shape[1]

    def at(self, tau: np.ndarray) -> np.ndarray:
        """Clip times ``(len(tau), n)`` at reference times ``tau`` (frames of the reference)."""
        ref = self.times[:, self.reference]
        return np.stack([np.interp(tau, ref, self.times[:, k]) for k in range(self.n_clips)], axis=1)


def choose_reference(motions: list[Motion], positions: list[np.ndarray], window: int = DEFAULT_WINDOW) -> int:
    """The clip most like the others: least summed mean path cost (seed 000: prefer a walk to a sprint)."""
    n = len(motions)
    if n <= 2:
        return 0
    w = joint_weights(motions[0].skeleton)
    score = np.zeros(n)
    for a in range(n):
        for b in range(a + 1, n):
            g = distance_grid(positions[a], positions[b], w, window)
            p = dp_path(g.cost, SlopeLimit.default(*g.cost.shape), True, auto_start(g.cost))
            score[a] += p.mean_cost
            score[b] += p.mean_cost
    return int(np.argmin(score))


def register_many(
    motions: list[Motion],
    reference: int | None = None,
    window: int = DEFAULT_WINDOW,
    slope_limit: int | None = None,
    loop: bool = False,
    start: tuple[int, int] | str = "auto",
    positions: list[np.ndarray] | None = None,
) -> Registration:
    """n-way registration: n−1 timewarp curves to a reference, merged into one curve of n-vectors.

    The reference is sampled once per frame over the span every curve covers (seed 000 samples it
    every 5–10 frames and fits a spline; our per-pair curves are splines already, so sampling them
    densely is the same curve).
    """
    if len(motions) < 1:
        raise MjmotionError("registration needs at least one clip")
    prepare(motions)
    pos = positions if positions is not None else [positions_of(m) for m in motions]
    ref = choose_reference(motions, pos, window) if reference is None else int(reference)
    n = len(motions)
    curves: list[TimewarpCurve | None] = []
    aligns: list[np.ndarray | None] = []
    costs = np.zeros(n)
    for k in range(n):
        if k == ref:
            curves.append(None)
            aligns.append(None)
            continue
        pr = register(motions[ref], motions[k], window, slope_limit, loop, "dp", start, positions=(pos[ref], pos[k]))
        curves.append(pr.curve)
        aligns.append(pr.alignment)
        costs[k] = pr.path.mean_cost
    lo = max([c.samples[0, 0] for c in curves if c is not None], default=0.0)
    hi = min([c.samples[-1, 0] for c in curves if c is not None], default=motions[ref].n_frames - 1.0)
    if hi - lo < 1:
        raise MjmotionError("the registered clips share less than one frame of the reference; they cannot be blended")
    tau = np.arange(lo, hi + 1e-9, 1.0)
    times = np.empty((len(tau), n))
    align = np.zeros((len(tau), n, 3))
    for k, (curve_k, align_k) in enumerate(zip(curves, aligns, strict=True)):
        if curve_k is None or align_k is None:
            times[:, k] = tau
            continue
        s = curve_k.samples
        times[:, k] = np.interp(tau, s[:, 0], s[:, 1])
        for c in range(3):
            align[:, k, c] = np.interp(tau, s[:, 0], align_k[:, c])
    keep = np.r_[True, np.all(np.diff(times, axis=0) > 0, axis=1)]
    return Registration(times=times[keep], alignment=align[keep], reference=ref, mean_costs=costs)
