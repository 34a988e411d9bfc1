"""Joint ranges: classes from structure and names, defaults, widenings, and the shared clips inside them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import clip_params, require_data, shared_clip

from mjmotion import bvh, limits, mjcf
from mjmotion import rotations as rot
from mjmotion.trim import leading_transient


def test_asf_classes_follow_the_legs_arms_and_names():
    skel = shared_clip("cmu_asfamc_converted/16_15.bvh").skeleton
    cls = dict(zip(skel.names, limits.joint_classes(skel)))
    assert cls["root"] == "root"
    assert [cls[n] for n in ("lfemur", "ltibia", "lfoot", "ltoes")] == ["hip", "knee", "ankle", "toe"]
    assert [cls[n] for n in ("lclavicle", "lhumerus", "lradius", "lwrist", "lhand", "lthumb")] == [
        "girdle", "shoulder", "elbow", "wrist", "finger", "finger",
    ]  # fmt: skip
    assert cls["lowerneck"] == "neck" and cls["head"] == "head" and cls["lowerback"] == "spine"
    lim = dict(zip(skel.names, limits.joint_limits(skel)))
    assert math.isinf(lim["root"]) and lim["ltibia"] == pytest.approx(math.radians(limits.DEFAULT_DEGREES["knee"]))
    assert lim["lhand"] == pytest.approx(math.pi)  # widened: 64_03 holds the ASF hand at a half turn


def test_daz_and_iclone_classes():
    daz = shared_clip("cmu_cgspeed_daz/07_01.bvh").skeleton
    cls = dict(zip(daz.names, limits.joint_classes(daz)))
    assert [cls[n] for n in ("rThigh", "rShin", "rFoot", "rShldr", "rForeArm", "rHand", "rIndex1", "leftEye")] == [
        "hip", "knee", "ankle", "shoulder", "elbow", "wrist", "finger", "eye",
    ]  # fmt: skip
    ic = shared_clip("cmu_iclone_ccrig/007_04.bvh").skeleton
    cls = dict(zip(ic.names, limits.joint_classes(ic)))
    assert cls["CC_Base_L_Calf"] == "knee" and cls["CC_Base_L_ThighTwist01"] == "helper" and cls["CC_Base_NeckTwist01"] == "neck"
    lim = dict(zip(ic.names, limits.joint_limits(ic)))
    assert lim["CC_Base_L_Thigh"] == pytest.approx(math.pi)  # the iClone thigh's bind rotation


def test_a_widening_never_narrows_and_matches_exact_names():
    assert limits.widening("lhand") is not None and limits.widening("lHand") is None  # daz hands keep the wrist default
    for w in limits.WIDENED:
        assert 0 < w.degrees <= 180 and w.clip and w.reason


@pytest.mark.parametrize("path", clip_params())
def test_every_shared_clip_stays_inside_its_ranges(path):
    if path is None:
        require_data()
    m = bvh.read(path)
    m = m[leading_transient(m) :]
    if m.name == "007_04":
        m = m[1:]  # SOURCES.md: frame 0 is a rest pose at another root position
    over = limits.violations(m.skeleton, m.rotations)
    bad = [m.skeleton.names[j] for j in np.flatnonzero(over.any(axis=0))]
    assert not bad, bad


def test_compiled_ball_joints_declare_the_ranges():
    skel = shared_clip("cmu_cgspeed_daz/07_01.bvh").skeleton
    c = mjcf.compile(skel)
    want = limits.joint_limits(skel)
    import mujoco

    for j, name in enumerate(skel.names[1:], 1):
        jid = mujoco.mj_name2id(c.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        assert c.model.jnt_limited[jid] and c.model.jnt_range[jid] == pytest.approx([0.0, want[j]])
    root = mujoco.mj_name2id(c.model, mujoco.mjtObj.mjOBJ_JOINT, skel.names[0])
    assert not c.model.jnt_limited[root]


def test_violations_see_a_knee_turned_beyond_its_range():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh", 2)[:50]
    j = m.skeleton.index("ltibia")
    q = m.rotations.copy()
    q[10, j] = rot.exp(np.array([math.radians(170.0), 0.0, 0.0]))
    over = limits.violations(m.skeleton, q)
    assert over[10, j] and over.sum() == 1
    assert np.allclose(limits.rotation_angles(q[10, j]), math.radians(170.0))


def test_within_eases_a_joint_that_leaves_its_range_back_inside_and_keeps_the_rest():
    """vary's exaggerated variants turned wrists and shoulders past their ranges (10_02 ×1.3: lhumerus
    161.8° > 160°). ``within`` brings such a joint inside, smoothly, about the same axis, and keeps every
    joint that stays in range and every angle well inside it exactly."""
    m = shared_clip("cmu_asfamc_converted/16_15.bvh", 2)[:200]
    knee = m.skeleton.index("ltibia")
    lim = limits.joint_limits(m.skeleton)[knee]
    assert limits.within(m.skeleton, m.rotations).tobytes() == m.rotations.tobytes()  # a clip in range: unchanged
    axis = np.array([0.6, 0.0, 0.8])
    theta = np.linspace(0.0, lim + math.radians(30.0), m.n_frames)  # a knee swept 30° past its end
    q = m.rotations.copy()
    q[:, knee] = rot.exp(theta[:, None] * axis)
    q[5, knee] *= -1.0  # (the same rotation, w < 0)
    got = limits.within(m.skeleton, q)
    angle = limits.rotation_angles(got[:, knee])
    assert not limits.violations(m.skeleton, got).any() and angle.max() < lim
    inside = theta <= lim - limits.EASE
    assert np.array_equal(got[:, np.arange(m.skeleton.n_joints) != knee], q[:, np.arange(m.skeleton.n_joints) != knee])
    assert np.array_equal(got[inside, knee], q[inside, knee])
    # the same axis, a monotone angle with no kink: its slope in θ falls smoothly from 1 towards 0
    back = rot.log(got[1:, knee])  # (frame 0 is the identity: no axis)
    assert np.allclose(back / np.linalg.norm(back, axis=1, keepdims=True), axis, atol=1e-9)
    slope = np.diff(angle) / np.diff(theta)
    assert np.all(slope > 0) and np.all(slope <= 1 + 1e-9) and np.max(np.abs(np.diff(slope))) < 0.1  # (a clamp: 1)
