"""Registration curves: grid against independent per-cell solutions, DP against brute force,
known timewarps and floor moves recovered from real clips, edge cases and the CLI."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import random_motion, random_skeleton
from scipy import optimize

from mjmotion import bvh, kinematics, transform
from mjmotion import registration as R
from mjmotion.errors import MjmotionError, SkeletonMismatchError
from mjmotion.registration.blendability import THRESHOLD

DAZ = "cmu_cgspeed_daz"


def _clip(mocap, name: str, start: int = 4):
    """A daz clip without its T-pose frames (mocap/SOURCES.md: start at frame 4)."""
    return bvh.read(str(mocap / DAZ / f"{name}.bvh"))[start:]


# --------------------------------------------------------------------------- grid
def _cell_by_optimiser(pa: np.ndarray, pb: np.ndarray, w: np.ndarray) -> tuple[float, np.ndarray]:
    """Eq. 2 by numerical minimisation over (theta, tx, ty): an independent check of Eq. 3–5."""
    w = w / w.sum()

    def f(x):
        c, s = np.cos(x[0]), np.sin(x[0])
        q = pb.copy()
        q[:, 0], q[:, 1] = c * pb[:, 0] - s * pb[:, 1] + x[1], s * pb[:, 0] + c * pb[:, 1] + x[2]
        return float(np.sum(w * np.sum((pa - q) ** 2, axis=1)))

    starts = np.linspace(-3, 3, 7)
    best = min((optimize.minimize(f, [t0, 0, 0], method="BFGS", options={"gtol": 1e-10}) for t0 in starts), key=lambda r: r.fun)
    return best.fun, best.x


def test_distance_grid_matches_numerical_minimum_per_cell():
    rng = np.random.default_rng(1)
    pa, pb = rng.normal(size=(6, 4, 3)), rng.normal(size=(5, 4, 3))
    w = np.array([1.0, 2.0, 0.5, 1.5])
    window = 1
    grid = R.distance_grid(pa, pb, w, window).cost
    for i, j in [(0, 0), (2, 3), (5, 4), (3, 1)]:
        ia = np.clip(np.arange(i - window, i + window + 1), 0, 5)
        jb = np.clip(np.arange(j - window, j + window + 1), 0, 4)
        ca, cb = pa[ia].reshape(-1, 3), pb[jb].reshape(-1, 3)
        ww = np.tile(w, 2 * window + 1)
        d, x = _cell_by_optimiser(ca, cb, ww)
        assert grid[i, j] == pytest.approx(d, rel=1e-6, abs=1e-9)
        th, tx, ty = R.rigid_2d(ca[None], cb[None], ww)[0]
        assert np.angle(np.exp(1j * (th - x[0]))) == pytest.approx(0, abs=1e-4)
        assert (tx, ty) == pytest.approx((x[1], x[2]), abs=1e-4)


def test_grid_leaves_out_joints_of_weight_zero_and_its_products_give_the_cost():
    rng = np.random.default_rng(4)
    pa, pb = rng.normal(size=(9, 5, 3)) + [3.0, -2.0, 1.0], rng.normal(size=(7, 5, 3))
    w = np.array([1.0, 0.0, 2.0, 0.5, 0.0])
    full = R.distance_grid(pa, pb, w, window=2).cost
    kept = R.distance_grid(pa[:, w > 0], pb[:, w > 0], w[w > 0], window=2).cost
    assert np.allclose(full, kept, rtol=0, atol=1e-13)
    left, right, left_z, right_z = R.grid.grid_operands(pa, pb, w, 2)
    assert left.shape == (18, 2 * 5 * 3) and right.shape == (7, 30) and left_z.shape == (9, 17) and right_z.shape == (7, 17)
    ab = left @ right.T
    assert np.allclose(np.maximum(left_z @ right_z.T - np.hypot(ab[:9], ab[9:]), 0), full, rtol=0, atol=1e-13)


def test_grid_in_row_blocks_equals_closed_form_cell_by_cell(monkeypatch):
    """Issue 19.5: the products run in blocks of rows (a ragged last block, rows picked by
    ``frames_a``); every cell equals Eq. 3–5 solved for that cell alone (``rigid_2d``, then the
    residual summed point by point), with clamped windows and a joint of weight zero."""
    rng = np.random.default_rng(5)
    pa, pb = rng.normal(size=(11, 4, 3)) + [4.0, -3.0, 1.0], rng.normal(size=(8, 4, 3))
    w, window = np.array([1.0, 0.0, 2.0, 0.5]), 2
    monkeypatch.setattr(R.grid, "BLOCK_BYTES", 16 * 8 * 3)  # 3 rows a block: 3 + 3 + 3 + 2
    grid = R.distance_grid(pa, pb, w, window).cost
    ww = np.tile(w, 2 * window + 1) / (w.sum() * (2 * window + 1))
    expect = np.empty((11, 8))
    for i in range(11):
        for j in range(8):
            ca = pa[np.clip(np.arange(i - window, i + window + 1), 0, 10)].reshape(-1, 3)
            cb = pb[np.clip(np.arange(j - window, j + window + 1), 0, 7)].reshape(-1, 3)
            th, tx, ty = R.rigid_2d(ca[None], cb[None], ww)[0]
            c, s = np.cos(th), np.sin(th)
            moved = np.column_stack([c * cb[:, 0] - s * cb[:, 1] + tx, s * cb[:, 0] + c * cb[:, 1] + ty, cb[:, 2]])
            expect[i, j] = ww @ np.sum((ca - moved) ** 2, axis=1)
    assert np.allclose(grid, expect, rtol=1e-12, atol=1e-13)
    rows, cols = np.array([10, 0, 4, 7, 7]), np.array([6, 1, 2])
    picked = R.distance_grid(pa, pb, w, window, frames_a=rows, frames_b=cols).cost
    assert np.allclose(picked, expect[np.ix_(rows, cols)], rtol=1e-12, atol=1e-13)


def test_grid_is_zero_for_a_clip_moved_on_the_floor():
    rng = np.random.default_rng(2)
    skel = random_skeleton(rng, 8, inner_positions=False)
    m = random_motion(rng, skel, 12)
    moved = transform.floor_transform(m, 2.1, (3.0, -1.5))
    pa, pb = kinematics.joint_positions(m), kinematics.joint_positions(moved)
    g = R.distance_grid(pa, pb).cost
    assert np.allclose(np.diag(g), 0.0, atol=1e-9)
    assert np.all(g[~np.eye(12, dtype=bool)] > 1e-4)  # other frames differ (random poses)


def test_grid_size_limit_refuses_with_advice():
    rng = np.random.default_rng(3)
    skel = random_skeleton(rng, 4, inner_positions=False)
    long = Motion_of(rng, skel, 10_000)
    with pytest.raises(MjmotionError, match=r"100,000,000-cell grid.*--frames.*--fps"):
        R.register(long, long)


def Motion_of(rng, skel, n):
    """A long motion without drawing random quaternions for every frame (only shapes matter)."""
    from mjmotion.skeleton import Motion

    q = np.zeros((n, skel.n_joints, 4))
    q[..., 0] = 1
    return Motion(skel, 120.0, np.zeros((n, 3)), q)


# --------------------------------------------------------------------------- paths
@pytest.mark.parametrize("backend", ["numpy", "auto"])
@pytest.mark.parametrize("shape", [(12, 12), (12, 8), (8, 12)])
def test_a_free_end_among_equal_ends_is_the_one_nearest_the_far_corner(shape, backend):
    """On a grid of equal costs (a still clip against a still clip) every end is as good; the path ran
    to the first one, half of the longer clip at the slope limit, and a still clip's registered blend
    with itself came out half as long."""
    cost = np.zeros(shape)
    corner = (shape[0] - 1, shape[1] - 1)
    for rule in ("per-end", "mean"):
        dp = R.dp_path(cost, R.SlopeLimit(1, 1), True, backend=backend, rule=rule)
        assert tuple(dp.cells[-1]) == corner, rule
    # The brute force and the threshold search take the same end (they took the first one too); the brute
    # force on the half-size grid of the same shape (12 x 12 holds 2.5e7 paths: a minute, over its budget).
    half = np.zeros((shape[0] // 2, shape[1] // 2))
    assert tuple(R.brute_path(half, R.SlopeLimit(2, 2), True).cells[-1]) == (half.shape[0] - 1, half.shape[1] - 1)
    for area in (1.0, 0.35):
        assert tuple(R.threshold_path(cost, R.SlopeLimit(2, 2), True, area_threshold=area).cells[-1]) == corner


@pytest.mark.parametrize("backend", ["numpy", "auto"])  # auto = the Numba kernel when installed
@pytest.mark.parametrize("seed", range(40))
def test_dp_equals_brute_force_on_small_random_grids(seed, backend):
    rng = np.random.default_rng(seed)
    n_a, n_b = rng.integers(1, 8, 2)
    cost = rng.random((n_a, n_b))
    slope = R.SlopeLimit(int(rng.integers(0, 3)), int(rng.integers(0, 3)))
    for free in (True, False):
        try:
            bf = R.brute_path(cost, slope, free)
        except MjmotionError:
            with pytest.raises(MjmotionError, match="slope limit"):
                R.dp_path(cost, slope, free, backend=backend)
            continue
        dp = R.dp_path(cost, slope, free, backend=backend)
        assert dp.cost == pytest.approx(bf.cost, rel=1e-12)
        np.testing.assert_array_equal(dp.cells, bf.cells)
        R.check_path(dp.cells, slope)
        assert dp.cost == pytest.approx(cost[dp.cells[:, 0], dp.cells[:, 1]].sum())
        assert tuple(dp.cells[0]) == (0, 0)
        if free:
            assert dp.cells[-1, 0] == n_a - 1 or dp.cells[-1, 1] == n_b - 1
        else:
            assert tuple(dp.cells[-1]) == (n_a - 1, n_b - 1)


def _least_mean_by_length(cost: np.ndarray, slope: R.SlopeLimit) -> float:
    """The least mean cell cost of a free-end path from (0, 0), by DP over (cell, run, length):
    for every boundary cell and path length the least total, then the least total / length — an
    exact method independent of the parametric search (affordable on small grids)."""
    n_a, n_b = cost.shape
    wv, wh = slope.vertical, slope.horizontal
    n_len = n_a + n_b
    best = np.full((n_a, n_b, 1 + wv + wh, n_len + 1), np.inf)  # state 0 D, 1..wv V_r, wv+1.. H_r
    best[0, 0, 0, 1] = cost[0, 0]

    def shift(x: np.ndarray) -> np.ndarray:  # one more cell
        out = np.full_like(x, np.inf)
        out[1:] = x[:-1]
        return out

    for i in range(n_a):
        for j in range(n_b):
            if i and j:
                best[i, j, 0] = shift(best[i - 1, j - 1].min(axis=0)) + cost[i, j]
            if i and wv:
                best[i, j, 1] = shift(np.minimum(best[i - 1, j, 0], best[i - 1, j, 1 + wv :].min(axis=0, initial=np.inf))) + cost[i, j]
                for r in range(2, wv + 1):
                    best[i, j, r] = shift(best[i - 1, j, r - 1]) + cost[i, j]
            if j and wh:
                best[i, j, 1 + wv] = shift(best[i, j - 1, : 1 + wv].min(axis=0)) + cost[i, j]
                for r in range(2, wh + 1):
                    best[i, j, wv + r] = shift(best[i, j - 1, wv + r - 1]) + cost[i, j]
    ends = np.concatenate([best[-1].min(axis=1), best[:, -1].min(axis=1)])  # (boundary cells, lengths)
    return float((ends / np.maximum(np.arange(n_len + 1), 1)).min())


@pytest.mark.parametrize("seed", range(12))
def test_least_mean_path_is_exact_against_brute_force_and_a_length_dp(seed):
    """Issue 18.5: with rule="mean" the free-end path has the least mean cell cost of all paths —
    brute force on small grids, a DP over (cell, run, length) on larger ones — and never more
    than Kovar & Gleicher's per-end path, which is exact for its own objective (least total per
    end cell, then least mean)."""
    rng = np.random.default_rng(100 + seed)
    small = rng.random(tuple(rng.integers(2, 8, 2)))
    slope = R.SlopeLimit(int(rng.integers(1, 3)), int(rng.integers(1, 3)))
    for backend in ("numpy", "auto"):
        dp = R.dp_path(small, slope, True, rule="mean", backend=backend)
        bf = R.brute_path(small, slope, True, rule="mean")
        assert dp.mean_cost == pytest.approx(bf.mean_cost, rel=1e-12)
        np.testing.assert_array_equal(dp.cells, bf.cells)
        R.check_path(dp.cells, slope)
    per_end = R.dp_path(small, slope, True, rule="per-end")
    assert per_end.cost == pytest.approx(R.brute_path(small, slope, True, rule="per-end").cost, rel=1e-12)
    assert dp.mean_cost <= per_end.mean_cost + 1e-15
    medium = rng.random((int(rng.integers(15, 30)), int(rng.integers(15, 30)))) ** 3  # skewed: cheap valleys
    slope = R.SlopeLimit.default(*medium.shape)
    exact = _least_mean_by_length(medium, slope)
    for method in ("dp", "threshold"):
        p = R.find_path(medium, method, rule="mean", **({"area_threshold": 1.0} if method == "threshold" else {}))
        assert p.mean_cost == pytest.approx(exact, rel=1e-12), method
        R.check_path(p.cells, slope)
    greedy = R.find_path(medium, "greedy")
    assert greedy.mean_cost >= exact - 1e-15


def test_free_end_rules_on_a_real_grid(mocap):
    """Greedy beats Kovar & Gleicher's per-end path on the mean (07_01 × 08_01), never the exact
    least-mean path; the per-end path is still the least total to its own end, and greedy's."""
    a, b = _clip(mocap, "07_01"), _clip(mocap, "08_01")
    grid = R.distance_grid(R.positions_of(a), R.positions_of(b), R.joint_weights(a.skeleton)).cost
    per_end, mean, greedy = (R.find_path(grid, m, start="auto", rule=r) for m, r in (("dp", "per-end"), ("dp", "mean"), ("greedy", "per-end")))
    assert greedy.mean_cost < per_end.mean_cost and mean.mean_cost < greedy.mean_cost
    for p in (per_end, greedy):  # the least total to the cell where each ends, from the same start
        end = tuple(p.cells[-1])
        to_end = R.dp_path(grid[: end[0] + 1, : end[1] + 1], R.SlopeLimit.default(*grid.shape), False, tuple(p.cells[0]))
        assert to_end.cost <= p.cost + 1e-12 and (p is greedy or to_end.cost == pytest.approx(p.cost, rel=1e-12))
    assert len(mean.cells) > 1.2 * len(per_end.cells)  # the least mean stair-steps along the valley


def _count_by_recursion(n_a: int, n_b: int, slope: R.SlopeLimit, free_end: bool) -> int:
    """Paths from (0, 0) counted by walking every step (the ends brute force records)."""
    import functools

    @functools.cache
    def walks(i: int, j: int, rh: int, rv: int) -> int:
        end = (i == n_a - 1 or j == n_b - 1) if free_end else (i == n_a - 1 and j == n_b - 1)
        n = int(end)
        for di, dj, nrh, nrv in ((1, 1, 0, 0), (1, 0, 0, rv + 1), (0, 1, rh + 1, 0)):
            if i + di < n_a and j + dj < n_b and nrh <= slope.horizontal and nrv <= slope.vertical:
                n += walks(i + di, j + dj, nrh, nrv)
        return n

    return walks(0, 0, 0, 0)


def test_count_paths_matches_delannoy_numbers_and_a_recursion():
    from math import comb

    def delannoy(m: int, n: int) -> int:  # lattice paths with steps (1,0), (0,1), (1,1)
        return sum(comb(m, k) * comb(n, k) * 2**k for k in range(min(m, n) + 1))

    free = R.SlopeLimit(99, 99)
    for m, n in ((1, 1), (4, 6), (9, 9), (12, 5)):
        assert R.count_paths((m, n), free, free_end=False) == delannoy(m - 1, n - 1)
    for shape, w in (((6, 9), 1), ((8, 8), 2), ((7, 5), 3)):
        for free_end in (False, True):
            assert R.count_paths(shape, R.SlopeLimit(w, w), free_end) == _count_by_recursion(*shape, R.SlopeLimit(w, w), free_end)
    assert R.count_paths((600, 600), R.SlopeLimit(2, 2)) == np.inf  # past float range: a clear "too many"


def test_brute_force_beyond_100_cells_within_a_time_budget():
    """Issue 18.6: brute force on a 150-cell grid (200 thousand paths) equals DP; a 16 × 16 grid
    (1.2e10 paths) stops at once with what it would take."""
    rng = np.random.default_rng(5)
    cost = rng.random((10, 15))
    slope = R.SlopeLimit(1, 1)
    for free_end in (True, False):
        bf = R.brute_path(cost, slope, free_end, time_limit_s=60.0)
        dp = R.dp_path(cost, slope, free_end)
        assert bf.cost == pytest.approx(dp.cost, rel=1e-12)
        np.testing.assert_array_equal(bf.cells, dp.cells)
    import time

    t0 = time.perf_counter()
    with pytest.raises(MjmotionError, match=r"16 × 16 grid: 1\.24e\+10 paths .* would take about .* over the 2 s budget.*--time-limit"):
        R.brute_path(rng.random((16, 16)), R.SlopeLimit(2, 2), True, time_limit_s=2.0)
    assert time.perf_counter() - t0 < 2.0  # its rate showed it could not finish: it did not wait for the budget
    with pytest.raises(MjmotionError, match="positive number of seconds"):
        R.brute_path(cost, slope, time_limit_s=0)


@pytest.mark.parametrize("loop", [False, True])
def test_alternative_searches_obey_constraints_and_cost_no_less_than_dp(loop):
    rng = np.random.default_rng(7)
    cost = rng.random((40, 50)) + np.abs(np.subtract.outer(np.arange(40) * 1.2, np.arange(50)))[:, :] * 0.05
    slope = R.SlopeLimit.default(40, 50)
    dp = R.find_path(cost, "dp", loop=loop)
    objective = (lambda p: p.mean_cost) if not loop else (lambda p: p.cost)
    for method in ("greedy", "threshold"):
        p = R.find_path(cost, method, loop=loop, **({"area_threshold": 1.0} if method == "threshold" else {}))
        R.check_path(p.cells, slope)
        assert objective(p) >= objective(dp) - 1e-12
    exact = R.find_path(cost, "threshold", loop=loop, area_threshold=1.0)
    assert objective(exact) == pytest.approx(objective(dp))
    with pytest.raises(MjmotionError, match="threshold"):
        R.find_path(cost, "threshold", loop=loop, area_threshold=0.01)


def test_slope_limit_default_follows_eq6():
    assert R.SlopeLimit.default(100, 100) == R.SlopeLimit(2, 2)
    assert R.SlopeLimit.default(300, 30) == R.SlopeLimit(horizontal=1, vertical=2)
    with pytest.raises(MjmotionError):
        R.SlopeLimit.of(-1, 5, 5)


# --------------------------------------------------------------------------- curves
@pytest.mark.parametrize("seed", range(10))
def test_timewarp_curve_strictly_increasing_and_pinned(seed):
    rng = np.random.default_rng(seed)
    n_a = int(rng.integers(20, 120))
    n_b = int(n_a * rng.uniform(0.6, 1.6))
    path = R.dp_path(rng.random((n_a, n_b)), R.SlopeLimit.default(n_a, n_b), free_end=False)
    s = R.timewarp_curve(path).samples
    assert np.all(np.diff(s, axis=0) > 0)
    np.testing.assert_allclose(s[0], path.cells[0], atol=0.05)
    np.testing.assert_allclose(s[-1], path.cells[-1], atol=0.05)
    d = R.discrete_timewarp(path).samples
    assert np.all(np.diff(d, axis=0) > 0)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_bspline_basis_equals_scipys_design_matrix(k):
    from scipy.interpolate import BSpline

    rng = np.random.default_rng(k)
    x = np.r_[0.0, np.sort(rng.uniform(0.0, 50.0, 300)), 50.0, 12.5]  # both ends and a knot exactly
    knots = np.r_[[0.0] * k, np.linspace(0.0, 50.0, 9), [50.0] * k]
    ours = R.curves.bspline_basis(x, knots, k)
    assert ours.shape == (len(x), len(knots) - k - 1)
    assert np.allclose(ours, BSpline.design_matrix(x, knots, k).toarray(), rtol=0, atol=1e-14)
    assert np.allclose(ours.sum(axis=1), 1.0)  # a partition of unity


@pytest.mark.parametrize("sigma", [0.4, 3.0, 6.0, 90.0])
def test_gaussian_smooth_equals_scipys_gaussian_filter1d(sigma):
    from scipy.ndimage import gaussian_filter1d

    x = np.random.default_rng(1).normal(size=(120, 3)).cumsum(axis=0)
    expect = gaussian_filter1d(x, sigma, axis=0, mode="nearest")
    assert np.allclose(R.align.gaussian_smooth(x, sigma), expect, rtol=0, atol=1e-12 * np.abs(x).max())


def test_register_loads_no_scipy(mocap):
    """A fresh registration of two clips stays off SciPy (its import alone would double a fresh `register`),
    Numba, CasADi, Matplotlib and MuJoCo (positions by NumPy FK, issue 19.2)."""
    code = (
        "import sys\n"
        "from mjmotion import bvh, registration as R\n"
        f"a = bvh.read({str(mocap / 'cmu_cgspeed_daz' / '07_01.bvh')!r})[4:]\n"
        f"b = bvh.read({str(mocap / 'cmu_cgspeed_daz' / '07_02.bvh')!r})[4:]\n"
        "R.register(a, b)\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'scipy', 'numba', 'casadi', 'matplotlib', 'mujoco'}))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "[]"


def test_discrete_timewarp_reproduces_sako_table_1():
    # case 1 (deletion): 1-1, 2-2, 2-3, 3-4 → frame 2 blends with 2.5 (2 iw 3); frames 0-based here
    d = R.discrete_timewarp(np.array([[0, 0], [1, 1], [1, 2], [2, 3]])).samples
    np.testing.assert_allclose(d, [[0, 0], [1, 1.5], [2, 3]])
    # case 2: three horizontal cells → the middle one (2 iw 4)
    d = R.discrete_timewarp(np.array([[0, 0], [1, 1], [1, 2], [1, 3], [2, 4]])).samples
    np.testing.assert_allclose(d, [[0, 0], [1, 2], [2, 4]])
    # case 3 (insertion): 1-1, 2-2, 3-2, 4-3 → 3 vs (2 iw 3)
    d = R.discrete_timewarp(np.array([[0, 0], [1, 1], [2, 1], [3, 2]])).samples
    np.testing.assert_allclose(d, [[0, 0], [1, 1], [2, 1.5], [3, 2]])


# --------------------------------------------------------------------------- ground truth on real clips
@pytest.mark.parametrize("name,theta,shift", [("07_01", 0.7, (1.5, -2.0)), ("09_01", -2.5, (-0.8, 3.1))])
def test_known_timewarp_and_floor_move_are_recovered(mocap, name, theta, shift):
    a = _clip(mocap, name)
    n = a.n_frames
    n_b = int(0.8 * n)

    def w(i):  # a smooth, strictly increasing re-timing that starts and ends inside A
        s = i / (n_b - 1)
        return (0.05 + 0.85 * s + 0.04 * np.sin(2 * np.pi * s)) * (n - 1)

    b = transform.floor_transform(transform.timewarp(a, w, n_b), theta, shift)
    reg = R.register(a, b)
    s = reg.curve.samples
    assert np.all(np.diff(s, axis=0) > 0)
    dense = np.linspace(0, n_b - 1, 20 * n_b)
    tb_true = np.interp(s[:, 0], w(dense), dense)
    rms = float(np.sqrt(np.mean((s[:, 1] - tb_true) ** 2)))
    assert rms < 1.5, f"timewarp RMS {rms:.2f} frames"
    # the transform applied to B to match A is the inverse of the move
    c, sn = np.cos(theta), np.sin(theta)
    true_t = -np.array([[c, sn], [-sn, c]]) @ np.array(shift)
    ang = np.degrees(np.abs(np.angle(np.exp(1j * (reg.alignment[:, 0] + theta)))))
    dist = np.linalg.norm(reg.alignment[:, 1:] - true_t, axis=1)
    assert ang.max() < 2.0 and dist.max() < 0.02, f"alignment error {ang.max():.2f}°, {dist.max() * 100:.1f} cm"
    assert set(reg.timing_s) == {"grid", "path", "curve", "blendability"}


def test_clip_registered_with_itself_is_the_identity(mocap):
    a = _clip(mocap, "09_01")
    reg = R.register(a, a)
    assert np.all(reg.path.cells[:, 0] == reg.path.cells[:, 1])
    np.testing.assert_allclose(reg.curve.samples[:, 0], reg.curve.samples[:, 1], atol=1e-6)
    np.testing.assert_allclose(reg.alignment, 0.0, atol=1e-6)
    assert reg.path.cost == pytest.approx(0.0, abs=1e-9)


def test_short_and_very_different_lengths(mocap):
    walk = _clip(mocap, "07_01")
    tiny = walk[40:43]  # fewer frames than the 5-frame window
    reg = R.register(walk, tiny)
    assert np.all(np.diff(reg.curve.samples, axis=0) > 0)
    assert abs(reg.curve.samples[0, 0] - 40) <= 3  # found where the excerpt comes from
    with pytest.raises(MjmotionError, match=r"^07_01: 1 frame as read; registration needs clips of at least 2 frames"):
        R.register(walk, walk[5:6])  # the clip is named (it read "got 113 and 1")
    # 10× different lengths: free end works, the pinned corners cannot be joined at W = 2
    short = walk[100:130].resample(walk.fps)
    reg = R.register(walk[:300], short)
    assert reg.path.cells[-1, 1] == short.n_frames - 1
    assert np.all(np.diff(reg.curve.samples, axis=0) > 0)
    with pytest.raises(MjmotionError, match="slope limit"):
        R.register(walk[:300], short, loop=True)


def test_different_topologies_refused(mocap):
    a = _clip(mocap, "07_01")
    b = bvh.read(str(mocap / "cmu_asfamc_converted" / "16_15.bvh"))
    with pytest.raises(SkeletonMismatchError):
        R.register(a, b)


def test_n_way_registration(mocap):
    walk = _clip(mocap, "07_01")
    slow = transform.timewarp(walk, lambda i: i * 0.7, int((walk.n_frames - 1) / 0.7))
    run = _clip(mocap, "09_01")
    reg = R.register_many([run, walk, slow])
    assert reg.reference in (1, 2)  # a walk is more like the others than the run (seed 000)
    assert np.all(np.diff(reg.times, axis=0) > 0)
    ref = reg.times[:, reg.reference]
    k = {1: 2, 2: 1}[reg.reference]  # the walk / slowed walk pair is related by t_slow = t_walk / 0.7
    factor = 0.7 if reg.reference == 2 else 1 / 0.7
    np.testing.assert_allclose(reg.times[:, k], ref * factor, atol=2.0)


def test_n_way_registration_is_one_n_dimensional_bspline(mocap):
    """Issue 18.2 (seed 000 §3.1): one clamped uniform cubic B-spline whose control points are
    n-vectors, a knot every 5–10 frames of the reference, strictly increasing in every coordinate;
    the registration's rows lie on it, it follows each pair's own curve, and it recovers the known
    relation of a walk and its copy slowed to 0.7× better than merging the pair curves did
    (0.26 frames at worst)."""
    walk = _clip(mocap, "07_01")
    slow = transform.timewarp(walk, lambda i: i * 0.7, int((walk.n_frames - 1) / 0.7))
    run = _clip(mocap, "09_01")
    reg = R.register_many([run, walk, slow], reference=1)
    sp = reg.spline
    assert sp.k == 3 and sp.c.shape[1] == 3
    t = sp.t
    assert np.all(t[:4] == t[0]) and np.all(t[-4:] == t[-1])  # clamped
    gaps = np.diff(t[3:-3])
    assert np.allclose(gaps, gaps[0]) and 5.0 <= gaps[0] <= 10.0  # uniform, every 5–10 reference frames
    assert sp.c.shape[0] == len(gaps) + 3
    assert np.all(np.diff(sp.c, axis=0) > 0)  # strictly increasing control points → strictly increasing curve
    tau = reg.times[:, 1]
    np.testing.assert_allclose(np.diff(tau), 1.0, atol=0.02)  # a row per frame of the reference
    np.testing.assert_allclose(sp(tau), reg.times, atol=1e-9)
    for k, clip in ((0, run), (2, slow)):  # within a third of a frame of each pair's own curve
        pair = R.register(walk, clip).curve.samples
        assert np.abs(reg.times[:, k] - np.interp(tau, pair[:, 0], pair[:, 1])).max() < 0.35
    assert np.abs(reg.times[:, 2] - tau / 0.7).max() < 0.2


# --------------------------------------------------------------------------- blendability
def test_blendability_tells_walks_and_runs_from_a_walk_and_a_pitch(mocap):
    """Issue 18.4 (seed 004 §7.2, Fig. 10): the score is the path's mean cost over the smaller
    self-similarity (the mean of a clip's own distance grid); walk/run pairs score under the
    threshold, a walk with the baseball pitch 124_01 over it."""
    asf = mocap / "cmu_asfamc_converted"
    walk = bvh.read(str(asf / "16_15.bvh"))[2:]
    pitch = bvh.read(str(asf / "124_01.bvh"))
    run = _clip(mocap, "09_01")
    pw, pp, pr_ = R.positions_of(walk), R.positions_of(pitch), R.positions_of(run)
    w = R.joint_weights(walk.skeleton)
    # a short clip's self-similarity is the mean of its whole own grid; a long one's a close estimate
    assert R.self_similarity(pr_, R.joint_weights(run.skeleton)) == pytest.approx(
        R.distance_grid(pr_, pr_, R.joint_weights(run.skeleton)).cost.mean(), rel=1e-12
    )
    assert R.self_similarity(pw, w) == pytest.approx(R.distance_grid(pw, pw, w).cost.mean(), rel=0.03)
    bad = R.register(walk, pitch, positions=(pw, pp))
    b = bad.blendability
    assert b.score == pytest.approx(bad.path.mean_cost / min(b.self_similarity), rel=1e-12)
    assert b.score > THRESHOLD and not b.blendable
    assert "unblendable" in b.warning("16_15", "124_01")
    good = R.register(_clip(mocap, "07_01"), run).blendability
    assert good.blendable and good.score < 0.8 and good.warning("a", "b") is None
    same = R.register(run, transform.floor_transform(run, 1.0, (2.0, 0.5))).blendability
    assert same.score == pytest.approx(0.0, abs=1e-9)  # a clip and itself moved on the floor
    # a clip that holds one pose has no spread to compare with: said so, not "blendability inf"
    still = run.replace(
        rotations=np.repeat(run.rotations[:1], run.n_frames, axis=0), root_positions=np.repeat(run.root_positions[:1], run.n_frames, axis=0)
    )
    frozen = R.register(run, still).blendability
    assert (
        not frozen.blendable
        and frozen.warning("09_01", "still") == "still holds one pose throughout: blendability (seed 004 §7.2) cannot be measured"
    )
    assert bad.to_json()["blendability"] == b.to_json() and b.to_json()["blendable"] is False


# --------------------------------------------------------------------------- CLI
def test_cli_register_of_a_still_clip_writes_standard_json(mocap, tmp_path):
    # A clip holding one pose has no blendability: its JSON says null, not the non-standard Infinity.
    run = _clip(mocap, "09_01")
    still = run.replace(rotations=np.repeat(run.rotations[:1], 60, axis=0), root_positions=np.repeat(run.root_positions[:1], 60, axis=0))
    bvh.write(still, tmp_path / "still.bvh")
    out = tmp_path / "reg.json"
    cmd = [sys.executable, "-m", "mjmotion.cli", "register", str(tmp_path / "still.bvh"), str(mocap / DAZ / "09_01.bvh"), "--json", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    d = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c} in {out.name}"))
    assert d["blendability"]["score"] is None and d["blendability"]["blendable"] is False
    assert "cannot be measured" in r.stdout + r.stderr


def test_cli_register_writes_the_documented_json(mocap, tmp_path):
    a = mocap / DAZ / "07_01.bvh"
    b = mocap / DAZ / "09_01.bvh"
    out = tmp_path / "reg.json"
    cmd = [sys.executable, "-m", "mjmotion.cli", "register", str(a), str(b), "--frames", "4:", "--json", str(out)]
    cmd += ["--plot", str(tmp_path / "g.png")]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    d = json.loads(out.read_text())
    assert set(d) >= {"frames", "path", "path_cost", "mean_cost", "timewarp", "alignment", "timing_s", "blendability"}
    assert d["blendability"]["blendable"] is True and "blendability 0." in r.stdout
    assert d["frames"] == [313, 145]
    tw = np.array(d["timewarp"])
    assert np.all(np.diff(tw, axis=0) > 0) and len(d["alignment"]) == len(tw)
    assert (tmp_path / "g.png").stat().st_size > 1000
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert again.returncode == 2 and again.stderr.startswith("error:") and "--force" in again.stderr
    bad = subprocess.run(cmd[:-4] + ["--json", str(tmp_path / "x.json"), "--window", "4"], capture_output=True, text=True)
    assert bad.returncode == 2 and "odd" in bad.stderr


def test_cli_area_threshold_reaches_the_dp_optimum_and_method_options_go_with_their_method(tmp_path, capsys):
    """The threshold search's error said "raise the threshold" with no option to do it, and options of
    another method (--time-limit with dp, --free-end with --loop or greedy) were ignored, the same path
    coming back. --area-threshold ≥ 1 prunes nothing: the DP optimum (threshold_path's doc)."""
    from mjmotion import bvh, synth
    from mjmotion.cli import main

    a, b = tmp_path / "walk.bvh", tmp_path / "run.bvh"
    bvh.write(synth.walk(seconds=2.0).motion, a)
    bvh.write(synth.run(seconds=2.0).motion, b)

    def path(*extra: str) -> list:
        out = tmp_path / "r.json"
        assert main(["register", str(a), str(b), "--json", str(out), "--force", *extra]) == 0
        return json.loads(out.read_text())["path"]

    assert path("--loop", "--method", "threshold", "--area-threshold", "2") == path("--loop")
    assert main(["register", str(a), str(b), "--json", str(tmp_path / "t.json"), "--loop", "--method", "threshold"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {a} and {b}: no path reaches the end") and "--area-threshold" in err, err
    for extra, says in (
        (["--time-limit", "5"], "--time-limit 5: bounds the brute search; give it with --method brute"),
        (["--area-threshold", "0.5"], "--area-threshold 0.5: bounds the threshold search"),
        (["--loop", "--free-end", "mean"], "--free-end mean: --loop fixes both ends"),
        (["--method", "greedy", "--free-end", "mean"], "--free-end mean: greedy"),
    ):
        assert main(["register", str(a), str(b), "--json", str(tmp_path / "x.json"), *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {says}") and err.count("\n") == 1, err
    assert not (tmp_path / "x.json").exists() and not (tmp_path / "t.json").exists()


def test_register_refuses_a_window_start_or_positions_that_are_no_setting():
    """A window of 10**6 asked for 159 GiB (2.5: a raw TypeError), a start of (500, 0) was "argmin of an
    empty sequence" and (-1, 0) wrapped to the last row, and NaN positions read "no path joins the corners"."""
    from mjmotion import registration, synth

    walk, run = synth.walk(seconds=1.0).motion, synth.run(seconds=1.0).motion
    for kwargs, message in (
        (dict(window=10**6), "window=1000000: expected a half-window L"),
        (dict(window=2.5), "window=2.5: expected a half-window L"),
        (dict(start=(500, 0)), r"start=\(500, 0\): expected a cell \(i, j\) of the 61×61 grid"),
        (dict(start=(-1, 0)), r"start=\(-1, 0\): expected a cell"),
        (dict(start=(0, 0, 0)), r"start=\(0, 0, 0\): expected a cell"),
        (dict(positions=(np.full((61, 22, 3), np.nan), np.zeros((61, 22, 3)))), r"positions\[0\]: expected finite joint positions"),
        (dict(positions=(np.zeros((61, 22, 3)), np.zeros((5, 3)))), r"positions\[1\]: expected finite joint positions of shape \(61, 22, 3\)"),
    ):
        with pytest.raises(MjmotionError, match=message):
            registration.register(walk, run, **kwargs)
