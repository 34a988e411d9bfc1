"""Hit-point adaptation on the real golf swing 64_01 and soccer kick 10_01 (seed 003 §2)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjmotion import bvh, hitpoint, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.errors import MjmotionError

GRID = [(dy, dz) for dy in (-0.2, 0.0, 0.2) for dz in (-0.2, 0.0, 0.2)]
REPORT_KEYS = {
    "hit_frame",
    "source_effector",
    "target",
    "achieved_effector",
    "hit_error_m",
    "reachable",
    "max_goal_error_m",
    "style_rmse",
    "k",
    "grip_error_m",
    "solve_s_per_frame",
    "solver",
}


@pytest.fixture(scope="module")
def swing():
    from conftest import require_data

    path = require_data() / "cmu_asfamc_converted" / "64_01.bvh"
    m = bvh.read(path)
    return path, m, hitpoint.fit_club(m)


@pytest.fixture(scope="module")
def short(swing):
    """Frames 250–420 (top of the backswing to the finish) with the club fitted on the whole clip."""
    _, m, prop = swing
    return m[250:420], prop


def across(problem: hitpoint.HitProblem) -> np.ndarray:
    return hitpoint.swing_plane_axes(problem)


def test_club_runs_through_both_hands_to_the_floor(swing):
    _, m, prop = swing
    assert prop.joint == "lhand"  # right-handed golfer: the left hand is on top
    pose = kinematics.forward(mjcf.compile(m.skeleton, (prop,)), m)
    grip, tip = pose.site("club/grip"), pose.site("club/tip")
    n = hitpoint.address_frames(grip)
    axis = (tip - grip)[:n] / np.linalg.norm(tip - grip, axis=1)[:n, None]
    rh = pose.joint_positions[:n, m.skeleton.index("rhand")]
    off = (rh - grip[:n]) - np.sum((rh - grip[:n]) * axis, axis=1)[:, None] * axis
    assert np.median(np.linalg.norm(off, axis=1)) < 0.05  # the trail hand is on the handle
    assert abs(np.median(tip[:n, 2]) - hitpoint.floor_height(m)) < 0.03  # the head rests on the floor
    assert np.linalg.norm(tip - grip, axis=1) == pytest.approx(mjcf.PROP_PRESETS["club"]["length"])


def test_hit_frame_is_the_impact(swing):
    _, m, _ = swing
    p = hitpoint.setup(m, offset=np.zeros(3))
    assert abs(p.hit - 325) <= 8  # SOURCES.md: impact ≈ frame 325
    assert p.blend[p.hit] == 1.0 and p.blend[0] == 0.0 and p.blend[-1] == 0.0
    d = np.linalg.norm(p.effector_fk - p.effector_fk[p.hit], axis=1)
    mid = slice(120, 380)  # away from the end tapers the blend is the seed's formula exactly
    assert np.allclose(p.blend[mid], np.clip(1 - d[mid] / p.falloff, 0, 1))


@pytest.mark.parametrize("solver", ["nlp", "dls"])
def test_grid_of_targets_is_reached_with_the_grip_kept(short, solver):
    s, prop = short
    base = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    axes = across(base)
    legs = [j for j, n in enumerate(s.skeleton.names) if any(k in n for k in ("hip", "femur", "tibia", "foot", "toes"))]
    for dy, dz in GRID:
        a = hitpoint.adapt(s, offset=dy * axes[0] + dz * axes[1], prop=prop, solver=solver, style=False)
        r = a.report
        assert r["reachable"] and r["hit_error_m"] < 1e-3 and r["max_goal_error_m"] < 1e-3, (dy, dz, r)
        assert r["grip_error_m"] < 5e-3, (dy, dz, r)
        assert np.array_equal(a.motion.rotations[[0, -1]], s.rotations[[0, -1]])
        assert np.array_equal(a.motion.rotations[:, [0] + legs], s.rotations[:, [0] + legs])
        assert np.array_equal(a.motion.root_positions, s.root_positions)


def test_locked_wrist_keeps_the_style_better_than_a_two_dof_wrist(short):
    """Seed 003 Table 2.1 in direction: mean style_rmse over the grid, locked < 2-DOF wrist.

    Holds on the impact half of 64_01 (frames 250–420, its own PCA) with the default
    style-learned stiffness. It does NOT hold in general: with clip-variance weights it flips, and
    on the five whole swings (DLS, 18 targets each) the 2-DOF wrist has the lower mean style_rmse
    in 4 of 5 at falloff 0.6 and on average at 0.35 (0.029 vs 0.033) and 0.2 (0.012 vs 0.015).
    """
    s, prop = short
    base = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    axes = across(base)
    mean = {}
    for wrist in ("locked", "swing"):
        errs = [hitpoint.adapt(s, offset=dy * axes[0] + dz * axes[1], prop=prop, solver="dls", wrist=wrist).report["style_rmse"] for dy, dz in GRID]
        mean[wrist] = float(np.mean(errs))
    assert mean["locked"] < mean["swing"], mean


def test_falloff_changes_the_path_not_the_hit(short):
    s, prop = short
    a = hitpoint.adapt(s, offset=np.array([0.0, 0.1, 0.1]), prop=prop, solver="dls", falloff=0.3, style=False)
    b = hitpoint.adapt(s, offset=np.array([0.0, 0.1, 0.1]), prop=prop, solver="dls", falloff=0.8, style=False)
    h = a.problem.hit
    assert np.linalg.norm(a.achieved[h] - b.achieved[h]) < 2e-3
    assert np.max(np.linalg.norm(a.achieved - b.achieved, axis=1)) > 0.02


def test_whole_shot_nlp_reaches_and_keeps_the_grip(short):
    s, prop = short
    sl = s[60:110]  # a window around the impact keeps the test small
    a = hitpoint.adapt(sl, offset=np.array([0.0, 0.1, -0.1]), prop=prop, solver="nlp-shot", falloff=0.4, edge=0.05, style=False)
    r = a.report
    assert r["hit_error_m"] < 1e-3 and r["max_goal_error_m"] < 1e-3 and r["grip_error_m"] < 5e-3, r
    assert np.array_equal(a.motion.rotations[[0, -1]], sl.rotations[[0, -1]])
    # The smoothness term makes the deviation from the source vary more smoothly than per-frame IK.
    b = hitpoint.adapt(sl, offset=np.array([0.0, 0.1, -0.1]), prop=prop, solver="nlp", falloff=0.4, edge=0.05, style=False)

    def roughness(x):
        dev = rot.log(rot.multiply(rot.conjugate(sl.rotations), x.rotations))
        return float(np.sum(np.diff(dev, n=2, axis=0) ** 2))

    assert roughness(a.motion) < roughness(b.motion)


def test_unreachable_target_is_flagged_not_raised(short):
    s, prop = short
    a = hitpoint.adapt(s, offset=np.array([0.0, 2.0, 0.0]), prop=prop, solver="dls", style=False)
    assert a.report["reachable"] is False and "unreachable" in a.report["message"]
    assert a.report["hit_error_m"] > 0.5


def test_kick_reaches_a_moved_ball_with_the_support_foot_still():
    from conftest import require_data

    m = bvh.read(require_data() / "cmu_asfamc_converted" / "10_01.bvh")
    s = m[520:660]
    left = [j for j, n in enumerate(s.skeleton.names) if n.startswith("l") and any(k in n for k in ("hip", "femur", "tibia", "foot", "toes"))]
    for off in ([0.1, 0, 0], [-0.1, 0, 0], [0, 0.1, 0], [0, -0.1, 0]):
        a = hitpoint.adapt(s, offset=np.array(off), effector="right_foot", solver="nlp", style=False)
        assert a.report["hit_error_m"] < 1e-3, a.report
        assert abs(a.report["hit_frame"] + 520 - 596) <= 6
        assert np.array_equal(a.motion.rotations[:, [0] + left], s.rotations[:, [0] + left])


def test_cli_writes_the_clip_and_the_report(swing, tmp_path, capsys):
    path, m, _ = swing
    out, rep = tmp_path / "hit.bvh", tmp_path / "hit.json"
    code = main(["hit", str(path), "--offset", "0", "0.05", "0.05", "--solver", "dls", "--falloff", "0.3", "-o", str(out), "--json", str(rep)])
    assert code == 0
    r = json.loads(rep.read_text())
    assert REPORT_KEYS <= set(r) and set(r) - REPORT_KEYS <= {"message"}
    assert r["reachable"] and r["style_rmse"] > 0 and r["k"] >= 1
    back = bvh.read(out)
    assert back.n_frames == m.n_frames
    assert main(["hit", str(path), "--offset", "0", "0", "0", "-o", str(out)]) == 2  # exists, no --force
    assert main(["hit", str(path), "--offset", "0", "0", "0", "--falloff", "-1", "-o", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err
    assert "falloff" in err and "Traceback" not in err


def test_style_weights_stiffen_what_the_style_space_sees(short):
    """A turn of a stiff coordinate moves the top-k PCA scores more than a turn of a supple one."""
    from mjmotion.style import PoseSpace

    s, prop = short
    p = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    w = p.lead.weights
    assert np.all(w > 0) and w.max() == pytest.approx(1.0)
    names = [n for n, j in zip(p.lead.names, p.lead.joints) for _ in range(j.dof)]
    assert w[names.index("lclavicle")] == pytest.approx(w.min())  # still in the source → stiffest
    space = PoseSpace.fit(s)
    k = space.components_for(0.7)
    moved = {}
    for i in (int(np.argmin(np.where(np.array(names) == "lclavicle", np.inf, w))), int(np.argmax(w))):
        d = np.zeros(p.lead.n_dof)
        d[i] = 0.05
        q = s.rotations.copy()
        ji = p.lead.joint_indices
        q[:, ji] = p.lead.apply(q[:, ji], np.broadcast_to(d, (s.n_frames, p.lead.n_dof)))
        moved[i] = float(np.mean(np.sum((space.scores(s.replace(rotations=rot.normalize(q)), k) - space.source_scores[:, :k]) ** 2, axis=1)))
    stiff, supple = moved
    assert moved[stiff] > moved[supple]


def test_blend_is_full_at_a_hit_near_either_end_and_zero_at_the_ends():
    from mjmotion.hitpoint import blend_weights

    effector = np.cumsum(np.full((200, 3), 0.01), axis=0)  # a steadily moving effector
    for hit in (3, 12, 100, 190, 196):
        b = blend_weights(effector, hit, falloff=0.5, fps=120.0, edge=0.5)
        assert b[hit] == pytest.approx(1.0) and b[0] == 0.0 and b[-1] == 0.0, hit
        assert np.all(np.diff(b[: hit + 1]) >= -1e-12) and np.all(np.diff(b[hit:]) <= 1e-12), hit


def test_table_2_1_with_the_seeds_solver_locked_wrist_keeps_the_style(short):
    """Seed 003 Table 2.1 in direction with its own solver, CCD: over the ±10 cm grid across the
    swing, the locked wrist's mean style_rmse is lower than the 2-DOF wrist's (seed: +29 % for
    2-DOF; measured here +15 % on this excerpt, +37 % on the whole of 64_01). NLP and DLS, which
    minimise deviation from the source, do not show it (README, results/hitpoint_grid)."""
    s, prop = short
    base = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    axes = across(base)
    grid = [(dy, dz) for dy in (-0.1, 0.0, 0.1) for dz in (-0.1, 0.0, 0.1)]
    mean = {}
    for wrist in ("locked", "swing"):
        reports = [hitpoint.adapt(s, offset=dy * axes[0] + dz * axes[1], prop=prop, solver="ccd", wrist=wrist).report for dy, dz in grid]
        assert all(r["hit_error_m"] < 1e-3 for r in reports)
        mean[wrist] = float(np.mean([r["style_rmse"] for r in reports]))
    assert mean["locked"] < mean["swing"], mean


def test_aim_is_setup_at_the_new_target_and_solve_of_it_is_adapt(short):
    """What the Studio's drag runs: one set-up, aimed at each ball position, gives the verb's answer bit for bit."""
    s, prop = short
    base = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    target = base.effector_fk[base.hit] + np.array([0.0, 0.08, 0.06])
    aimed, fresh = hitpoint.aim(base, target), hitpoint.setup(s, target=target, prop=prop)
    np.testing.assert_array_equal(aimed.goals, fresh.goals)
    np.testing.assert_array_equal(aimed.target, fresh.target)
    assert aimed.hit == fresh.hit and base.goals is not aimed.goals
    for solver in ("dls", "nlp"):
        a = hitpoint.solve(aimed, solver, style=solver == "dls")
        b = hitpoint.adapt(s, target=target, prop=prop, solver=solver, style=solver == "dls")
        np.testing.assert_array_equal(a.motion.rotations, b.motion.rotations)
        assert {k: v for k, v in a.report.items() if k != "solve_s_per_frame"} == {k: v for k, v in b.report.items() if k != "solve_s_per_frame"}
    with pytest.raises(MjmotionError, match="three finite numbers"):
        hitpoint.aim(base, np.array([0.0, np.nan, 1.0]))


def test_a_preview_solves_few_frames_reaches_the_ball_and_stays_near_the_full_solve():
    from mjmotion import synth

    drive = synth.drive()  # a golf drive: the blend touches ~90 of its frames (it addresses the ball)
    base = hitpoint.setup(drive.motion, offset=np.zeros(3), frame=drive.hit_frame, prop=drive.prop)
    problem = hitpoint.aim(base, base.effector_fk[base.hit] + np.array([0.0, 0.05, 0.05]))
    active = np.flatnonzero(problem.blend > 0)
    frames = hitpoint.preview_frames(problem, 24)
    assert len(active) > 80 and 16 <= len(frames) <= 27 and problem.hit in frames and frames[0] == active[0] and frames[-1] == active[-1]
    assert np.array_equal(hitpoint.preview_frames(problem, len(active)), active)
    seen = []
    p = hitpoint.solve(problem, "dls", style=False, preview=24, on_frame=lambda i, n: seen.append((i, n)))
    full = hitpoint.solve(problem, "dls", style=False)
    assert seen == [(i, len(frames)) for i in range(len(frames))] and p.report["preview_frames"] == len(frames)
    assert p.report["hit_error_m"] < 1e-3  # the hit frame is solved, not interpolated
    np.testing.assert_array_equal(p.motion.rotations[frames], full.motion.rotations[frames])  # solved frames: the full solve's
    assert hitpoint.source_kept(p) == (True, True)
    between = np.setdiff1d(active, frames)
    assert len(between) > 0 and not np.array_equal(p.motion.rotations[between], full.motion.rotations[between])
    dev = np.linalg.norm(p.achieved - full.achieved, axis=1)
    assert np.median(dev[between]) < 0.01 and dev.max() < 0.05  # interpolated δ: near the full solve's path

    def stop(i: int, n: int) -> None:
        if i == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        hitpoint.solve(problem, "dls", on_frame=stop)
