"""The NumPy FK (registration's positions) against MuJoCo's ``mj_kinematics`` (DESIGN: MuJoCo is the reference)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_motion, random_skeleton

from mjmotion import bvh, fk, kinematics


@pytest.mark.parametrize("seed", range(4))
def test_numpy_fk_equals_mujoco_on_random_skeletons_with_translations(seed):
    """Random trees with 6-channel inner joints; quaternions not of unit length (the motion normalises
    them when it is made) and per-frame translations on joints without position channels (MuJoCo ignores them)."""
    rng = np.random.default_rng(seed)
    skel = random_skeleton(rng, n_joints=int(rng.integers(3, 30)))
    m = random_motion(rng, skel, n_frames=12)
    tr = np.broadcast_to(skel.offsets, (12, skel.n_joints, 3)).copy() if m.translations is None else m.translations.copy()
    tr[:, [j for j in range(skel.n_joints) if not skel.has_positions(j)]] += 0.3  # not channels: ignored
    m = m.replace(rotations=m.rotations * rng.uniform(0.5, 2.0, (12, skel.n_joints, 1)), translations=tr)
    assert any(skel.has_positions(j) for j in range(1, skel.n_joints))  # the slide joints are exercised
    ours, ref = fk.joint_positions(m), kinematics.joint_positions(m)
    assert ours.shape == ref.shape == (12, skel.n_joints, 3)
    assert np.abs(ours - ref).max() < 1e-12


@pytest.mark.parametrize("rel", ["cmu_cgspeed_daz/05_01.bvh", "cmu_asfamc_converted/16_15.bvh", "cmu_iclone_ccrig/002_07.bvh"])
def test_numpy_fk_equals_mujoco_on_shared_clips(mocap, rel):
    m = bvh.read(str(mocap / rel))[:200]
    err = np.abs(fk.joint_positions(m) - kinematics.joint_positions(m)).max()
    assert err <= 1e-12 * m.skeleton.stature(), f"max FK difference {err} m"
