"""Registration speed: grid, path and curve for two 600-frame clips, against baselines.

Prints, from one run:
  * grid / path / curve times of ``mjmotion.registration`` (median of repeats) and the whole
    registration with and without forward kinematics;
  * the same distance grid by a straightforward per-cell loop (seed 000 Eq. 3–5 cell by cell,
    written here as the baseline), its time and the speed ratio, and the largest difference;
  * the DP path against tslearn's DTW on the same precomputed cost matrix (pip install tslearn;
    the row is skipped with a message if it is absent), plus a cost cross-check.

Clips: cmu_cgspeed_daz/05_01 (a 5 s straight walk, T-pose frames dropped) stretched to 600
frames, and a copy re-timed by a known smooth warp and moved on the floor (600 frames), so the
run also reports the recovery error. Goals (issue 4): whole registration < 50 ms; ≥ 100× the
per-cell loop; (issue 19) the grid at >= 70 % of its GEMM floor: the time of its two matrix
products alone (``registration.grid.grid_operands``), measured interleaved with the grid.

    python benchmarks/bench_registration.py [--repeats 7] [--baseline-rows 600]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

if __name__ == "__main__":  # BLAS threads must be fixed before NumPy loads (see --threads)
    _t = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--threads=")), "1")
    for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_v, _t)

import numpy as np

from mjmotion import bvh, transform
from mjmotion import registration as R

N = 600


def data_dir() -> Path | None:
    env = os.environ.get("MJMOTION_DATA")
    cand = Path(env) if env else Path(__file__).resolve().parents[1].parent / "shared" / "mocap"
    return cand if cand.is_dir() else None


def clips() -> tuple:
    d = data_dir()
    if d is None:
        sys.exit("real mocap not found: set MJMOTION_DATA to the shared/mocap directory")
    src = bvh.read(str(d / "cmu_cgspeed_daz" / "05_01.bvh"))[4:]
    a = transform.timewarp(src, lambda i: i * (src.n_frames - 1) / (N - 1), N)

    def w(i):
        s = i / (N - 1)
        return (0.03 + 0.9 * s + 0.03 * np.sin(2 * np.pi * s)) * (N - 1)

    b = transform.floor_transform(transform.timewarp(a, w, N), 0.9, (2.0, -1.0))
    return a, b, w


def per_cell_grid(pa: np.ndarray, pb: np.ndarray, weights: np.ndarray, window: int, rows: int) -> np.ndarray:
    """The baseline: Eq. 3–5 evaluated cell by cell with a Python loop over cells."""
    n_a, n_b = len(pa), len(pb)
    out = np.empty((rows, n_b))
    w = np.tile(weights, 2 * window + 1)
    w = w / w.sum()
    for i in range(rows):
        ia = np.clip(np.arange(i - window, i + window + 1), 0, n_a - 1)
        p = pa[ia].reshape(-1, 3)
        for j in range(n_b):
            jb = np.clip(np.arange(j - window, j + window + 1), 0, n_b - 1)
            q = pb[jb].reshape(-1, 3)
            x, y, xq, yq = p[:, 0], p[:, 1], q[:, 0], q[:, 1]
            sx, sy, sxq, syq = w @ x, w @ y, w @ xq, w @ yq
            num = w @ (y * xq - x * yq) - (sy * sxq - sx * syq)
            den = w @ (x * xq + y * yq) - (sx * sxq + sy * syq)
            th = np.arctan2(num, den)
            c, s = np.cos(th), np.sin(th)
            tx = sx - (c * sxq - s * syq)
            ty = sy - (s * sxq + c * syq)
            moved = np.column_stack([c * xq - s * yq + tx, s * xq + c * yq + ty, q[:, 2]])
            out[i, j] = w @ np.sum((p - moved) ** 2, axis=1)
    return out


def timed(fn, repeats: int, clock=time.perf_counter):
    times, result = [], None
    for _ in range(repeats):
        t = clock()
        result = fn()
        times.append(clock() - t)
    return statistics.median(times), result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument(
        "--threads",
        default="1",
        help="BLAS threads, as --threads=N (default 1: on a shared 2-core machine OpenBLAS threads contend and a 600×105 product slows ~10×)",
    )
    ap.add_argument("--baseline-rows", type=int, default=N, help="rows of the per-cell baseline to time (scaled to the full grid)")
    args = ap.parse_args()
    a, b, w_true = clips()
    weights = R.joint_weights(a.skeleton)
    window = R.DEFAULT_WINDOW
    t_fk, (pa, pb) = timed(lambda: (R.positions_of(a), R.positions_of(b)), args.repeats)
    # the grid against its GEMM floor: the same two products alone, interleaved with the whole grid
    left, right, left_z, right_z = R.grid.grid_operands(pa, pb, weights, window)
    pair = {"grid": lambda: R.distance_grid(pa, pb, weights, window), "gemms": lambda: (left @ right.T, left_z @ right_z.T)}
    pair["operands"] = lambda: R.grid.grid_operands(pa, pb, weights, window)
    samples: dict[str, list[float]] = {k: [] for k in pair}
    for r in range(max(args.repeats, 7) * 5):
        for k in pair if r % 2 else list(pair)[::-1]:
            t = time.perf_counter()
            pair[k]()
            samples[k].append(time.perf_counter() - t)
    med = {k: statistics.median(v) for k, v in samples.items()}
    p90 = {k: float(np.percentile(v, 90)) for k, v in samples.items()}
    t_grid, grid = med["grid"], R.distance_grid(pa, pb, weights, window)
    start = R.auto_start(grid.cost)
    slope = R.SlopeLimit.default(N, N)
    t_path_np, path = timed(lambda: R.dp_path(grid.cost, slope, True, start, backend="numpy"), args.repeats)
    try:
        R.dp_path(grid.cost, slope, True, start, backend="numba")  # compile / load the cache once
        t_path, path_nb = timed(lambda: R.dp_path(grid.cost, slope, True, start, backend="numba"), args.repeats)
        assert np.array_equal(path_nb.cells, path.cells)
        numba_row = f"; Numba kernel {t_path * 1e3:.1f} ms (same path)"
    except R.MjmotionError:
        t_path, numba_row = t_path_np, "; Numba not installed"
    t_curve, curve = timed(lambda: R.timewarp_curve(path), args.repeats)
    t_align, align = timed(lambda: R.alignment_curve(pa, pb, curve.samples, weights, window), args.repeats)
    t_all, reg = timed(lambda: R.register(a, b, positions=(pa, pb)), args.repeats)  # "auto" DP backend
    t_all_fk, _ = timed(lambda: R.register(a, b), args.repeats)
    t_all_cpu, _ = timed(lambda: R.register(a, b, positions=(pa, pb)), args.repeats, time.process_time)

    dense = np.linspace(0, N - 1, 20 * N)
    s = reg.curve.samples
    rms = float(np.sqrt(np.mean((s[:, 1] - np.interp(s[:, 0], w_true(dense), dense)) ** 2)))
    load = os.getloadavg()[0]
    print(f"BLAS threads: {os.environ.get('OPENBLAS_NUM_THREADS')}; load average {load:.1f} on {os.cpu_count()} cores")
    n_w = int((weights > 0).sum())
    print(f"two {N}-frame clips ({a.skeleton.n_joints} joints, {n_w} weighted), window {2 * window + 1} frames; median of {args.repeats}")
    print(f"  forward kinematics (MuJoCo, both clips) {t_fk * 1e3:8.1f} ms")
    print(
        f"  grid  (vectorised, {N}×{N})           {t_grid * 1e3:8.1f} ms  (p90 {p90['grid'] * 1e3:.1f}; {len(samples['grid'])} runs interleaved with:)"
    )
    print(f"    its two GEMMs alone (the floor)      {med['gemms'] * 1e3:8.1f} ms  (p90 {p90['gemms'] * 1e3:.1f})")
    print(f"    building the operands (window clouds){med['operands'] * 1e3:8.1f} ms  (p90 {p90['operands'] * 1e3:.1f})")
    share = med["gemms"] / t_grid
    print(f"  grid at {share:.0%} of the GEMM floor (goal >= 70%): {'met' if share >= 0.7 else 'NOT met'}")
    print(f"  path  (DP, free end, slope limit 2)    {t_path_np * 1e3:8.1f} ms  NumPy rows ({len(path.cells)} cells){numba_row}")
    print(f"  curve (monotone B-spline) + alignment  {(t_curve + t_align) * 1e3:8.1f} ms  ({t_curve * 1e3:.1f} + {t_align * 1e3:.1f})")
    print(
        f"  whole registration                     {t_all * 1e3:8.1f} ms  (goal < 50 ms); CPU time {t_all_cpu * 1e3:.1f} ms; "
        f"with FK {t_all_fk * 1e3:.1f} ms"
    )
    theta = np.degrees(np.median(reg.alignment[:, 0]))
    print(f"  recovered timewarp RMS {rms:.2f} frames; alignment theta {theta:.2f}° (true {-np.degrees(0.9):.2f}°)")

    for method in ("greedy", "threshold"):  # Sako's alternatives (seed 004 §5.2, Table 2's "accuracy")
        reps = 1 if method == "threshold" else args.repeats
        t_m, p_m = timed(lambda m=method: R.find_path(grid.cost, m, start=start), reps)
        ratio = 100 * p_m.mean_cost / path.mean_cost
        print(f"  path  ({method:9s})                    {t_m * 1e3:8.1f} ms  mean cost {ratio:.1f}% of DP's")

    rows = min(args.baseline_rows, N)
    t = time.perf_counter()
    base = per_cell_grid(pa, pb, weights, window, rows)
    t_base = (time.perf_counter() - t) * N / rows
    diff = float(np.abs(base - grid.cost[:rows]).max())
    scaled = "" if rows == N else f" (timed on {rows} rows, scaled to {N})"
    print(f"  per-cell loop baseline grid            {t_base * 1e3:8.1f} ms{scaled}; max |difference| {diff:.1e} m²")
    print(f"  grid speed-up vs per-cell loop         {t_base / t_grid:8.0f}×  (goal ≥ 100×)")

    try:
        from tslearn.metrics import dtw_path_from_metric
    except ImportError:
        print("  tslearn DTW: skipped (pip install tslearn to compare)")
        return
    dtw_path_from_metric(grid.cost[:50, :50], metric="precomputed")  # compile numba once
    t_ts, (ts_path, _) = timed(lambda: dtw_path_from_metric(grid.cost, metric="precomputed"), args.repeats)
    for backend in ("numpy", "numba"):
        try:
            t_ours, _ = timed(lambda b=backend: R.dp_path(grid.cost, slope, False, backend=b), args.repeats)
        except R.MjmotionError:
            continue
        print(
            f"  tslearn DTW (corners, no slope limit)  {t_ts * 1e3:8.1f} ms; ours (corners, slope limit 2, {backend}) "
            f"{t_ours * 1e3:.1f} ms: tslearn/ours = {t_ts / t_ours:.2f}"
        )
    # cross-check: with a slope limit as long as tslearn's longest straight run, the optima agree
    ts_cells = np.array(ts_path)
    ts_cost = float(grid.cost[ts_cells[:, 0], ts_cells[:, 1]].sum())
    run, longest = 0, 0
    for st in np.diff(ts_cells, axis=0):
        run = run + 1 if st[0] == 0 or st[1] == 0 else 0
        longest = max(longest, run)
    ours = R.find_path(grid.cost, "dp", slope_limit=max(longest, 1), loop=True)
    print(f"  cost check: tslearn {ts_cost:.8g} m², ours with W={max(longest, 1)} {ours.cost:.8g} m²")


if __name__ == "__main__":
    main()
