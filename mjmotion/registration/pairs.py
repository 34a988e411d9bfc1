"""Registration of two clips: grid, path, timewarp curve and alignment (seed 000 §3.1)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..caps import MAX_WINDOW
from ..errors import MjmotionError, is_whole
from ..fk import joint_positions
from ..skeleton import Motion
from .align import alignment_curve
from .blendability import Blendability, blendability
from .curves import TimewarpCurve, discrete_timewarp, timewarp_curve
from .grid import DEFAULT_WINDOW, MAX_CELLS, Grid, check_grid_size, distance_grid, joint_weights
from .paths import Path, find_path


@dataclass(frozen=True)
class PairRegistration:
    """Everything :func:`register` finds for clips A and B (frames of each clip)."""

    grid: Grid
    path: Path
    curve: TimewarpCurve
    alignment: np.ndarray  # (N, 3) theta, tx, ty per curve sample: applied to B to match A
    timing_s: dict[str, float] = field(default_factory=dict)
    blendability: Blendability | None = None

    def to_json(self) -> dict:
        """The JSON record of ``mjmotion register`` (keys documented in the issue/CLI help)."""
        return {
            "frames": list(self.grid.cost.shape),
            "path": self.path.cells.tolist(),
            "path_cost": self.path.cost,
            "mean_cost": self.path.mean_cost,
            "method": self.path.method,
            "timewarp": self.curve.samples.tolist(),
            "alignment": self.alignment.tolist(),
            "timing_s": self.timing_s,
            **({"blendability": self.blendability.to_json()} if self.blendability is not None else {}),
        }

    def __repr__(self) -> str:
        """``PairRegistration(240 × 180 grid, 231-cell path, mean_cost=0.01737, ...)``: no arrays."""
        from ..summary import fields

        na, nb = self.grid.cost.shape
        score = self.blendability.score if self.blendability is not None else None
        cells = f"{len(self.path.cells)}-cell path"
        return fields("PairRegistration", f"{na} × {nb} grid", cells, method=self.path.method, mean_cost=self.path.mean_cost, blendability=score)

    def to_markdown(self) -> str:
        """The registration's numbers as a two-column Markdown table (the arrays are in :meth:`to_json`)."""
        from ..summary import markdown_table

        rows: dict[str, object] = {
            "frames (A, B)": tuple(int(n) for n in self.grid.cost.shape),
            "method": self.path.method,
            "path cells": len(self.path.cells),
            "path cost (m²)": self.path.cost,
            "mean cost (m²)": self.path.mean_cost,
            "timewarp samples": len(self.curve.samples),
        }
        if self.blendability is not None:
            rows["blendability"] = self.blendability.score
            rows["blendable"] = self.blendability.blendable
        rows.update({f"{k} (ms)": 1e3 * v for k, v in self.timing_s.items()})
        return markdown_table(rows, header=("registration", "value"))


def positions_of(motion: Motion) -> np.ndarray:
    """World joint positions ``(T, J, 3)``: NumPy FK of MuJoCo's tree (:mod:`mjmotion.fk`), so a
    registration loads no MuJoCo."""
    return joint_positions(motion)


def prepare(motions: list[Motion]) -> None:
    """Refuse clips that cannot be registered together (other topology or frame rate)."""
    first = motions[0]
    for m in motions[1:]:
        first.skeleton.require_same_topology(m.skeleton, f"{first.name or 'clip 1'} and {m.name or 'another clip'}")
        if abs(m.fps - first.fps) > 1e-3 * first.fps:
            raise MjmotionError(
                f"{m.name or 'a clip'} runs at {m.fps:g} fps and {first.name or 'the first'} at {first.fps:g} fps; "
                "resample them to one rate first (--fps)"
            )


def register(
    a: Motion,
    b: Motion,
    window: int = DEFAULT_WINDOW,
    slope_limit: int | None = None,
    loop: bool = False,
    method: str = "dp",
    start: tuple[int, int] | str = "auto",
    curve: str = "bspline",
    weights: dict[str, float] | None = None,
    positions: tuple[np.ndarray, np.ndarray] | None = None,
    max_cells: int = MAX_CELLS,
    rule: str = "per-end",
    path_options: dict[str, Any] | None = None,
) -> PairRegistration:
    """Register clip B to clip A: grid, path, timewarp curve and alignment (seed 000 §3.1).

    ``start="auto"`` starts a free-end path at the best cell of the first third of the first row
    or column (seed 004 §5.3), so clips need not begin in phase; ``loop`` pins both corners.
    Also scores how blendable the pair is (:mod:`.blendability`, seed 004 §7.2).
    ``positions`` may pass precomputed ``(T, J, 3)`` joint positions of both clips. ``weights``:
    joint name → weight of the distance (:func:`.grid.joint_weights`); ``rule``: the free-end
    objective (:func:`.paths.dp_path`); ``path_options``: more options of the path search
    (``time_limit_s`` for brute force, ``area_threshold`` for threshold).
    Clips shorter than the window still work (windows repeat edge frames); a clip of one
    frame cannot be registered.
    """
    prepare([a, b])
    if min(a.n_frames, b.n_frames) < 2:
        short = [m.name or ("the first clip", "the second clip")[k] for k, m in enumerate((a, b)) if m.n_frames < 2]
        raise MjmotionError(f"{' and '.join(short)}: 1 frame as read; registration needs clips of at least 2 frames")
    # (a window of 10**6 asked for 159 GiB, 2.5 was a raw TypeError; NaN positions read "no path joins the corners")
    if not (is_whole(window) and 0 <= window <= MAX_WINDOW // 2):
        raise MjmotionError(f"window={window!r}: expected a half-window L (clouds of 2L+1 frames), a whole number from 0 to {MAX_WINDOW // 2}")
    check_grid_size(a.n_frames, b.n_frames, max_cells)
    w = joint_weights(a.skeleton, weights)
    if positions is not None:
        for k, (m, pos) in enumerate(zip((a, b), positions)):
            shape = np.shape(pos)
            if shape != (m.n_frames, a.skeleton.n_joints, 3) or not np.all(np.isfinite(pos)):
                raise MjmotionError(
                    f"positions[{k}]: expected finite joint positions of shape {(m.n_frames, a.skeleton.n_joints, 3)} (frames, joints, xyz), got {shape}"
                )
    pa, pb = positions if positions is not None else (positions_of(a), positions_of(b))
    t0 = time.perf_counter()
    grid = distance_grid(pa, pb, w, window, max_cells)
    t1 = time.perf_counter()
    path = find_path(grid.cost, method, slope_limit, loop, start, rule, **(path_options or {}))
    t2 = time.perf_counter()
    if curve == "bspline":
        tw = timewarp_curve(path)
    elif curve == "discrete":
        tw = discrete_timewarp(path)
    else:
        raise MjmotionError(f"unknown timewarp curve {curve!r}; expected bspline or discrete")
    align = alignment_curve(pa, pb, tw.samples, w, window)
    t3 = time.perf_counter()
    blend = blendability(pa, pb, path.mean_cost, w, window)
    t4 = time.perf_counter()
    timing = {"grid": t1 - t0, "path": t2 - t1, "curve": t3 - t2, "blendability": t4 - t3}
    return PairRegistration(grid, path, tw, align, timing, blend)
