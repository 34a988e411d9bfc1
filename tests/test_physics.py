"""Inverse-dynamics residuals, ground-reaction checks, hitting metrics and the ball-launch simulation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import random_motion, random_skeleton, require_data

from mjmotion import bvh, feet, kinematics, mjcf
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


def base_floor(c: mjcf.CompiledModel, m: Motion) -> float:
    return feet.foot_heights_speeds(c, m).floor


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


def test_ground_reaction_residual_known_answers():
    """One contact point under the root: a push inside the friction cone is supplied exactly, a
    pull (negative normal force) is left over whole, a shove beyond the cone leaves the excess."""
    w = 700.0
    origin = np.array([[0.0, 0.0, 1.0]] * 3)
    pts = np.array([[[0.0, 0.0, 0.0]]] * 3)
    act = np.ones((3, 1), dtype=bool)
    force = np.array([[0.0, 0.0, w], [0.0, 0.0, -0.5 * w], [0.0, 0.0, 0.0]])
    torque = np.cross(pts[:, 0] - origin, force)
    r = ph.ground_reaction_residual(force, torque, origin, pts, act, w, mu=1.0, lever=1.0)
    assert r[0] == pytest.approx(0.0, abs=1e-9) and r[1] == pytest.approx(0.5, abs=1e-9) and r[2] == 0.0
    # Without support the whole wrench is left over: |(F, τ/lever)| / weight.
    free = ph.ground_reaction_residual(force, torque + [1.0, 0.0, 0.0], origin, pts, ~act, w, lever=2.0)
    assert free == pytest.approx(np.linalg.norm(np.concatenate([force, (torque + [1.0, 0, 0]) / 2.0], axis=1), axis=1) / w)


def test_ground_reaction_residual_is_the_least_squares_optimum():
    """Against an independent solver (SciPy's bounded least squares) on random supports and
    wrenches; and the direct parallel-force construction never undercuts the optimum."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(11)
    t, n, w, lever, mu = 40, 5, 600.0, 0.9, 0.8
    pts = np.concatenate([rng.uniform(-0.15, 0.15, (t, n, 2)), rng.uniform(-0.01, 0.01, (t, n, 1))], axis=2)
    act = rng.random((t, n)) < 0.8
    origin = np.column_stack([rng.normal(0, 0.05, (t, 2)), np.full(t, 0.95)])
    force = np.column_stack([rng.normal(0, 150, (t, 2)), rng.normal(w, 300, t)])
    torque = rng.normal(0, 60, (t, 3))
    r = ph.ground_reaction_residual(force, torque, origin, pts, act, w, mu, lever)
    d = np.array([[mu, 0, 1], [0, mu, 1], [-mu, 0, 1], [0, -mu, 1]], dtype=float)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for i in range(t):
        if not act[i].any():
            continue
        cols = [np.concatenate([e, np.cross(p - origin[i], e) / lever]) for p in pts[i, act[i]] for e in d]
        a = np.array(cols).T / w
        b = np.concatenate([force[i], torque[i] / lever]) / w
        ref = lsq_linear(a, b, bounds=(0, np.inf), method="bvls", tol=1e-12)
        assert r[i] == pytest.approx(np.linalg.norm(a @ ref.x - b), abs=1e-6)
    bound = ph.parallel_support_bound(force, torque, origin, pts, act, w, mu, lever)
    assert np.all(bound >= r - 1e-9)
    fast = ph.ground_reaction_residual(force, torque, origin, pts, act, w, mu, lever, tol=0.15)
    assert np.array_equal(fast > 0.15, r > 0.15)
    assert (act.any(axis=1) & (bound <= 0.15)).any()  # some frames were decided by the bound


def test_parallel_support_bound_known_answers():
    """Body weight whose centre of pressure lies 0.2 m beyond the end of a two-point support: the
    construction puts the force at the nearer point and leaves 0.2 m × weight of torque; over the
    middle of the segment, nothing; beyond the friction pyramid or without support, no bound."""
    w, lever = 700.0, 0.8
    origin = np.array([[0.0, 0.0, 1.0]] * 4)
    pts = np.array([[[-0.1, 0.0, 0.0], [0.1, 0.0, 0.0]]] * 4)
    act = np.array([[True, True], [True, True], [True, True], [False, False]])
    cop = np.array([[0.3, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    force = np.array([[0.0, 0.0, w], [0.0, 0.0, w], [1.2 * w, 0.0, w], [0.0, 0.0, w]])
    torque = np.cross(cop - origin, force)
    bound = ph.parallel_support_bound(force, torque, origin, pts, act, w, mu=1.0, lever=lever)
    assert bound[0] == pytest.approx(0.2 / lever, rel=1e-12) and bound[1] == pytest.approx(0.0, abs=1e-12)
    assert np.isinf(bound[2:]).all()
    exact = ph.ground_reaction_residual(force, torque, origin, pts, act, w, mu=1.0, lever=lever)
    assert 0.0 < exact[0] < bound[0]  # tilted forces do better than parallel ones: an upper bound


@pytest.mark.parametrize("rel", ["cmu_asfamc_converted/16_15.bvh", "cmu_cgspeed_daz/07_02.bvh", "cmu_iclone_ccrig/007_04.bvh"])
def test_the_bound_decides_the_supported_frames_of_clean_walks(rel, monkeypatch):
    """The construction proves at least four in five of a clean walk's passing supported frames
    within tolerance, so the exact solve runs on few (a triangle construction proved 22-79 %),
    and never undercuts the optimum."""
    from mjmotion.thresholds import Params

    m = _clip(rel)
    c = mjcf.compile(m.skeleton)
    tol = Params().residual_tol
    seen = {}

    def spy(force, torque, origin, points, active, weight, mu=1.0, lever=1.0, tol=None):
        seen["args"] = (force, torque, origin, points, active, weight, mu, lever)
        return real(force, torque, origin, points, active, weight, mu, lever, tol)

    real = ph.ground_reaction_residual
    monkeypatch.setattr(ph, "ground_reaction_residual", spy)
    ph.residuals(c, m)
    force, torque, origin, points, active, weight, mu, lever = seen["args"]
    exact = real(force, torque, origin, points, active, weight, mu, lever)
    bound = ph.parallel_support_bound(force, torque, origin, points, active, weight, mu, lever)
    passing = active.any(axis=1) & (exact <= tol)
    assert np.all(bound >= exact - 1e-9)
    assert (bound[passing] <= tol).mean() >= 0.8


def test_whole_body_wrench_agrees_with_mj_inverse():
    """The vectorised Newton–Euler wrench equals the free root's rows of mj_inverse (no smoothing,
    the same central differences up to second-order terms) on a captured walk."""
    m = _clip("cmu_asfamc_converted/16_15.bvh")[2:200]
    c = mjcf.compile(m.skeleton)
    f1, t1 = ph.inverse_wrench(c, m)
    f2, t2 = ph.whole_body_wrench(c, kinematics.forward(c, m), m.fps)
    w = ph.total_mass(c) * ph.GRAVITY
    assert np.median(np.linalg.norm(f1 - f2, axis=1)) < 0.005 * w
    assert np.median(np.linalg.norm(t1 - t2, axis=1)) < 0.01 * w  # N·m against body weight × 1 m
    assert np.percentile(np.linalg.norm(f1 - f2, axis=1), 90) < 0.03 * w


def test_lifted_mid_stance_gives_flight_residual_one():
    m = _clip("cmu_asfamc_converted/64_01.bvh")[:120]  # golf address: standing still
    c = mjcf.compile(m.skeleton)
    base = ph.residuals(c, m)
    assert not base.flight.any() and np.isnan(base.flight_residual)
    root = m.root_positions.copy()
    root[40:80, 2] += 0.2  # hovering 20 cm up, motionless: only an external force holds it
    lifted = m.replace(root_positions=root)
    r = ph.residuals(c, lifted, feet.foot_heights_speeds(c, lifted, floor=base_floor(c, m)))
    assert r.flight[41:80].all()
    assert r.flight_residual == pytest.approx(1.0, abs=0.1)
    # The low-pass filter rings for a few frames after the 20 cm steps; the hover itself fails throughout.
    assert r.violation[55:65].all() and r.violation[41:80].mean() > 0.85


def test_free_fall_needs_no_force():
    m = _standing(96)
    t = np.arange(96) / m.fps
    # Thrown upwards from 1 m at 4 m/s for 0.8 s: a ballistic root path with the pose held fixed.
    root = m.root_positions + np.outer(1.0 + 4.0 * t - 0.5 * ph.GRAVITY * t**2, [0, 0, 1])
    c = mjcf.compile(m.skeleton)
    thrown = m.replace(root_positions=root)
    r = ph.residuals(c, thrown, feet.foot_heights_speeds(c, thrown, floor=0.0))
    assert r.flight.all()
    # The low-pass filter pads each end with a quadratic: a parabola passes unbent, ends included.
    assert r.flight_residual == pytest.approx(0.0, abs=1e-3)
    assert not r.violation.any() and r.root_force_ratio[2:-2].max() < 5e-3


def test_ballistic_residual_is_the_distance_from_free_fall():
    """A thrown centre of mass reads 0 over its flight, whatever its launch; the same flight played
    twice as fast (4 g of curvature) reads 3; hovering reads 1; stretches too short to fit, NaN."""
    fps = 120.0
    t = np.arange(60) / fps
    arc = np.column_stack([0.3 + 3.0 * t, -0.5 * t, 1.0 + 2.0 * t - 0.5 * ph.GRAVITY * t * t])
    air = np.zeros(60, dtype=bool)
    air[10:50] = True
    r = ph.ballistic_residual(arc, air, fps)
    assert np.allclose(r[10:50], 0.0, atol=1e-9) and np.isnan(r[:10]).all() and np.isnan(r[50:]).all()
    fast = np.column_stack([arc[:, 0], arc[:, 1], 1.0 + 4.0 * t - 2.0 * ph.GRAVITY * t * t])  # t -> 2t
    assert ph.ballistic_residual(fast, air, fps)[30] == pytest.approx(3.0)
    assert ph.ballistic_residual(np.ones((60, 3)), air, fps)[30] == pytest.approx(1.0)
    short = np.zeros(60, dtype=bool)
    short[20:24] = True
    assert np.isnan(ph.ballistic_residual(arc, short, fps)).all()
    # the fits themselves: each kept stretch and its acceleration, (0, 0, -g) for the arc, 4 g when twice as fast
    ((a, b, acc),) = ph.ballistic_fits(arc, air, fps)
    assert (a, b) == (10, 50) and np.allclose(acc, [0.0, 0.0, -ph.GRAVITY], atol=1e-9)
    assert ph.ballistic_fits(fast, air, fps)[0][2][2] == pytest.approx(-4.0 * ph.GRAVITY)
    assert ph.ballistic_fits(arc, short, fps) == []


def test_toe_less_feet_push_on_their_unmodelled_toes():
    """A cgspeed daz foot ends at the ball: weight borne 3 cm ahead of its ball line is only
    feasible with the toes the skeleton does not model, which reach 0.13 x stature from the heel."""
    m = _clip("cmu_cgspeed_daz/07_01.bvh")[60:90]
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    tr = feet.foot_heights_speeds(c, m, pose, floor=0.0)
    t = 10
    f = int(np.argmin(tr.heights[t]))
    support = np.zeros(tr.points.shape[:3], dtype=bool)
    support[:, f] = True
    points, active = ph._with_toes(m.skeleton, tr, support)
    n_soles = tr.points.shape[1] * tr.points.shape[2]
    assert points.shape[1] == n_soles + 2 * len(tr.sides) and active[:, n_soles + 2 * f :][:, :2].all()
    heel, ball = tr.points[t, f, :2].mean(axis=0), tr.points[t, f, 2:4].mean(axis=0)
    toes = points[t, n_soles + 2 * f : n_soles + 2 * f + 2].mean(axis=0)
    assert np.linalg.norm((toes - heel)[:2]) == pytest.approx(ph.TOE_REACH * m.skeleton.stature(), rel=1e-6)
    weight = ph.total_mass(c) * ph.GRAVITY
    ahead = (ball - heel)[:2] / np.linalg.norm((ball - heel)[:2])
    cop = ball + 0.03 * np.array([ahead[0], ahead[1], 0.0])
    origin = pose.joint_positions[t : t + 1, 0]
    force = np.array([[0.0, 0.0, weight]])
    torque = np.cross(cop - origin, force)  # the weight pushed up at the centre of pressure
    lever = 0.5 * m.skeleton.stature()
    flat = tr.points[t : t + 1].reshape(1, -1, 3)
    without = ph.ground_reaction_residual(force, torque, origin, flat, support[t : t + 1].reshape(1, -1), weight, 1.0, lever)
    with_toes = ph.ground_reaction_residual(force, torque, origin, points[t : t + 1], active[t : t + 1], weight, 1.0, lever)
    assert without[0] > 0.02 and with_toes[0] < 1e-6


def test_jump_flight_residual_near_zero():
    m = _clip("cmu_asfamc_converted/16_01.bvh")
    r = ph.residuals(mjcf.compile(m.skeleton), m)
    assert r.flight.sum() > 30
    assert r.flight_residual < 0.3
    # The take-off push: the contact frames just before flight need more than body weight.
    first = int(np.flatnonzero(r.flight)[0])
    assert r.root_force_ratio[first - 20 : first].max() > 1.5
    # Its one long flight, fitted: the centre of mass of captured ASF data falls at g (the control
    # for the daz runs' 1.2-1.8 g, experiments.physics_audit.flight_falls).
    (acc,) = r.flight_accelerations
    assert acc[2] == pytest.approx(-ph.GRAVITY, rel=0.05) and np.hypot(*acc[:2]) < 0.1 * ph.GRAVITY


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
