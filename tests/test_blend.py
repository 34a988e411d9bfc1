"""Blending: weights, exact reproduction at weight 1, walk/run blends against the linear baseline."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from mjmotion import blend as B
from mjmotion import bvh, evaluate, kinematics, transform
from mjmotion import registration as R
from mjmotion.errors import MjmotionError, SkeletonMismatchError

DAZ = "cmu_cgspeed_daz"
WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def _clip(mocap, name: str):
    return bvh.read(str(mocap / DAZ / f"{name}.bvh"))[4:]  # frames 0-3: T-pose (SOURCES.md)


@pytest.fixture(scope="module")
def walk_run():
    from conftest import require_data

    d = require_data()
    walk, run = _clip(d, "07_01"), _clip(d, "09_01")
    reg = R.register_many([walk, run], reference=0)
    reg_blends = {w: B.blend([walk, run], [1 - w, w], registration=reg) for w in WEIGHTS}
    lin_blends = {w: B.blend([walk, run], [1 - w, w], method="linear") for w in WEIGHTS}
    return walk, run, reg_blends, lin_blends


def mean_speed(m) -> float:
    """Horizontal root path length over duration, m/s."""
    return float(np.linalg.norm(np.diff(m.root_positions[:, :2], axis=0), axis=1).sum() / m.duration)


def steps_per_s(m) -> float:
    """Cadence from swing peaks of both feet (each step lifts a foot once), steps/s."""
    track = evaluate.foot_heights_speeds(None, m)
    peaks = np.sort(
        np.concatenate([signal.find_peaks(track.heights[:, f], prominence=0.05, distance=int(0.2 * m.fps))[0] for f in range(track.heights.shape[1])])
    )
    if len(peaks) < 2:
        return float("nan")
    return (len(peaks) - 1) / ((peaks[-1] - peaks[0]) / m.fps)


# --------------------------------------------------------------------------- weights
def test_weights_must_sum_to_one_and_be_non_negative():
    assert B.check_weights([0.25, 0.75], 2) == pytest.approx([0.25, 0.75])
    with pytest.raises(MjmotionError, match="sum to 1.1"):
        B.check_weights([0.5, 0.6], 2)
    with pytest.raises(MjmotionError, match="non-negative"):
        B.check_weights([1.5, -0.5], 2)
    with pytest.raises(MjmotionError, match="expected 3 weights"):
        B.check_weights([0.5, 0.5], 3)


def test_bezier_weight_curve_is_smooth_monotone_and_sums_to_one():
    s = np.linspace(0, 1, 101)
    e = B.bezier_ease(s)
    assert e[0] == 0 and e[-1] == 1 and np.all(np.diff(e) >= 0)
    assert np.gradient(e, s)[[0, -1]] == pytest.approx([0, 0], abs=0.05)  # zero slope at the ends
    curve = B.WeightCurve(((0.0, 0.0, np.array([1.0, 0, 0])), (1.0, 0.5, np.array([0, 0.5, 0.5])), (1.2, 0.5, np.array([0, 0, 1.0]))))
    w = curve(np.linspace(0, 3, 61))
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    np.testing.assert_allclose(w[0], [1, 0, 0])
    np.testing.assert_allclose(w[-1], [0, 0, 1])
    assert np.all(np.abs(np.diff(w, axis=0)) < 0.2)  # no step change


# --------------------------------------------------------------------------- exactness
def test_weight_one_reproduces_the_clip_up_to_a_floor_move(walk_run):
    walk, run, reg_blends, lin_blends = walk_run
    for w, clip in ((0.0, walk), (1.0, run)):
        b = reg_blends[w]
        pb = kinematics.joint_positions(b)
        # which frames of the clip were used: the registration's span, one frame per output frame
        pc = kinematics.joint_positions(clip)
        start = int(np.argmin([np.abs((pc[k] - pc[k, :1]) - (pb[0] - pb[0, :1])).max() for k in range(len(pc))]))
        seg = pc[start : start + b.n_frames]
        n = len(seg)
        theta, tx, ty = R.rigid_2d(pb[None, :n].reshape(1, -1, 3), seg[None].reshape(1, -1, 3), np.ones(n * pc.shape[1]))[0]
        moved = kinematics.joint_positions(transform.floor_transform(clip, theta, (tx, ty)))[start : start + n]
        assert np.abs(moved - pb[:n]).max() < 1e-4
    lin = lin_blends[0.0]
    np.testing.assert_allclose(kinematics.joint_positions(lin), kinematics.joint_positions(walk[: lin.n_frames]), atol=1e-6)


def test_weight_one_plays_the_registered_span_to_its_last_frame():
    """With weight 1 on one clip the blend plays every frame of the span the registration covers, the last
    included (the spline meets its end node to ~1e-6 frames, and a clock 3e-6 short dropped it)."""
    from mjmotion import synth

    walk, run = synth.walk(seconds=2).motion, synth.run(seconds=2).motion
    reg = R.register_many([walk, run])
    for k, w in ((0, [1.0, 0.0]), (1, [0.0, 1.0])):
        first, last = np.round(reg.times[[0, -1], k]).astype(int)
        assert B.blend([walk, run], w, registration=reg).n_frames == last - first + 1


def test_same_topology_different_bone_lengths_blends_on_first_skeleton(mocap):
    walk = _clip(mocap, "07_01")[:150]
    big = walk.replace(skeleton=walk.skeleton.with_offsets(walk.skeleton.offsets * 1.1), root_positions=walk.root_positions * 1.1)
    b = B.blend([walk, big], [0.5, 0.5])
    assert b.skeleton is walk.skeleton
    assert b.n_frames > 100


def test_different_topology_refused(mocap):
    walk = _clip(mocap, "07_01")
    asf = bvh.read(str(mocap / "cmu_asfamc_converted" / "16_15.bvh"))
    for method in ("registered", "linear"):
        with pytest.raises(SkeletonMismatchError):
            B.blend([walk, asf], [0.5, 0.5], method=method)


# --------------------------------------------------------------------------- walk/run
def test_blend_speeds_increase_with_run_weight_between_the_inputs(walk_run):
    walk, run, reg_blends, _ = walk_run
    speeds = [mean_speed(reg_blends[w]) for w in WEIGHTS]
    assert np.all(np.diff(speeds) > 0), speeds
    lo, hi = mean_speed(walk), mean_speed(run)
    assert speeds[0] == pytest.approx(lo, rel=0.05) and speeds[-1] == pytest.approx(hi, rel=0.05)
    assert all(lo < s < hi for s in speeds[1:-1])


def test_registered_blends_skate_less_than_linear_and_keep_the_rhythm(walk_run):
    walk, run, reg_blends, lin_blends = walk_run
    lo, hi = sorted((steps_per_s(walk), steps_per_s(run)))
    cadence = []
    for w in WEIGHTS[1:-1]:
        reg_skate = evaluate.skate_mm_per_s(reg_blends[w])
        lin_skate = evaluate.skate_mm_per_s(lin_blends[w])
        assert reg_skate < lin_skate, f"w={w}: registered {reg_skate:.0f} mm/s vs linear {lin_skate:.0f} mm/s"
        cadence.append(steps_per_s(reg_blends[w]))
        assert lo <= cadence[-1] <= hi, f"w={w}: {cadence[-1]:.2f} steps/s outside [{lo:.2f}, {hi:.2f}]"
    assert np.all(np.diff(cadence) > 0)


def test_three_way_blend(mocap):
    walk, run = _clip(mocap, "07_01"), _clip(mocap, "09_01")
    slow = transform.timewarp(walk, lambda i: 0.75 * i, int((walk.n_frames - 1) / 0.75))
    b = B.blend([walk, slow, run], [0.4, 0.3, 0.3])
    speeds = sorted(mean_speed(m) for m in (walk, slow, run))
    assert speeds[0] < mean_speed(b) < speeds[-1]
    assert b.skeleton is walk.skeleton and b.fps == walk.fps


def test_time_varying_weights(mocap):
    walk, run = _clip(mocap, "07_01"), _clip(mocap, "09_01")
    curve = B.WeightCurve(((0.0, 0.0, np.array([1.0, 0.0])), (0.3, 0.6, np.array([0.0, 1.0]))))
    b = B.blend([walk, run], curve)
    v = np.linalg.norm(np.diff(b.root_positions[:, :2], axis=0), axis=1) * b.fps
    n = int(0.3 * b.fps)
    assert v[: n - 10].mean() < 0.7 * v[-30:].mean()  # walks first, runs at the end
    assert evaluate.root_jump_m(b, [walk, run]) <= 1e-9


# --------------------------------------------------------------------------- CLI
def test_cli_blend(mocap, tmp_path):
    a, b = mocap / DAZ / "07_01.bvh", mocap / DAZ / "09_01.bvh"
    out = tmp_path / "jog.bvh"
    base = [sys.executable, "-m", "mjmotion.cli", "blend", str(a), str(b), "--frames", "4:"]
    r = subprocess.run(base + ["--weights", "0.5,0.5", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    m = bvh.read(str(out))
    assert mean_speed(m) == pytest.approx(mean_speed(B.blend([_clip(mocap, "07_01"), _clip(mocap, "09_01")], [0.5, 0.5])), rel=0.02)
    bad = subprocess.run(base + ["--weights", "0.5,0.6", "-o", str(tmp_path / "x.bvh")], capture_output=True, text=True)
    assert bad.returncode == 2 and "sum to 1" in bad.stderr and "Traceback" not in bad.stderr


def test_a_still_clip_blended_with_itself_by_registration_keeps_its_length():
    """Every frame of a still clip matches every other: the registration's free end took the first of
    the equal ends and the blend had 59 of the clip's 120 frames."""
    from mjmotion import synth

    w = synth.walk(seconds=1.0).motion
    still = w.replace(root_positions=np.repeat(w.root_positions[:1], 120, 0), rotations=np.repeat(w.rotations[:1], 120, 0))
    out = B.blend([still, still], [0.5, 0.5], method="registered")
    assert out.n_frames == still.n_frames
    np.testing.assert_allclose(out.root_positions, still.root_positions, atol=1e-9)
