"""Minimal-cost path search on our grids: seed 004 Tables 2–4 (Sako §5.2, §7.3).

Four searches over the registration grid of two clips (:mod:`mjmotion.registration`): brute
force (every path; only on sub-grids of at most 100 cells), greedy, threshold-pruned recursion
(Sako's "area threshold", Table 4) and dynamic programming. Each is timed and its path cost
compared with the optimum (brute force on the sub-grids, DP on the full grids — the sub-grids
check that the two agree).

Like Sako, with costs counted in integers (Table 2: the grid quantised to 0–255, an 8-bit image
of it) and in real values (Table 3). Fixed corners (seed 000's loops; objective = total cost) and
a free end on the boundary (start at the cheapest cell of the first third of the first row or
column, seed 004 §5.3) are measured. A free end has two objectives, both solved exactly by DP and
by brute force (:func:`mjmotion.registration.dp_path`): Kovar & Gleicher's (seed 004 §4.3; the
least-total path to each end cell, then the least mean of those — the default) and the least mean
cell cost over every path. Every path is scored on both: its mean against the least mean, and its
total against the least total to the cell where it ends.

``brute_force.md`` (seed 004 Tables 2–3's brute force at the sizes it can finish): brute force on
growing sub-grids of the first pair, with the number of paths (:func:`mjmotion.registration.count_paths`),
its time and DP's, and for the full grids the time all their paths would take at the measured rate.
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
from ..trim import skip_leading_transient
from . import Table

T = TypeVar("T")

#: Sako's area thresholds (Table 4: 20 % failed, 30 % and 40 % optimal; 30–35 % recommended).
AREA_THRESHOLDS = (0.20, 0.30, 0.35, 0.40, 1.0)
AREA_THRESHOLDS_QUICK = (0.20, 0.30, 0.40)
#: Brute force enumerates every path: a 10 × 10 sub-grid has 1.1 M paths to the boundary (~3 s), 8 × 8 51 k.
SUB_GRID = 10
SUB_GRID_QUICK = 8
#: Sub-grid sizes of the brute-force scaling table (12 × 12: 25 M paths, about Sako's 81 s).
BRUTE_SIZES = (6, 8, 10, 12)
BRUTE_SIZES_QUICK = (6, 8)
#: The scaling table's brute-force budget per run (s).
BRUTE_LIMIT_S = 900.0

COLUMNS = (
    "grid", "cells", "values", "ends", "method", "time ms", "cost / optimum", "accuracy %", "total / least to its end", "path cells",
)  # fmt: skip


@dataclass(frozen=True)
class Pair:
    """Two clips to register: ``a`` along the grid's rows, ``b`` along its columns."""

    label: str
    a: Motion
    b: Motion


def daz_clip(data_dir: Path, name: str) -> Motion:
    """A cgspeed daz clip without its leading T-pose frames (:mod:`mjmotion.trim`, as every verb reads
    it: frames 0–3), also :mod:`.timewarp_blend`'s walks and runs."""
    path = Path(data_dir) / "cmu_cgspeed_daz" / f"{name}.bvh"
    if not path.is_file():
        raise MjmotionError(f"{path}: missing; the experiment needs the cgspeed daz walks and runs (SOURCES.md)")
    return skip_leading_transient(bvh.read(str(path)))[0].replace(name=name)


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
    """The score against the optimum: total cost with fixed corners, mean cell cost with a free end."""
    return path.cost if loop else path.mean_cost


def least_to_end(cost: np.ndarray, path: reg.Path, slope: reg.SlopeLimit) -> float:
    """The least total cost of any path from ``path``'s first cell to its last (fixed corners)."""
    (i0, j0), (i1, j1) = path.cells[0], path.cells[-1]
    return reg.dp_path(cost[: i1 + 1, : j1 + 1], slope, False, (int(i0), int(j0))).cost


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
    """Rows of :data:`COLUMNS` for every method on one grid.

    The optimum is brute force's when run, else DP's: the least total with fixed corners, the
    least mean with a free end (``rule="mean"``); "total / least to its end" compares each path with
    the cheapest from its start to where it ends (1 for every path of the per-end rule).
    """
    ends = "corners" if loop else "free end"

    def search(method: str, rule: str = "per-end", **options: Any) -> Callable[[], reg.Path]:
        return lambda: reg.find_path(cost, method, loop=loop, start="auto", rule=rule, **options)

    methods: list[tuple[str, Callable[[], reg.Path], int]] = []
    if brute:
        methods.append(("brute force", search("brute", time_limit_s=None), 1))
        if not loop:
            methods.append(("brute force, least mean", search("brute", "mean", time_limit_s=None), 1))
    methods.append(("DP", search("dp"), repeats))
    if not loop:
        methods.append(("DP, least mean", search("dp", "mean"), repeats))
    methods.append(("greedy", search("greedy"), repeats))
    methods += [(f"threshold {th:.0%}", search("threshold", area_threshold=th), 1) for th in thresholds]
    results: list[tuple[str, float, reg.Path | None]] = []
    for name, fn, reps in methods:
        try:
            t, p = timed(fn, reps)
            results.append((name, t, p))
        except MjmotionError:  # Sako's "failed": no path under the threshold, or greedy stuck
            results.append((name, float("nan"), None))
    exact = ("brute force" if brute else "DP") + ("" if loop else ", least mean")
    opt = objective(next(p for n, _, p in results if n == exact and p is not None), loop)
    slope = reg.SlopeLimit.default(*cost.shape)
    rows: list[tuple] = []
    for name, t, found in results:
        if found is None:
            rows.append((grid_label, cost.size, values, ends, name, "failed", "failed", "failed", "failed", "–"))
            continue
        value = objective(found, loop)
        ratio = value / opt if opt > 0 else (1.0 if value == 0 else float("inf"))
        least = least_to_end(cost, found, slope)
        to_end = found.cost / least if least > 0 else (1.0 if found.cost == 0 else float("inf"))
        rows.append((grid_label, cost.size, values, ends, name, 1e3 * t, ratio, 100.0 / ratio, to_end, len(found.cells)))
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
            acc, to_end = 100.0 / mean_r, max(float(r[8]) for r in ok)
            cells_ = statistics.mean(float(r[9]) for r in ok)
        else:
            mean_t = mean_r = worst = acc = to_end = cells_ = float("nan")
        out.append((kind, size, values, ends, method, mean_t, mean_r, worst, acc, to_end, cells_, f"{len(ok)}/{len(rows)}"))
    return out


SUMMARY_COLUMNS = (
    "grid", "cells", "values", "ends", "method", "time ms (mean)", "cost / optimum (mean)", "worst", "accuracy %",
    "total / least to its end (worst)", "path cells (mean)", "solved",
)  # fmt: skip
BRUTE_COLUMNS = ("grid", "cells", "ends", "paths", "brute force s", "paths/s", "DP ms", "same path as DP")


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
        if n == 0:
            brute = brute_table(grid, pair, BRUTE_SIZES_QUICK if quick else BRUTE_SIZES)
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
            ("free end, two exact objectives: DP and brute force = Kovar & Gleicher's rule (seed 004 §4.3: the least-total "
                "path to each end cell, then the least mean of those; the default); 'least mean' = the least mean cell cost "
                "over every path (DP: Dinkelbach's parametric search over DP passes)"),
            ("cost / optimum: total cost with fixed corners; with a free end the mean cell cost over the least mean; "
                "accuracy % = 100 · optimum / cost (Sako's Eq. 4, as her tables report it); worst = largest ratio; "
                "total / least to its end: the path's total over the cheapest path from its start to its end cell "
                "(1 = optimal for where it ends; what the per-end rule guarantees)"),
            "values: integer = the grid quantised to 0–255 (Sako's Table 2), real = float64 (Table 3)",
            ("threshold N %: cells above N % of the grid's maximum are never entered (Sako's Table 4; 100 % prunes "
                "nothing); solved = pairs where a path was found (Sako's 'failed' otherwise)"),
            "time: wall clock after the grid is built (as Sako's), median of repeats for DP and greedy, shared 2-core machine",
            ("Sako (2006, Delphi): brute force 81 s / 1179 s (integer / real values), greedy < 1 s at 92.4 % / 94.9 %, "
                "threshold recursion 8 s at 100 %; area threshold 20 % failed, 30 % 21 s, 40 % 36 s"),
        ],
        files=[str(out_dir / "pairs.md"), *files],
    )  # fmt: skip
    table.notes += free_end_notes(detail.rows)
    table.files.append(str(out_dir / "brute_force.md"))
    (out_dir / "pairs.md").write_text(detail.markdown(), encoding="utf-8")
    (out_dir / "brute_force.md").write_text(brute.markdown(), encoding="utf-8")
    table.write(out_dir)
    return table


def free_end_notes(detail: Sequence[Sequence[object]]) -> list[str]:
    """What the least-mean objective does on the full grids, against the per-end rule and greedy."""
    full = [tuple(r) for r in detail if r[3] == "free end" and "every" not in str(r[0]) and r[5] != "failed"]
    # (grid, values, method) → (mean / least mean, total / least to its end, path cells)
    by = {(str(r[0]), str(r[2]), str(r[4])): (float(str(r[6])), float(str(r[8])), float(str(r[9]))) for r in full}
    pairs = sorted({(str(r[0]), str(r[2])) for r in full})
    lower = [by[k + ("DP",)][0] for k in pairs if k + ("DP",) in by]
    longer = [by[k + ("DP, least mean",)][2] / by[k + ("DP",)][2] for k in pairs if k + ("DP",) in by and k + ("DP, least mean",) in by]
    beat = [k for k in pairs if k + ("greedy",) in by and by[k + ("greedy",)][0] < by[k + ("DP",)][0]]
    greedy_to_end = max((by[k + ("greedy",)][1] for k in pairs if k + ("greedy",) in by), default=float("nan"))
    if not lower:
        return []
    return [
        (f"free end, full grids: the per-end path's mean is {min(lower):.3f}–{max(lower):.3f}× the least mean; greedy's "
            f"mean is below the per-end path's on {len(beat)} of {len(pairs)} grids, but its total is up to "
            f"{greedy_to_end:.2f}× the least to the cell where it ends; the least-mean paths have "
            f"{min(longer):.2f}–{max(longer):.2f}× as many cells — a path's mean drops when it trades a diagonal for two "
            "straight steps through cells cheaper than its mean, so it stair-steps along the valley"),
    ]  # fmt: skip


def _search_of(cost: np.ndarray, method: str, loop: bool, **options: Any) -> Callable[[], reg.Path]:
    """A path search of ``cost`` to time (a free end starts at :func:`mjmotion.registration.auto_start`)."""
    return lambda: reg.find_path(cost, method, loop=loop, start="auto", **options)


def brute_table(grid: np.ndarray, pair: Pair, sizes: Sequence[int]) -> Table:
    """Brute force on ``size × size`` sub-grids of ``grid`` (real values, both end rules): paths, time
    and agreement with DP; then each end rule's path count on the full grid and the time brute force
    would take at the fastest rate measured (:data:`BRUTE_COLUMNS`)."""
    table = Table(
        f"Brute force by grid size ({pair.label}, real values; seed 004 Tables 2–3)",
        BRUTE_COLUMNS,
        notes=[
            "sub-grid: every k-th frame of both clips; paths: every path brute force enumerates (registration.count_paths: "
            "to the far corner, or every path ending on the last row or column); same path as DP: brute force and DP found the same optimum (free end: the per-end rule)",
            f"each run within a {BRUTE_LIMIT_S:g} s budget (mjmotion register --method brute --time-limit S); "
            "Sako (2006): brute force 81 s (integer values) and 1179 s (real values) on her walks and runs",
        ],
    )
    rate = 0.0
    for size in sizes:
        sub, k = sub_grid(grid, size)
        for loop in (True, False):
            slope = reg.SlopeLimit.default(*sub.shape)
            start = (0, 0) if loop else reg.auto_start(sub)
            n_paths = reg.count_paths(sub.shape, slope, not loop, start)
            t_bf, bf = timed(_search_of(sub, "brute", loop, time_limit_s=BRUTE_LIMIT_S), 1)
            t_dp, dp = timed(_search_of(sub, "dp", loop), 5)
            rate = max(rate, n_paths / max(t_bf, 1e-9))
            same = bool(np.array_equal(bf.cells, dp.cells))
            table.add(f"every {k} frames ({sub.shape[0]}×{sub.shape[1]})", sub.size, "corners" if loop else "free end", n_paths, t_bf,
                      n_paths / max(t_bf, 1e-9), 1e3 * t_dp, same)  # fmt: skip
    for loop in (True, False):
        slope = reg.SlopeLimit.default(*grid.shape)
        start = (0, 0) if loop else reg.auto_start(grid)
        n_paths = reg.count_paths(grid.shape, slope, not loop, start)
        t_dp, _ = timed(_search_of(grid, "dp", loop), 5)
        table.add(f"full ({grid.shape[0]}×{grid.shape[1]})", grid.size, "corners" if loop else "free end", n_paths,
                  n_paths / rate if rate > 0 else float("nan"), rate, 1e3 * t_dp, "–")  # fmt: skip
    table.notes.append("full grids: brute force s is the estimate at the fastest rate measured above (paths/s); inf = more than 1e308 paths")
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
