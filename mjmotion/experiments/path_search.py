"""Minimal-cost path search on our grids: seed 004 Tables 2–4 (Sako §5.2, §7.3).

Four searches over the registration grid of two clips (:mod:`mjmotion.registration`): brute
force (every path; only on sub-grids of at most 100 cells), greedy, threshold-pruned recursion
(Sako's "area threshold", Table 4) and dynamic programming. Each is timed and its path cost
compared with the optimum (brute force on the sub-grids, DP on the full grids — the sub-grids
check that the two agree).

Like Sako, with costs counted in integers (Table 2: the grid quantised to 0–255, an 8-bit image
of it) and in real values (Table 3). Both end rules of :func:`mjmotion.registration.find_path`
are measured: fixed corners (seed 000's loops; objective = total cost) and a free end on the
boundary (seed 004 §4.3; objective = mean cell cost, start at the cheapest cell of the first
third of the first row or column, seed 004 §5.3).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from .. import bvh, plots
from .. import registration as reg
from ..errors import MjmotionError
from ..skeleton import Motion
from . import Table

T = TypeVar("T")

#: Sako's area thresholds (Table 4: 20 % failed, 30 % and 40 % optimal; 30–35 % recommended).
AREA_THRESHOLDS = (0.20, 0.30, 0.35, 0.40, 1.0)
AREA_THRESHOLDS_QUICK = (0.20, 0.30, 0.40)
#: Brute force enumerates every path: a 10 × 10 sub-grid is ~1.5 M paths (~3 s), 8 × 8 ~0.1 s.
SUB_GRID = 10
SUB_GRID_QUICK = 8
#: cgspeed daz clips open with a T-pose and 3 frames interpolating out of it (SOURCES.md).
DAZ_START = 4

COLUMNS = ("grid", "cells", "values", "ends", "method", "time ms", "cost / optimum", "accuracy %", "path cells")


@dataclass(frozen=True)
class Pair:
    """Two clips to register: ``a`` along the grid's rows, ``b`` along its columns."""

    label: str
    a: Motion
    b: Motion


def daz_clip(data_dir: Path, name: str) -> Motion:
    """A cgspeed daz clip without its leading T-pose frames (also :mod:`.timewarp_blend`'s walks and runs)."""
    path = Path(data_dir) / "cmu_cgspeed_daz" / f"{name}.bvh"
    if not path.is_file():
        raise MjmotionError(f"{path}: missing; the experiment needs the cgspeed daz walks and runs (SOURCES.md)")
    return bvh.read(str(path))[DAZ_START:].replace(name=name)


def real_pairs(data_dir: Path, quick: bool = False) -> list[Pair]:
    """Same-flavour daz walks and runs (120 fps): walk × walk, walk × run, run × run."""
    names = [("07_01", "09_01")] if quick else [("07_01", "08_01"), ("07_01", "09_01"), ("09_01", "09_11")]
    return [Pair(f"{a} × {b}", daz_clip(data_dir, a), daz_clip(data_dir, b)) for a, b in names]


def bundled_pairs(quick: bool = False) -> list[Pair]:
    """The bundled procedural clips: walk × run, walk × its known re-timing, walk × faster walk."""
    from .. import synth

    lib = synth.library()
    names = [("walk", "run"), ("walk", "walk_warped")] + ([] if quick else [("walk", "walk_fast")])
    return [Pair(f"{a} × {b}", lib[a].motion, lib[b].motion) for a, b in names]


def quantise(cost: np.ndarray, levels: int = 255) -> np.ndarray:
    """The grid as Sako's integer counts: ``round(levels · cost / max)`` ``(nA, nB)`` float."""
    top = float(cost.max())
    return np.round(cost * (levels / top)) if top > 0 else np.zeros_like(cost)


def sub_grid(cost: np.ndarray, size: int) -> tuple[np.ndarray, int]:
    """Every k-th frame of both clips, ``size × size`` cells spanning the whole grid; returns (grid, k)."""
    k = max(1, min(cost.shape) // size)
    return np.ascontiguousarray(cost[::k, ::k][:size, :size]), k


def objective(path: reg.Path, loop: bool) -> float:
    """What the search minimises: total cost with fixed corners, mean cell cost with a free end."""
    return path.cost if loop else path.mean_cost


def timed(fn: Callable[[], T], repeats: int) -> tuple[float, T]:
    """Median wall time (s) of ``repeats`` calls of ``fn()`` and its last result."""
    times, out = [], None
    for _ in range(max(1, repeats)):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    assert out is not None
    return statistics.median(times), out


def search_rows(cost: np.ndarray, grid_label: str, values: str, loop: bool, brute: bool, thresholds: tuple[float, ...], repeats: int) -> list[tuple]:
    """Rows of :data:`COLUMNS` for every method on one grid; the optimum is brute force when run, else DP."""
    ends = "corners" if loop else "free end"

    def search(method: str, **options: Any) -> Callable[[], reg.Path]:
        return lambda: reg.find_path(cost, method, loop=loop, start="auto", **options)

    methods: list[tuple[str, Callable[[], reg.Path], int]] = []
    if brute:
        methods.append(("brute force", search("brute"), 1))
    methods.append(("DP", search("dp"), repeats))
    methods.append(("greedy", search("greedy"), repeats))
    methods += [(f"threshold {th:.0%}", search("threshold", area_threshold=th), 1) for th in thresholds]
    results: list[tuple[str, float, reg.Path | None]] = []
    for name, fn, reps in methods:
        try:
            t, p = timed(fn, reps)
            results.append((name, t, p))
        except MjmotionError:  # Sako's "failed": no path under the threshold, or greedy stuck
            results.append((name, float("nan"), None))
    best = next(p for n, _, p in results if n == ("brute force" if brute else "DP") and p is not None)
    opt = objective(best, loop)
    rows: list[tuple] = []
    for name, t, found in results:
        if found is None:
            rows.append((grid_label, cost.size, values, ends, name, "failed", "failed", "failed", "–"))
            continue
        value = objective(found, loop)
        ratio = value / opt if opt > 0 else (1.0 if value == 0 else float("inf"))
        rows.append((grid_label, cost.size, values, ends, name, 1e3 * t, ratio, 100.0 / ratio, len(found.cells)))
    return rows


def summarise(detail: Sequence[Sequence[object]]) -> list[tuple]:
    """Per-pair rows of :data:`COLUMNS` → one row per (grid kind, values, ends, method) over the pairs,
    like Sako's tables (means over her 10 motions): :data:`SUMMARY_COLUMNS`."""
    groups: dict[tuple, list[tuple]] = {}
    for row in map(tuple, detail):
        kind = "sub-grid" if "every" in str(row[0]) else "full grid"
        groups.setdefault((kind, row[2], row[3], row[4]), []).append(row)
    out = []
    for (kind, values, ends, method), rows in groups.items():
        ok = [r for r in rows if r[5] != "failed"]
        cells = sorted({int(r[1]) for r in rows})
        size = f"{cells[0]}" if len(cells) == 1 else f"{cells[0]}–{cells[-1]}"
        if ok:
            ratios = [float(r[6]) for r in ok]
            mean_t, mean_r, worst = statistics.mean(float(r[5]) for r in ok), statistics.mean(ratios), max(ratios)
            acc = 100.0 / mean_r
        else:
            mean_t = mean_r = worst = acc = float("nan")
        out.append((kind, size, values, ends, method, mean_t, mean_r, worst, acc, f"{len(ok)}/{len(rows)}"))
    return out


SUMMARY_COLUMNS = (
    "grid", "cells", "values", "ends", "method", "time ms (mean)", "cost / optimum (mean)", "worst", "accuracy %", "solved",
)  # fmt: skip


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False) -> Table:
    """Tables 2–4 on real mocap (``data_dir``) or on the bundled clips.

    Writes ``out_dir/table.md`` (the summary over the clip pairs, returned), ``out_dir/pairs.md``
    (every pair and grid) and the distance-grid PNGs.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    pairs = real_pairs(Path(data_dir), quick) if data_dir is not None else bundled_pairs(quick)
    size = SUB_GRID_QUICK if quick else SUB_GRID
    repeats = 1 if quick else 5
    source = (
        "real mocap, cgspeed daz at 120 fps (T-pose frames 0–3 dropped)" if data_dir is not None
        else "bundled procedural clips (mjmotion.synth, 60 fps)"
    )  # fmt: skip
    detail = Table("Minimal-cost path search, every clip pair", COLUMNS, notes=[f"source: {source}"])
    files: list[str] = []
    for n, pair in enumerate(pairs):
        pa, pb = reg.positions_of(pair.a), reg.positions_of(pair.b)
        weights = reg.joint_weights(pair.a.skeleton)
        grid = reg.distance_grid(pa, pb, weights).cost
        counts = quantise(grid)
        sub, k = sub_grid(grid, size)
        for values, g, s in (("real", grid, sub), ("integer", counts, sub_grid(counts, size)[0])):
            for loop in (True, False):
                label = f"{pair.label}, every {k} frames ({s.shape[0]}×{s.shape[1]})"
                for row in search_rows(s, label, values, loop, True, (), repeats):
                    detail.add(*row)
                if quick and values == "integer":
                    continue  # the demo times the full grids in real values only
                label = f"{pair.label} ({g.shape[0]}×{g.shape[1]})"
                thresholds = AREA_THRESHOLDS_QUICK if quick else AREA_THRESHOLDS
                for row in search_rows(g, label, values, loop, False, thresholds, repeats):
                    detail.add(*row)
        if n == 0 or not quick:
            files += grid_figures(out_dir, pair, grid)
    pair_list = "; ".join(f"{p.label} ({p.a.n_frames}×{p.b.n_frames} frames)" for p in pairs)
    table = Table(
        "Minimal-cost path: brute force, greedy, threshold recursion and DP (seed 004 Tables 2–4)",
        SUMMARY_COLUMNS,
        rows=list(summarise(detail.rows)),
        notes=[
            f"source: {source}; pairs: {pair_list}; every pair and grid in pairs.md",
            "grid: seed 000 Eq. 2–5, 5-frame windows; slope limit seed 000 Eq. 6 (W = 2 for similar lengths)",
            (f"sub-grid: every k-th frame of both clips, {size} × {size} cells, small enough for brute force to "
                "enumerate every path; its optimum is brute force's, a full grid's is DP's"),
            ("cost / optimum: total cost with fixed corners, mean cell cost with a free end (the objective each "
                "minimises); accuracy % = 100 · optimum / cost (Sako's Eq. 4, as her tables report it); worst = largest ratio"),
            "values: integer = the grid quantised to 0–255 (Sako's Table 2), real = float64 (Table 3)",
            ("threshold N %: cells above N % of the grid's maximum are never entered (Sako's Table 4; 100 % prunes "
                "nothing); solved = pairs where a path was found (Sako's 'failed' otherwise)"),
            "time: wall clock after the grid is built (as Sako's), median of repeats for DP and greedy, shared 2-core machine",
            ("Sako (2006, Delphi): brute force 81 s / 1179 s (integer / real values), greedy < 1 s at 92.4 % / 94.9 %, "
                "threshold recursion 8 s at 100 %; area threshold 20 % failed, 30 % 21 s, 40 % 36 s"),
        ],
        files=[str(out_dir / "pairs.md"), *files],
    )  # fmt: skip
    below = [r for r in detail.rows if r[3] == "free end" and isinstance(r[6], float) and r[6] < 1 - 1e-12]
    if below:
        table.notes.append(
            f"free end: {len(below)} path(s) ({', '.join(sorted({str(r[4]) for r in below}))}) end with a lower mean cost than "
            "DP's: DP keeps, per boundary cell, the cheapest total path and then picks the least average (Kovar & "
            "Gleicher's rule, brute force likewise), which is not always the least-average path overall"
        )
    (out_dir / "pairs.md").write_text(detail.markdown(), encoding="utf-8")
    table.write(out_dir)
    return table


def grid_figures(out_dir: Path, pair: Pair, grid: np.ndarray) -> list[str]:
    """Distance grid with the DP path and its B-spline timewarp curve, and the greedy path over it."""
    stem = pair.label.replace(" × ", "_x_").replace(" ", "_")
    dp = reg.find_path(grid, "dp", start="auto")
    curve = reg.timewarp_curve(dp)
    greedy = reg.find_path(grid, "greedy", start="auto")
    labels = (f"frame of {pair.a.name or 'A'}", f"frame of {pair.b.name or 'B'}")
    files = [
        plots.distance_grid(grid, dp.cells, curve.samples, out_dir / f"grid_{stem}.png", labels=labels,
                            title=f"{pair.label}: DP path and timewarp curve"),
        plots.distance_grid(grid, greedy.cells, curve.samples, out_dir / f"greedy_{stem}.png", labels=labels,
                            title=f"{pair.label}: greedy path (white) vs DP curve (red)"),
    ]  # fmt: skip
    return [str(f) for f in files]
