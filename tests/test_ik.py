"""IK chains and solvers on a real golf swing: exact FK, Jacobians, limits, agreement between solvers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError
from mjmotion.ik import ccd, chains, dls, nlp


@pytest.fixture(scope="module")
def swing():
    from conftest import require_data

    d = require_data()
    m = bvh.read(d / "cmu_asfamc_converted" / "64_01.bvh")
    s = m.skeleton
    eff = chains.Effector("fist", s.index("lhand"), (0.08, 0.02, 0.0))
    lead = chains.build_chain(m, "lowerback", "lhand", eff, wrist="swing")
    second = chains.build_chain(m, "rclavicle", "rhand", None, wrist="swing")
    cm = mjcf.compile(s)
    return m, cm, lead, second, kinematics.qpos(cm, m)


def test_freedoms_follow_roles_and_the_root_is_refused(swing):
    m, _, lead, _, _ = swing
    freedoms = dict(zip(lead.names, (j.freedom for j in lead.joints)))
    assert freedoms["lradius"] == "hinge" and freedoms["lwrist"] == "hinge"  # elbow, forearm roll bone
    assert freedoms["lhand"] == "swing" and freedoms["lhumerus"] == "ball"
    locked = chains.build_chain(m, "lowerback", "lhand", lead.effector, wrist="locked")
    assert locked.n_dof == lead.n_dof - 2
    with pytest.raises(MjmotionError):
        chains.build_chain(m, "root", "lhand")


def test_hinge_axis_is_the_clips_own(swing):
    """CMU elbows are 1-DOF in the data: every frame's elbow rotation is about the found axis."""
    m, _, lead, _, _ = swing
    j = next(c for c in lead.joints if m.skeleton.names[c.joint] == "lradius")
    v = rot.log(rot.multiply(rot.conjugate(j.q_ref), m.rotations[:, j.joint]))
    off_axis = v - np.outer(v @ j.basis[:, 0], j.basis[:, 0])
    assert np.abs(off_axis).max() < 1e-5  # the file stores degrees to 6 decimals


def test_an_elbow_that_rolls_in_its_clip_also_rolls_in_the_ik(swing):
    """The bundled shots keep the forearm's pronation in the elbow's channels: the elbow gets that roll
    as a second freedom (flexion across the bone, the roll about it); CMU's 1-DOF elbows stay 1-DOF."""
    from mjmotion import synth

    m, _, lead, _, _ = swing
    assert next(c for c in lead.joints if m.skeleton.names[c.joint] == "lradius").dof == 1
    drive = synth.drive().motion
    chain = chains.build_chain(drive, "Spine", "LeftHand", None, wrist="ball")
    elbow = next(c for c in chain.joints if drive.skeleton.names[c.joint] == "LeftForeArm")
    bone = chains.bone_axis(drive.skeleton, elbow.joint)
    assert elbow.freedom == "hinge" and elbow.dof == 3
    assert np.allclose(elbow.basis[:, 2], bone) and abs(elbow.basis[:, 0] @ bone) < 1e-9
    # flexion and roll span the clip's elbow motion, continuously; the carrying angle hardly moves
    c = chains._coords(elbow.basis, elbow.q_ref, drive.rotations[:, elbow.joint])
    assert np.ptp(c[:, 0]) > np.radians(20) and np.ptp(c[:, 2]) > chains.HINGE_ROLL and np.ptp(c[:, 1]) < np.radians(5)
    assert np.abs(np.diff(c, axis=0)).max() < np.radians(30)  # no wrap between frames (a wrap jumps ~180°; the roll peaks at 20° a frame)
    assert elbow.upper[1] - elbow.lower[1] < np.ptp(c[:, 1]) + 2 * chains.ELBOW_CARRY + 1e-9
    # a hinge whose clip does not roll it keeps its single flexion axis
    q = drive.rotations.copy()
    q[:, elbow.joint] = rot.exp(np.outer(np.radians(np.linspace(10, 90, drive.n_frames)), elbow.basis[:, 0]))
    flat = drive.replace(rotations=q)
    assert next(c for c in chains.build_chain(flat, "Spine", "LeftHand", None).joints if c.joint == elbow.joint).dof == 1


def test_zero_delta_is_the_fk_pose_and_limits_contain_it(swing):
    m, cm, lead, _, q = swing
    kin = chains.ChainKinematics(cm, lead)
    kin.set_frame(q[300])
    kin.set_delta(np.zeros(lead.n_dof))
    assert np.array_equal(kin.data.qpos, q[300])
    lo, hi = lead.bounds(m)
    assert np.all(lo <= 0) and np.all(hi >= 0) and np.all(hi - lo > 0)


def test_jacobian_matches_finite_differences(swing):
    _, cm, lead, _, q = swing
    kin = chains.ChainKinematics(cm, lead)
    kin.set_frame(q[200])
    d = np.random.default_rng(1).normal(0, 0.2, lead.n_dof)
    kin.set_delta(d)
    jac = kin.jacobian(rotation=True)
    e0 = kin.effector().copy()
    h = 1e-7
    num = np.zeros((3, lead.n_dof))
    for i in range(lead.n_dof):
        dd = d.copy()
        dd[i] += h
        kin.set_delta(dd)
        num[:, i] = (kin.effector() - e0) / h
    assert np.abs(jac[:3] - num).max() < 1e-5


def test_symbolic_fk_matches_mujoco_to_a_nanometre(swing):
    """Both chains together (the second's base, thorax, is inside the first), random coordinates."""
    _, cm, lead, second, q = swing
    fk = nlp.SymbolicFK(cm, [lead, second])
    rng = np.random.default_rng(2)
    k1, k2 = chains.ChainKinematics(cm, lead), chains.ChainKinematics(cm, second)
    rh = cm.body_ids[second.tip]
    for t in (0, 250, 330):
        d1, d2 = rng.normal(0, 0.4, lead.n_dof), rng.normal(0, 0.4, second.n_dof)
        k1.set_frame(q[t])
        k1.set_delta(d1)
        k2.set_frame(k1.data.qpos.copy())
        k2.set_delta(d2)
        out = fk.function(np.concatenate([d1, d2]), fk.params(q[t], k1.data.xpos, k1.data.xmat))
        assert np.abs(np.asarray(out[2]).ravel() - k1.effector()).max() < 1e-9
        assert np.abs(np.asarray(out[3]).ravel() - k2.data.xpos[rh]).max() < 1e-9
        assert np.abs(np.asarray(out[4]).reshape(3, 3, order="F") - k2.data.xmat[rh].reshape(3, 3)).max() < 1e-9


def test_nlp_optimum_agrees_with_scipy_on_mujoco_fk_and_beats_dls(swing):
    """The NLP's weighted least deviation equals SLSQP's on the same problem through MuJoCo FK."""
    m, cm, lead, _, q = swing
    t = 320
    kin = chains.ChainKinematics(cm, lead)
    kin.set_frame(q[t])
    kin.set_delta(np.zeros(lead.n_dof))
    goal = kin.effector() + np.array([0.05, -0.08, 0.1])
    lo, hi = lead.bounds(m)
    fs = nlp.FrameSolver(cm, lead)
    r = fs.solve(q[t], kin.data.xpos, kin.data.xmat, goal, lo[t], hi[t])
    w = lead.weights
    cost = lambda d: float(np.sum(d**2 / w))

    def eff(d):
        kin.set_delta(d)
        return kin.effector() - goal

    ref = minimize(
        cost,
        np.zeros(lead.n_dof),
        jac=lambda d: 2 * d / w,
        method="SLSQP",
        bounds=list(zip(lo[t], hi[t])),
        constraints={"type": "eq", "fun": eff},
        options={"ftol": 1e-14, "maxiter": 500},
    )
    assert r.error < 1e-9 and np.linalg.norm(eff(ref.x)) < 1e-6
    assert cost(r.delta) == pytest.approx(cost(ref.x), rel=1e-4)
    rd = dls.solve(kin, q[t], goal, lo[t], hi[t])
    assert rd.error < 1e-4
    assert cost(r.delta) <= cost(rd.delta) * (1 + 1e-6)
    assert np.all(r.delta >= lo[t] - 1e-9) and np.all(r.delta <= hi[t] + 1e-9)


def test_dls_six_d_goal_and_ccd_position_goal(swing):
    m, cm, lead, second, q = swing
    t = 300
    k2 = chains.ChainKinematics(cm, second)
    k2.set_frame(q[t])
    k2.set_delta(np.full(second.n_dof, 0.05))
    p, r = k2.tip_frame()
    lo, hi = second.bounds(m)
    res = dls.solve(k2, q[t], p, lo[t], hi[t], goal_rotation=r)
    assert res.error < 1e-4 and res.rotation_error < 1e-3
    kin = chains.ChainKinematics(cm, lead)
    kin.set_frame(q[t])
    kin.set_delta(np.zeros(lead.n_dof))
    goal = kin.effector() + np.array([0.0, 0.05, 0.05])
    lo1, hi1 = lead.bounds(m)
    rc = ccd.solve(kin, q[t], goal, lo1[t], hi1[t])
    assert rc.error < 1e-4
    assert np.all(rc.delta >= lo1[t]) and np.all(rc.delta <= hi1[t])
    # Starting at the goal is no work at all (§2.2.3).
    kin.set_delta(np.zeros(lead.n_dof))
    r0 = ccd.solve(kin, q[t], kin.effector().copy(), lo1[t], hi1[t])
    assert r0.iterations == 0 and not r0.delta.any()


def test_analytic_two_bone_reaches_targets_and_keeps_bone_lengths():
    from mjmotion.ik import analytic

    rng = np.random.default_rng(0)
    n = 200
    top = rng.normal(size=(n, 3))
    mid = top + rng.normal(size=(n, 3)) * 0.3
    end = mid + rng.normal(size=(n, 3)) * 0.3
    l1, l2 = np.linalg.norm(mid - top, axis=1), np.linalg.norm(end - mid, axis=1)
    # Targets inside the reachable shell, and some beyond it.
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    frac = rng.uniform(0.2, 1.3, n)
    dist = np.abs(l1 - l2) + frac * (l1 + l2 - np.abs(l1 - l2))
    target = top + direction * dist[:, None]
    axis = analytic.bend_axes(top, mid, end, fallback=np.cross(mid - top, target - top))
    r_top, r_mid, short = analytic.two_bone(top, mid, end, target, axis)
    new_mid = top + rot.rotate(r_top, mid - top)
    new_end = new_mid + rot.rotate(r_top, rot.rotate(r_mid, end - mid))
    assert np.allclose(np.linalg.norm(new_mid - top, axis=1), l1)
    assert np.allclose(np.linalg.norm(new_end - new_mid, axis=1), l2)
    inside = frac <= 1.0
    assert np.abs(np.linalg.norm(new_end - target, axis=1)[inside]).max() < 1e-5
    assert np.allclose(short[inside], 0.0, atol=1e-5)
    # Out of reach: the limb points straight at the target and says how far it is short.
    out = ~inside
    assert np.allclose(short[out], np.linalg.norm(target - top, axis=1)[out] - (l1 + l2)[out], atol=1e-5)
    assert np.allclose(np.linalg.norm(new_end - target, axis=1)[out], short[out], atol=1e-5)


def test_an_overconstrained_frame_goes_straight_to_the_best_effort_without_casadi_warnings(tmp_path, capfd):
    """A walk's hand asked 10 cm out: frames whose chain has fewer free coordinates than goal equations
    went to IPOPT anyway, which refused them, and CasADi printed a warning on stderr for each."""
    from mjmotion.cli import main

    src, out = tmp_path / "walk.bvh", tmp_path / "out.bvh"
    assert main(["synth", "walk", "--seconds", "2", "-o", str(src)]) == 0
    capfd.readouterr()
    assert main(["hit", str(src), "--offset", "0", "0.1", "0", "--solver", "nlp", "-o", str(out)]) in (0, 2)
    err = capfd.readouterr().err
    assert "CasADi" not in err and "WARNING" not in err, err[:600]  # (the tmp path holds the test name)
    assert out.exists()


def test_ctrl_c_during_a_solve_is_raised_once_it_returns(ctrl_c):
    """CasADi catches the KeyboardInterrupt Python raises inside IPOPT's callback and returns from the solve
    (`hit --solver nlp-shot` ran on for 20 s after Ctrl-C and wrote its result). A stand-in solver that
    swallows the interrupt as CasADi does: nlp._solve raises it once the solver returns."""
    import os
    import signal

    from mjmotion.ik import nlp

    class Swallowing:
        calls = 0

        def __call__(self, **args):
            self.calls += 1
            try:
                os.kill(os.getpid(), signal.SIGINT)
                for _ in range(1000):  # (Python runs the handler between bytecodes)
                    pass
            except KeyboardInterrupt:
                pass  # what CasADi does (its warning: "KeyboardInterruptException")
            return {"x": args["x0"]}

        def stats(self):
            return {"success": False, "return_status": "NonIpopt_Exception_Thrown", "iter_count": 1}

    s = Swallowing()
    with pytest.raises(KeyboardInterrupt):
        nlp._solve(s, x0=np.zeros(2))
    assert s.calls == 1 and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # without an interrupt, the solution and the stats come back
    quiet = type("Quiet", (), {"__call__": lambda self, **a: {"x": a["x0"]}, "stats": lambda self: {"success": True}})()
    assert nlp._solve(quiet, x0=np.ones(2))[1] == {"success": True}
