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
