"""The data model: slicing, sampling, resampling, scale detection and named parts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import random_motion, random_skeleton

from mjmotion import bvh
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError
from mjmotion.skeleton import ASF_UNIT, CM, METRE, MM, Motion, detect_scale, side_of


def _motion(n=30, fps=30.0):
    rng = np.random.default_rng(0)
    skel = random_skeleton(rng, 6, inner_positions=False)
    return random_motion(rng, skel, n).replace(fps=fps)


def test_slice_keeps_frames_and_fps():
    m = _motion()
    s = m[5:15]
    assert s.n_frames == 10 and s.fps == m.fps
    assert np.array_equal(s.rotations, m.rotations[5:15])
    assert m[::2].fps == m.fps / 2
    with pytest.raises(MjmotionError, match="empty"):
        m[20:10]


def test_sample_at_integer_frames_is_exact_and_midpoints_are_geodesic():
    m = _motion()
    root, q, _ = m.sample(np.arange(m.n_frames, dtype=float))
    assert np.allclose(root, m.root_positions)
    assert np.allclose(np.abs(np.sum(q * m.rotations, -1)), 1.0)
    _, mid, _ = m.sample(np.array([3.5]))
    a, b = m.rotations[3], m.rotations[4]
    # The midpoint is equally far (in angle) from both ends and half the total angle.
    da, db = rot.angle_between(mid[0], a), rot.angle_between(mid[0], b)
    assert np.allclose(da, db) and np.allclose(da + db, rot.angle_between(a, b))


def test_resample_preserves_duration_and_poses_at_shared_times():
    m = _motion(n=31, fps=30.0)
    up = m.resample(60.0)
    assert up.n_frames == 61 and up.fps == 60.0
    assert np.allclose(up.root_positions[::2], m.root_positions)
    assert np.allclose(np.abs(np.sum(up.rotations[::2] * m.rotations, -1)), 1.0)
    down = m.resample(10.0)
    assert down.n_frames == 11
    assert np.allclose(down.root_positions, m.root_positions[::3])


def test_resample_keeps_the_last_frame_of_a_rounded_frame_time(mocap):
    """Issue 18.7: 16_16's Frame Time 0.00833333 reads as 120.00005 fps; at 120 fps it keeps all
    510 frames (flooring the duration dropped one), each within a hair of the source's pose."""
    m = bvh.read(str(mocap / "cmu_asfamc_converted" / "16_16.bvh"))
    assert m.n_frames == 510 and m.fps != 120.0
    r = m.resample(120.0)
    assert r.n_frames == 510
    np.testing.assert_allclose(r.root_positions, m.root_positions, atol=1e-5)
    # a 12-frame clip whose frame time rounds 1/15 s down (0.0666666) keeps 12 frames at 15 fps
    short = _motion(n=12).replace(fps=1 / 0.0666666)
    assert short.resample(15.0).n_frames == 12


@pytest.mark.parametrize("fps", [7.0, 10.0, 24.0, 25.0, 29.97, 50.0, 59.94, 60.0, 119.88])
@pytest.mark.parametrize("rounding", [1.0, 1 - 4e-7, 1 + 4e-7])  # the clip's rate as a rounded frame time reads it
def test_resample_keeps_the_duration_to_within_one_output_frame(fps, rounding):
    m = _motion(n=31, fps=30.0 * rounding)
    r = m.resample(fps)
    assert -1.0 / fps < r.duration - m.duration <= 1e-4 * m.duration
    assert np.allclose(r.root_positions[0], m.root_positions[0])
    if fps in (10.0, 60.0):  # a whole number of output frames, whatever the rounding: all of them, the last the clip's last
        assert r.n_frames == round(m.duration * fps) + 1
        assert np.allclose(r.root_positions[-1], m.root_positions[-1], atol=1e-4)


def test_motion_validates_shapes_and_fps():
    m = _motion()
    with pytest.raises(MjmotionError):
        Motion(m.skeleton, 30.0, m.root_positions[:-1], m.rotations)
    with pytest.raises(MjmotionError, match="fps"):
        m.replace(fps=0.0)


@pytest.mark.parametrize(
    "extent, scale",
    [(1.7, METRE), (30.0, ASF_UNIT), (170.0, CM), (1700.0, MM)],
)
def test_detect_scale(extent, scale):
    assert detect_scale(extent) == scale


def test_detect_scale_refuses_ambiguous_sizes():
    # the option that gives a file's unit is --units (convert's --scale rescales what it writes)
    with pytest.raises(MjmotionError, match="give it with --units") as e:
        detect_scale(5.0)
    assert "--scale" not in str(e.value)


def test_detected_units_of_shared_flavours(mocap):
    assert bvh.read(mocap / "cmu_asfamc_converted" / "16_15.bvh").skeleton.scale == CM
    assert bvh.read(mocap / "cmu_cgspeed_max" / "131_01.bvh").skeleton.scale == ASF_UNIT
    assert bvh.read(mocap / "cmu_cgspeed_max" / "scaled_131_01.bvh").skeleton.scale == METRE
    # The same motion in ASF units and in metres gives the same world positions.
    a = bvh.read(mocap / "cmu_cgspeed_max" / "131_01.bvh")
    b = bvh.read(mocap / "cmu_cgspeed_max" / "scaled_131_01.bvh")
    assert np.allclose(a.skeleton.offsets, b.skeleton.offsets, atol=2e-5)


@pytest.mark.parametrize(
    "name, side",
    [("LeftHand", "left"), ("lhumerus", "left"), ("lHand", "left"), ("CC_Base_L_Foot", "left"),
     ("RightAnkle", "right"), ("rtibia", "right"), ("rShldr", "right"), ("lowerback", None), ("root", None),
     ("Hips", None), ("RHipJoint", "right")],
)  # fmt: skip
def test_side_of(name, side):
    assert side_of(name) == side


def test_feet_and_hands_on_every_flavour(mocap):
    expect = {
        "cmu_asfamc_converted/16_15": ("lfoot", "ltoes", "rwrist"),
        "cmu_cgspeed_daz/07_01": ("lFoot", None, "rHand"),
        "cmu_cgspeed_max/131_01": ("LeftAnkle", "LeftToe", "RightWrist"),
        "cmu_iclone_ccrig/002_05": ("CC_Base_L_Foot", "CC_Base_L_ToeBase", "CC_Base_R_Hand"),
    }
    for clip, (ankle, toe, hand) in expect.items():
        s = bvh.read(mocap / f"{clip}.bvh").skeleton
        a, t = s.feet()["left"]
        assert s.names[a] == ankle and (t is None if toe is None else s.names[t] == toe)
        assert s.names[s.hands()["right"]] == hand
        assert 1.4 < s.stature() < 2.0


def test_descendants_of_a_random_tree_match_the_parent_walk():
    rng = np.random.default_rng(7)
    skel = random_skeleton(rng, 30)
    for j in range(skel.n_joints):
        below = []
        for c in range(skel.n_joints):
            k = c
            while k > j:
                k = int(skel.parents[k])
            if k == j and c != j:
                below.append(c)
        assert skel.descendants(j) == below


def test_a_motion_checks_its_values_and_keeps_its_arrays_read_only():
    """A NaN or a zero quaternion is refused naming its frame and joint (a NaN went on into every metric as nan, a
    zero quaternion into SciPy's traceback on write); scaled quaternions are normalised; a result that shares
    arrays with its input cannot be written into (an adapted shot's root moved its source's too)."""
    from mjmotion import synth

    walk = synth.walk(seconds=1).motion
    q = walk.rotations.copy()
    q[5, 3, 0] = np.nan
    with pytest.raises(MjmotionError, match=rf"rotations at frame 5, joint '{walk.skeleton.names[3]}' is nan"):
        walk.replace(rotations=q)
    q = walk.rotations.copy()
    q[7, 2] = 0.0
    with pytest.raises(MjmotionError, match=rf"frame 7, joint '{walk.skeleton.names[2]}' is a zero quaternion"):
        walk.replace(rotations=q)
    rp = walk.root_positions.copy()
    rp[3, 2] = np.inf
    with pytest.raises(MjmotionError, match="root_positions at frame 3 is inf"):
        walk.replace(root_positions=rp)
    with pytest.raises(MjmotionError, match="at least one frame"):
        walk.replace(rotations=walk.rotations[:0], root_positions=walk.root_positions[:0])
    scaled = walk.replace(rotations=walk.rotations * 3.0)
    np.testing.assert_allclose(scaled.rotations, walk.rotations, atol=1e-15)
    moved = walk.replace(name="moved")  # shares the arrays
    with pytest.raises(ValueError, match="read-only"):
        moved.root_positions[:, 2] += 1.0
    assert type(walk.replace(fps=np.float64(29.97)).fps) is float
    # The skeleton too: clips and their results share it (an edit of a walk's offsets changed a jog
    # blended from it earlier), and it keeps its own copy of the arrays it was made from.
    for key in ("parents", "offsets", "end_parents", "end_offsets"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(moved.skeleton, key)[0] = getattr(moved.skeleton, key)[0]
    given = walk.skeleton.offsets.copy()
    own = dataclasses.replace(walk.skeleton, offsets=given)
    given[3] *= 2.0
    np.testing.assert_array_equal(own.offsets, walk.skeleton.offsets)


def test_api_misuse_is_a_clear_error_not_a_traceback():
    """Each of these raised a raw IndexError, ValueError, TypeError or AttributeError from inside."""
    from mjmotion import blend, evaluate, hitpoint, registration, synth, transform

    walk, run = synth.walk(seconds=1).motion, synth.run(seconds=1).motion
    cases = [
        (lambda: walk.sample(np.array([np.nan])), "finite frame numbers"),
        (lambda: transform.timewarp(walk, lambda i: i * 1.0, 0), "at least one frame"),
        (lambda: registration.register_many([walk, run], reference=5), r"reference 5: expected the index of one of the 2 clips"),
        (lambda: registration.register_many([walk, run], reference=-1), "reference -1"),
        (lambda: blend.blend([walk, run], "0.5,0.5"), "expected 2 numbers"),
        (lambda: blend.blend([walk, run], [[0.5, 0.5]]), r"expected 2 weights \(one per clip, a flat list\), got \[\[0.5, 0.5\]\]"),
        (lambda: blend.blend(walk, [1.0]), "blend: expected a list of Motions"),
        (lambda: evaluate.evaluate("walk.bvh"), "evaluate: expected a Motion .* got str"),
        (lambda: bvh.read("walk.bvh", scale="cm"), "scale='cm': expected metres per file unit as a number"),
        (lambda: evaluate.evaluate(walk, sources=walk), "a list of Motions"),
        (lambda: bvh.write("walk", "never.bvh"), "expected a Motion to write, got str"),
        (lambda: blend.WeightCurve(((0.0, 0.0, np.array([1.0, 0.0])), (1.0, -0.5, np.array([0.0, 1.0])))), r"weight key 1: .* ramp ≥ 0"),
        (lambda: blend.WeightCurve(((0.0, 0.0, np.array([1.0, 0.0])), (np.nan, 0.5, np.array([0.0, 1.0])))), "weight key 1: time nan"),
    ]
    drive = synth.drive()
    cases.append(
        (
            lambda: hitpoint.adapt(drive.motion, offset=np.array([0.1, 0.0]), frame=drive.hit_frame, prop=drive.prop, style=False),
            "offset: expected 3 finite numbers",
        )
    )
    for call, message in cases:
        with pytest.raises(MjmotionError, match=message):
            call()
