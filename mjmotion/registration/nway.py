"""n-way registration: n clips registered to a reference clip (seed 000 §3.1, last paragraphs)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import MjmotionError
from ..skeleton import Motion
from .blendability import Blendability
from .curves import monotone_bspline
from .grid import DEFAULT_WINDOW, distance_grid, joint_weights
from .pairs import PairRegistration, positions_of, prepare, register
from .paths import SlopeLimit, auto_start, dp_path

#: Seed 000 §3.1: the reference is sampled every 5–10 frames and the n clips' times there are the
#: points the one n-dimensional curve is fitted to.
SAMPLE_EVERY = 8


@dataclass(frozen=True)
class Registration:
    """n clips registered to a reference (seed 000 §3.1, last paragraphs).

    Attributes:
        times: ``(N, n)`` float frames, column ``k`` the time of clip ``k``; every column strictly
            increasing. Row ``m`` is one instant of the registration (for :func:`register_many`:
            the curve :attr:`spline` at every frame of the reference).
        alignment: ``(N, n, 3)`` ``[theta, tx, ty]`` moving clip ``k`` onto the reference.
        reference: index of the reference clip.
        mean_costs: ``(n,)`` mean path cost of each clip against the reference (0 for itself).
        blendability: per clip, its :class:`~.blendability.Blendability` with the reference
            (``None`` for the reference itself; empty for a registration built from rows).
        spline: the clamped uniform cubic B-spline (:class:`~.curves.Spline`) ``τ → (n,)`` of
            the clips' times at reference time ``τ``, its n-dimensional control points strictly
            increasing in every coordinate (``None`` for a registration built from rows).
    """

    times: np.ndarray
    alignment: np.ndarray
    reference: int
    mean_costs: np.ndarray
    spline: Any = None
    blendability: tuple[Blendability | None, ...] = ()

    @property
    def n_clips(self) -> int:
        return self.times.shape[1]

    def __repr__(self) -> str:
        """``Registration(2 clips, reference 0, 240 instants, mean_costs=(0, 0.01737))``: no arrays."""
        from ..summary import fields

        size = (f"{self.n_clips} clips", f"reference {self.reference}", f"{len(self.times)} instants")
        return fields("Registration", *size, mean_costs=tuple(float(c) for c in self.mean_costs))

    def to_markdown(self) -> str:
        """Per clip: its mean path cost against the reference and its blendability, as a Markdown table."""
        from ..summary import number

        lines = ["| clip | mean cost (m²) | blendability |", "|---|---|---|"]
        for k in range(self.n_clips):
            b = self.blendability[k] if k < len(self.blendability) else None
            shown = "reference" if k == self.reference else number(b.score if b is not None else None)
            lines.append(f"| {k} | {number(float(self.mean_costs[k]))} | {shown} |")
        return "\n".join(lines) + "\n"

    def at(self, tau: np.ndarray) -> np.ndarray:
        """Clip times ``(len(tau), n)`` at reference times ``tau`` (frames of the reference)."""
        ref = self.times[:, self.reference]
        return np.stack([np.interp(tau, ref, self.times[:, k]) for k in range(self.n_clips)], axis=1)


def choose_reference(
    motions: list[Motion], positions: list[np.ndarray], window: int = DEFAULT_WINDOW, weights: dict[str, float] | None = None
) -> int:
    """The clip most like the others: least summed mean path cost (seed 000: prefer a walk to a sprint)."""
    n = len(motions)
    if n <= 2:
        return 0
    w = joint_weights(motions[0].skeleton, weights)
    score = np.zeros(n)
    for a in range(n):
        for b in range(a + 1, n):
            g = distance_grid(positions[a], positions[b], w, window)
            p = dp_path(g.cost, SlopeLimit.default(*g.cost.shape), True, auto_start(g.cost))
            score[a] += p.mean_cost
            score[b] += p.mean_cost
    return int(np.argmin(score))


def ndim_curve(times: np.ndarray, reference: int, sample_every: float = SAMPLE_EVERY) -> Any:
    """One clamped uniform cubic B-spline ``τ → (n,)`` through corresponding times, strictly
    increasing in every coordinate (seed 000 §3.1).

    ``times: (N, n)`` corresponding frames, column ``reference`` strictly increasing (the
    parameter ``τ``). The reference is sampled every ``sample_every`` frames: one knot per sample,
    so one n-dimensional control point per sample (plus the cubic's three), fitted by least
    squares to every row with monotone control points and pinned ends
    (:func:`.curves.monotone_bspline`); the reference's own coordinate comes out as ``τ``.
    """
    tau = times[:, reference]
    return monotone_bspline(tau, times, round((tau[-1] - tau[0]) / sample_every))


def register_many(
    motions: list[Motion],
    reference: int | None = None,
    window: int = DEFAULT_WINDOW,
    slope_limit: int | None = None,
    loop: bool = False,
    start: tuple[int, int] | str = "auto",
    positions: list[np.ndarray] | None = None,
    weights: dict[str, float] | None = None,
    sample_every: float = SAMPLE_EVERY,
) -> Registration:
    """n-way registration as seed 000 §3.1 builds it: a timewarp curve of every clip to the
    reference, then one n-dimensional curve.

    Each clip is registered to the reference (:func:`.pairs.register`, its own strictly increasing
    B-spline); over the span of the reference every pair covers, the clips' times at each frame of
    the reference are gathered into n-vectors and one clamped uniform cubic B-spline whose control
    points are n-vectors, one per ``sample_every`` frames of the reference (seed 000: 5–10), is
    fitted to them, strictly increasing in every coordinate (:func:`ndim_curve`). ``times`` are
    the curve at each frame of the reference. ``weights``: joint name → weight of the distance
    (:func:`.grid.joint_weights`).
    """
    if len(motions) < 1:
        raise MjmotionError("registration needs at least one clip")
    if not 1 <= sample_every:
        raise MjmotionError(f"sample_every must be at least 1 frame of the reference, got {sample_every}")
    prepare(motions)
    pos = positions if positions is not None else [positions_of(m) for m in motions]
    if reference is not None and not 0 <= int(reference) < len(motions):
        raise MjmotionError(f"reference {reference}: expected the index of one of the {len(motions)} clips (0 to {len(motions) - 1})")
    ref = choose_reference(motions, pos, window, weights) if reference is None else int(reference)
    pairs = [
        None
        if k == ref
        else register(motions[ref], motions[k], window, slope_limit, loop, "dp", start, weights=weights, positions=(pos[ref], pos[k]))
        for k in range(len(motions))
    ]
    return combine(pairs, ref, motions[ref].n_frames, sample_every)


def combine(pairs: list[PairRegistration | None], reference: int, n_reference: int, sample_every: float | None = SAMPLE_EVERY) -> Registration:
    """One :class:`Registration` from each clip's registration to the reference (``None`` at the
    reference): the clips' times gathered at every frame of the reference over the span every pair
    covers, fitted by one n-dimensional B-spline (:func:`ndim_curve`, a control point every
    ``sample_every`` frames); ``sample_every=None`` keeps the gathered times as they are (a
    discrete timewarp stays discrete)."""
    ref, n = int(reference), len(pairs)
    curves = [None if p is None else p.curve for p in pairs]
    aligns = [None if p is None else p.alignment for p in pairs]
    costs = np.array([0.0 if p is None else p.path.mean_cost for p in pairs])
    blends = [None if p is None else p.blendability for p in pairs]

    lo = max([c.samples[0, 0] for c in curves if c is not None], default=0.0)
    hi = min([c.samples[-1, 0] for c in curves if c is not None], default=n_reference - 1.0)
    if hi - lo < 1:
        raise MjmotionError("the registered clips share less than one frame of the reference; they cannot be blended")
    # the n-vectors of corresponding times at every frame of the reference, and one curve through them
    tau = np.linspace(lo, hi, int(np.ceil(hi - lo - 1e-9)) + 1)
    gathered = np.column_stack([tau if c is None else np.interp(tau, c.samples[:, 0], c.samples[:, 1]) for c in curves])
    spline = None if sample_every is None else ndim_curve(gathered, ref, sample_every)
    times = gathered if spline is None else spline(tau)
    keep = np.r_[True, np.all(np.diff(times, axis=0) > 0, axis=1)]
    times = times[keep]
    align = np.zeros((len(times), n, 3))
    for k, (curve_k, align_k) in enumerate(zip(curves, aligns, strict=True)):
        if curve_k is not None and align_k is not None:
            for c in range(3):
                align[:, k, c] = np.interp(times[:, ref], curve_k.samples[:, 0], align_k[:, c])
    return Registration(times=times, alignment=align, reference=ref, mean_costs=costs, spline=spline, blendability=tuple(blends))
