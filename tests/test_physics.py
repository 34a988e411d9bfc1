"""Inverse-dynamics residuals, ground-reaction checks, hitting metrics and the ball-launch simulation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import random_motion, random_skeleton, require_data

from mjmotion import bvh, kinematics, mjcf
from mjmotion import physics as ph
from mjmotion import rotations as rot
from mjmotion.skeleton import Motion


def _clip(rel: str) -> Motion:
    return bvh.read(require_data() / rel)


def test_difference_matches_mj_differentiate_pos():
    rng = np.random.default_rng(3)
    skel = random_skeleton(rng, 10)
    m = random_motion(rng, skel, 6)
    c = mjcf.compile(skel)
    q = kinematics.qpos(c, m)
    for t in range(5):
        ref = np.zeros(c.model.nv)
        mujoco.mj_differentiatePos(c.model, ref, 1.0, q[t], q[t + 1])
        assert np.allclose(ph.difference(c.model, q[t], q[t + 1]), ref, atol=1e-10)


def test_finite_differences_exact_for_quadratic_root_path():
    rng = np.random.default_rng(4)
    skel = random_skeleton(rng, 6, inner_positions=False)
    m = random_motion(rng, skel, 30)
    t = np.arange(30) / 60.0
    m = m.replace(rotations=np.broadcast_to(m.rotations[:1], m.rotations.shape).copy(), root_positions=np.outer(t**2, [1.0, -2.0, 3.0]))
    c = mjcf.compile(skel)
    for step in (1, 3):
        qvel, qacc = ph.finite_differences(c.model, kinematics.qpos(c, m), 60.0, step)
        assert np.allclose(qacc[:, :3], [2.0, -4.0, 6.0])
        assert np.allclose(qvel[step:-step, :3], np.outer(2 * t[step:-step], [1.0, -2.0, 3.0]))
        assert np.allclose(qacc[:, 3:], 0.0)


def _standing(n: int = 60) -> Motion:
    m = _clip("cmu_asfamc_converted/64_01.bvh")[50:51]
    return m.replace(root_positions=np.repeat(m.root_positions, n, 0), rotations=np.repeat(m.rotations, n, 0))


def test_static_pose_needs_body_weight_at_the_com():
    m = _standing(12)
    c = mjcf.compile(m.skeleton)
    f, tq = ph.inverse_wrench(c, m)
    weight = ph.total_mass(c) * ph.GRAVITY
    assert np.allclose(f, [0.0, 0.0, weight], atol=1e-6 * weight)
    d = mujoco.MjData(c.model)
    d.qpos[:] = kinematics.qpos(c, m)[0]
    mujoco.mj_forward(c.model, d)
    com = d.subtree_com[c.body_ids[0]]
    assert np.allclose(ph.centre_of_pressure(f, tq, m.root_positions), com[:2], atol=1e-6)
    r = ph.residuals(c, m)
    assert np.allclose(r.root_force_ratio, 1.0) and not r.flight.any()
    assert r.physics_violation_ratio == 0.0  # weight on the feet, CoP between them


def test_centre_of_pressure_of_a_known_point_force():
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.normal(size=(20, 2)), np.zeros(20)])
    force = rng.normal(size=(20, 3)) + [0, 0, 20.0]
    origin = rng.normal(size=(20, 3)) + [0, 0, 1.0]
    torque = np.cross(p - origin, force)
    assert np.allclose(ph.centre_of_pressure(force, torque, origin), p[:, :2])


def test_distance_to_hull():
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    assert ph.distance_to_hull(np.array([0.3, 0.6]), sq) == 0.0
    assert ph.distance_to_hull(np.array([1.5, 0.5]), sq) == pytest.approx(0.5)
    assert ph.distance_to_hull(np.array([2.0, 2.0]), sq) == pytest.approx(np.sqrt(2))
    line = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert ph.distance_to_hull(np.array([1.0, 0.3]), line) == pytest.approx(0.3)
    assert ph.distance_to_hull(np.array([3.0, 0.0]), line[:1]) == pytest.approx(3.0)


def test_lifted_mid_stance_gives_flight_residual_one():
    m = _clip("cmu_asfamc_converted/64_01.bvh")[:120]  # golf address: standing still
    c = mjcf.compile(m.skeleton)
    base = ph.residuals(c, m)
    assert not base.flight.any() and np.isnan(base.flight_residual)
    root = m.root_positions.copy()
    root[40:80, 2] += 0.2  # hovering 20 cm up, motionless: only an external force holds it
    r = ph.residuals(c, m.replace(root_positions=root))
    assert r.flight[41:80].all()
    assert r.flight_residual == pytest.approx(1.0, abs=0.1)
    assert r.violation[45:75].all()


def test_free_fall_needs_no_force():
    m = _standing(40)
    t = np.arange(40) / m.fps
    # Thrown upwards from 1 m: a ballistic root path with the pose held fixed.
    root = m.root_positions + np.outer(1.0 + 2.0 * t - 0.5 * ph.GRAVITY * t**2, [0, 0, 1])
    c = mjcf.compile(m.skeleton)
    r = ph.residuals(c, m.replace(root_positions=root))
    assert r.flight.all()
    assert r.flight_residual == pytest.approx(0.0, abs=1e-6)


def test_jump_flight_residual_near_zero():
    m = _clip("cmu_asfamc_converted/16_01.bvh")
    r = ph.residuals(mjcf.compile(m.skeleton), m)
    assert r.flight.sum() > 30
    assert r.flight_residual < 0.3
    # The take-off push: the contact frames just before flight need more than body weight.
    first = int(np.flatnonzero(r.flight)[0])
    assert r.root_force_ratio[first - 20 : first].max() > 1.5


# ----------------------------------------------------------------- hitting


def _face_poses(yaw_deg: float, speed: float = 20.0, n: int = 7, fps: float = 120.0):
    t = (np.arange(n) - n // 2) / fps
    q = rot.exp(np.array([0.0, 0.0, np.radians(yaw_deg)]))
    return np.column_stack([-0.06 + speed * t, 0 * t, 0 * t]), np.repeat(q[None], n, 0)


@pytest.mark.parametrize("yaw", [-10.0, 10.0])
def test_launch_turns_with_the_bat_face(yaw):
    box, size = mujoco.mjtGeom.mjGEOM_BOX, [0.02, 0.2, 0.2]
    straight = ph.simulate_launch(box, size, *_face_poses(0.0), 120.0, 3, [0.0, 0.0, 0.0])
    turned = ph.simulate_launch(box, size, *_face_poses(yaw), 120.0, 3, [0.0, 0.0, 0.0])
    assert straight.contacted and turned.contacted
    assert abs(straight.azimuth_deg) < 0.5
    assert turned.azimuth_deg == pytest.approx(yaw, abs=2.0)  # frictionless: along the face normal
    # A massive bat at 20 m/s with e = 0.5 sends a resting ball at about (1 + e) 20 m/s.
    assert straight.speed == pytest.approx(30.0, rel=0.2)


def test_restitution_is_roughly_the_requested_coefficient():
    box, size = mujoco.mjtGeom.mjGEOM_BOX, [0.02, 0.2, 0.2]
    pos, quat = np.tile([0.06, 0.0, 0.0], (7, 1)), np.tile([1.0, 0, 0, 0], (7, 1))
    for e in (0.3, 0.5, 0.8):
        out = ph.simulate_launch(box, size, pos, quat, 120.0, 3, [0.0, 0.0, 0.0], ball_velocity=(10.0, 0, 0), restitution=e, effector_mass=1e4)
        assert -out.velocity[0] / 10.0 == pytest.approx(e, abs=0.15)


def test_hit_metrics_on_a_club_swing():
    m = _clip("cmu_asfamc_converted/64_01.bvh")
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    c = mjcf.compile(m.skeleton, (prop,))
    spot = kinematics.forward(c, m).site(prop.site)
    speed = np.linalg.norm(np.gradient(spot, axis=0), axis=1) * m.fps
    h = int(np.argmax(speed))
    ball = mjcf.Ball(position=tuple(spot[h] + [0.0, 0.0, 0.0]), radius=0.0214, mass=0.046)
    hit = ph.hit_metrics(m, ball, h, (prop,), launch=True)
    assert hit["hit_error_m"] == pytest.approx(-0.0214, abs=1e-6) and hit["contact"]
    assert hit["impact_speed"] == pytest.approx(speed[h], rel=0.05)
    assert hit["launch_contacted"] and hit["launch_speed"] > 0.5 * speed[h]
    far = mjcf.Ball(position=tuple(spot[h] + [0.0, 0.0, 0.5]), radius=0.0214, mass=0.046)
    miss = ph.hit_metrics(m, far, h, (prop,), launch=False)
    assert miss["hit_error_m"] == pytest.approx(0.5 - 0.0214, abs=1e-6) and not miss["contact"]


def test_launch_predictability_rank_correlation():
    # A grid of hit points; "locked" adapters turn the face with the lateral offset, "free" ones at random.
    rng = np.random.default_rng(7)
    offsets = np.linspace(-0.1, 0.1, 6)
    hit_points = np.column_stack([np.zeros(6), offsets, np.zeros(6)])
    locked = [_face_poses(100 * y) for y in offsets]
    free = [_face_poses(rng.uniform(-15, 15)) for _ in offsets]
    box, size = mujoco.mjtGeom.mjGEOM_BOX, [0.02, 0.2, 0.2]
    p_locked = ph.launch_predictability(box, size, locked, 120.0, 3, hit_points)
    p_free = ph.launch_predictability(box, size, free, 120.0, 3, hit_points)
    assert p_locked.rho_azimuth == pytest.approx(1.0)
    assert abs(p_free.rho_azimuth) < 0.9
    assert len(p_locked.launches) == 6


@pytest.mark.parametrize("wrist", ["locked", "world"])
def test_reach_hit_point_meets_the_target_and_stays_local(wrist):
    m = _clip("cmu_asfamc_converted/64_01.bvh")
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    c = mjcf.compile(m.skeleton, (prop,))
    h = 325
    spot = kinematics.forward(c, m).site(prop.site)
    target = spot[h] + [0.03, -0.06, 0.04]
    out = ph.reach_hit_point(m, prop, h, target, falloff=0.25, wrist=wrist)
    got = kinematics.forward(c, out).site(prop.site)
    assert np.allclose(got[h], target, atol=1e-9)
    far = np.abs(np.arange(m.n_frames) - h) > 0.25 * m.fps + 1
    assert np.allclose(out.rotations[far], m.rotations[far])
    assert np.abs(np.diff(got[h - 40 : h + 40], axis=0) - np.diff(spot[h - 40 : h + 40], axis=0)).max() < 0.01


def test_hit_grid_on_a_golf_swing_is_monotone_for_a_translated_club():
    m = _clip("cmu_asfamc_converted/64_01.bvh")
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    offsets = ph.grid_offsets(m, prop, 325, 3, 0.05)[3:6]  # the middle row: lateral only
    p = ph.hit_grid(m, prop, 325, offsets, wrist="world")
    assert all(ln.contacted for ln in p.launches)
    assert abs(p.rho_azimuth) == pytest.approx(1.0)


def test_centre_of_pressure_of_an_accelerating_body_is_the_zmp():
    # A rigid pose accelerating horizontally at a: the ZMP is x_com - z_com * a / g (point-mass formula).
    m = _standing(30)
    a = np.array([2.0, -1.0, 0.0])
    t = np.arange(30) / m.fps
    moved = m.replace(root_positions=m.root_positions + 0.5 * np.outer(t**2, a))
    c = mjcf.compile(m.skeleton)
    f, tq = ph.inverse_wrench(c, moved)
    assert np.allclose(f, ph.total_mass(c) * (a + [0, 0, ph.GRAVITY]), rtol=1e-6)
    d = mujoco.MjData(c.model)
    q = kinematics.qpos(c, moved)
    cop = ph.centre_of_pressure(f, tq, moved.root_positions)
    for i in (5, 15, 25):
        d.qpos[:] = q[i]
        mujoco.mj_forward(c.model, d)
        com = d.subtree_com[c.body_ids[0]]
        assert np.allclose(cop[i], com[:2] - com[2] * a[:2] / ph.GRAVITY, atol=1e-6)
