"""MuJoCo forward kinematics against an independent NumPy FK, and site Jacobians by finite differences."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import clip_params, random_motion, random_skeleton, require_data
from reference_fk import file_to_world, reference_fk

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot


@pytest.mark.parametrize("path", clip_params())
def test_mujoco_fk_matches_numpy_fk_on_shared_clip(path):
    if path is None:
        require_data()
    text = path.read_text()
    motion = bvh.read(path)
    names, ref = reference_fk(text)
    assert list(motion.skeleton.names) == names
    ref_world = file_to_world(ref, motion.skeleton.scale)
    pose = kinematics.forward(mjcf.compile(motion.skeleton), motion)
    err = np.abs(pose.joint_positions - ref_world).max()
    assert err <= 1e-9 * motion.skeleton.stature(), f"max FK difference {err} m"


@pytest.mark.parametrize("seed", range(6))
def test_mujoco_fk_matches_numpy_fk_on_random_skeleton(seed):
    rng = np.random.default_rng(seed)
    skel = random_skeleton(rng, n_joints=int(rng.integers(2, 25)))
    motion = random_motion(rng, skel, n_frames=15)
    text = bvh.format_motion(motion)
    names, ref = reference_fk(text)
    # Written in metres and Z up (the random skeleton's own units): no mapping needed.
    pose = kinematics.forward(mjcf.compile(skel), bvh.parse(text, "random.bvh", scale=1.0, up="z"))
    assert np.abs(pose.joint_positions - ref).max() < 1e-9
    # And the in-memory motion itself agrees to the six written decimals.
    direct = kinematics.forward(mjcf.compile(skel), motion)
    assert np.abs(direct.joint_positions - ref).max() < 1e-5


def test_fk_world_orientation_composes_local_rotations():
    rng = np.random.default_rng(3)
    skel = random_skeleton(rng, 8, inner_positions=False)
    motion = random_motion(rng, skel, 5)
    pose = kinematics.forward(mjcf.compile(skel), motion)
    for j in range(1, skel.n_joints):
        p = skel.parents[j]
        expect = rot.multiply(pose.joint_rotations[:, p], motion.rotations[:, j])
        assert np.allclose(rot.angle_between(expect, pose.joint_rotations[:, j]), 0.0, atol=1e-7)


def test_site_jacobian_matches_finite_differences():
    rng = np.random.default_rng(11)
    skel = random_skeleton(rng, 10, inner_positions=True)
    motion = random_motion(rng, skel, 1)
    prop = mjcf.default_prop(skel, "club", skel.names[5])
    compiled = mjcf.compile(skel, [prop])
    q0 = kinematics.qpos(compiled, motion)[0]
    jacp, _ = kinematics.site_jacobian(compiled, q0, prop.site)
    m = compiled.model
    sid = compiled.site_id(prop.site)

    def site_pos(q):
        d = mujoco.MjData(m)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        return d.site_xpos[sid].copy()

    eps = 1e-6
    num = np.zeros((3, m.nv))
    for k in range(m.nv):
        dv = np.zeros(m.nv)
        dv[k] = eps
        qp, qm = q0.copy(), q0.copy()
        mujoco.mj_integratePos(m, qp, dv, 1.0)
        mujoco.mj_integratePos(m, qm, -dv, 1.0)
        num[:, k] = (site_pos(qp) - site_pos(qm)) / (2 * eps)
    assert np.abs(num - jacp).max() < 1e-6


def test_qpos_places_ball_and_root(mocap):
    motion = bvh.read(mocap / "cmu_asfamc_converted" / "64_01.bvh")[:10]
    compiled = mjcf.compile(motion.skeleton, (), mjcf.Ball(position=(1.0, 2.0, 0.3)))
    q = kinematics.qpos(compiled, motion)
    assert np.allclose(q[:, :3], motion.root_positions)
    a = compiled.ball_qpos_adr
    assert np.allclose(q[:, a : a + 3], [1.0, 2.0, 0.3])
    pose = kinematics.forward(compiled, q)
    assert np.allclose(pose.joint_positions[:, 0], motion.root_positions)
