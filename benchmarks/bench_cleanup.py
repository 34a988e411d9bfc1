"""Cleanup's pinned paths: the banded solve against the same least-squares problem assembled sparse.

``mjmotion.cleanup.pinned_paths`` holds each plant's touching point still as the judge measures
it, one least-squares problem per plant and its blend window. Its normal
equations are banded (steps couple neighbouring frames, accelerations three), and it solves them
with ``scipy.linalg.solveh_banded``. The baseline here is the way it was first written: every
term a row of a ``scipy.sparse`` matrix, the normal equations formed and factored by ``spsolve``.
Both run on the calls a real cleanup makes (the linear blend of the daz walk
07_01 and run 09_01), rounds interleaved; the table gives the median time of all calls per
round and the largest difference between the two answers.

    python benchmarks/bench_cleanup.py [--rounds 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from mjmotion import blend, bvh
from mjmotion import cleanup as cl
from mjmotion.trim import leading_transient


def sparse_pinned_paths(plants, exact, ankles_xy, reach, fps, window, stiffness, blend_s, fades=None):
    """The objective of :func:`mjmotion.cleanup.pinned_paths`, one sparse row per term, solved by
    ``spsolve`` on the normal equations (the baseline)."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    t_count = len(ankles_xy)
    out = ankles_xy.copy()
    half = max(5, int(round(window * fps)) | 1) // 2
    k = np.argmin(reach[..., 2], axis=1)
    planted, near, anchor_w = cl.stretches(plants, t_count, fps, blend_s, fades)
    run_lo, run_hi = np.zeros(t_count, dtype=int), np.zeros(t_count, dtype=int)
    for a, b in cl._runs(planted):
        run_lo[a:b], run_hi[a:b] = a, b
    for lo_s, hi_s in cl._runs(near):
        m = hi_s - lo_s
        rows: list[int] = []
        cols: list[int] = []
        vals: list[float] = []
        rhs: list[np.ndarray] = []
        for t in np.flatnonzero(planted[lo_s:hi_s]) + lo_s:
            lo, hi = max(run_lo[t], t - half), min(run_hi[t], t + half + 1)
            if hi - lo < 2:
                continue
            steps = np.arange(lo, hi - 1) - lo_s
            wgt = fps / np.sqrt(len(steps))
            r = reach[lo:hi, k[t], :2]
            rows += list(len(rhs) + np.arange(len(steps))) * 2
            cols += list(steps + 1) + list(steps)
            vals += [wgt] * len(steps) + [-wgt] * len(steps)
            rhs += list(-(r[1:] - r[:-1]) * wgt)
        still = sp.csr_matrix((vals, (rows, cols)), shape=(len(rhs), m))
        target = np.asarray(rhs, dtype=float).reshape(-1, 2)
        ext = np.arange(max(0, lo_s - 2), min(t_count, hi_s + 2))
        d2 = sp.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(len(ext) - 2, len(ext))).tocsc() * (stiffness * fps * fps)
        unknown = (ext >= lo_s) & (ext < hi_s)
        d2u, d2k = d2[:, np.flatnonzero(unknown)], d2[:, np.flatnonzero(~unknown)]
        held = sp.diags(planted[ext[1:-1]].astype(float))
        a_u, a_k = ankles_xy[lo_s:hi_s], ankles_xy[ext[~unknown]]
        anchor = np.where(planted[lo_s:hi_s, None], exact[lo_s:hi_s], a_u)
        aw = anchor_w[lo_s:hi_s]
        base = d2u.T @ d2u + d2u.T @ held @ d2u + sp.diags(aw)
        base_rhs = d2u.T @ (d2u @ a_u) - d2u.T @ (held @ (d2k @ a_k)) + aw[:, None] * anchor
        lhs = (still.T @ still + base).tocsc()
        out[lo_s:hi_s] = np.asarray(spsolve(lhs, still.T @ target + base_rhs)).reshape(m, 2)
    return out


def calls() -> list[tuple]:
    """The ``pinned_paths`` calls of one real cleanup, recorded."""
    import bench_registration

    d = bench_registration.data_dir()
    if d is None:
        sys.exit("real mocap not found: set MJMOTION_DATA to the shared/mocap directory")
    w, r = (bvh.read(d / "cmu_cgspeed_daz" / f) for f in ("07_01.bvh", "09_01.bvh"))
    w, r = w[leading_transient(w) :], r[leading_transient(r) :]
    seen: list[tuple] = []
    real = cl.pinned_paths

    def spy(*args):
        seen.append(args)
        return real(*args)

    cl.pinned_paths = spy
    try:
        cl.cleanup(blend.blend([w, r], [0.5, 0.5], method="linear"), sources=[w, r])
    finally:
        cl.pinned_paths = real
    return seen


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7, help="timed rounds (default 7)")
    args = ap.parse_args()
    recorded = calls()
    rows = {"pinned_paths (banded, solveh_banded)": cl.pinned_paths, "sparse rows + spsolve (baseline)": sparse_pinned_paths}
    times: dict[str, list[float]] = {k: [] for k in rows}
    for rnd in range(args.rounds + 1):  # round 0 warms up
        for label, f in rows.items() if rnd % 2 else reversed(rows.items()):
            t = time.perf_counter()
            for a in recorded:
                f(*a)
            if rnd:
                times[label].append(time.perf_counter() - t)
    diff = max(float(np.abs(cl.pinned_paths(*a) - sparse_pinned_paths(*a)).max()) for a in recorded)
    ours, base = (statistics.median(v) for v in times.values())
    print(f"{len(recorded)} pinned_paths calls of a real cleanup, {args.rounds} interleaved rounds, median per round")
    for label, v in times.items():
        print(f"{label:<40}{1000 * statistics.median(v):9.1f} ms")
    print(f"banded / sparse: {base / ours:.1f}x faster; largest difference between the answers {diff:.1e} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
