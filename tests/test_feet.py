"""Sole points calibrated from stance: flat on the floor at mid-stance whatever the rest pose."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_clip

from mjmotion import feet, kinematics, mjcf
from mjmotion import rotations as rot


@pytest.mark.parametrize("rel", ["cmu_asfamc_converted/16_15.bvh", "cmu_iclone_ccrig/007_04.bvh", "cmu_cgspeed_daz/07_01.bvh"])
def test_soles_lie_flat_at_mid_stance(rel):
    """At the quiet stance frames the calibration used, each foot's heel and ball points are level
    (within 1.5 cm) — the compiled boxes stand on an edge there for iClone (tilted ~70°)."""
    m = shared_clip(rel)[4:]
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    soles = feet.calibrate_soles(m.skeleton, [(pose, m.fps)])
    assert soles.calibrated and soles.local.shape[1] in (4, 6)
    pts = feet.sole_points(soles, pose)  # (T, F, P, 3)
    for f, (ankle, _) in enumerate(m.skeleton.feet()[s] for s in soles.sides):
        z = pose.joint_positions[:, ankle, 2]
        v = np.linalg.norm(np.gradient(pose.joint_positions[:, ankle, :2], axis=0), axis=1)
        low = z <= np.quantile(z, 0.4)
        quiet = low & (v <= np.quantile(v[low], 0.25))
        spread = np.ptp(pts[quiet, f, :4, 2], axis=1)
        assert np.median(spread) < 0.015, np.median(spread)
        # The sole is ANKLE_HEIGHT x stature below the ankle along its normal (or deeper).
        depth = -(soles.local[f, :4] @ soles.normals[f])
        assert depth.min() >= mjcf.ANKLE_HEIGHT * m.skeleton.stature() - 1e-9


def test_rest_pose_soles_for_a_clip_too_short_to_calibrate():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[100:110]
    c = mjcf.compile(m.skeleton)
    soles = feet.calibrate_soles(m.skeleton, [(kinematics.forward(c, m), m.fps)])
    assert not soles.calibrated
    assert np.allclose(soles.normals, soles.normals[0]) and soles.normals[0] @ [0, 0, 1] > 0.9


def test_lowest_heights_equal_the_lowest_points():
    m = shared_clip("cmu_iclone_ccrig/002_01.bvh")[:40]
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    assert np.allclose(feet.lowest_heights(c, pose, c.body_geom_ids), feet.lowest_points(c, pose, c.body_geom_ids)[..., 2], atol=1e-12)


def test_a_track_moved_to_another_floor_shifts_heights_only():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[2:200]
    tr = feet.foot_heights_speeds(None, m, floor=0.0)
    up = tr.at_floor(0.02)
    assert np.allclose(up.heights, tr.heights - 0.02) and np.array_equal(up.speeds, tr.speeds)
    q = rot.exp(np.array([0.0, 0.0, 0.3]))
    assert q.shape == (4,)
