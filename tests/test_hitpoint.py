"""Hit-point adaptation on the real golf swing 64_01 and soccer kick 10_01 (seed 003 §2)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjmotion import bvh, hitpoint, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.errors import MjmotionError

# across and up the plane across the swing at the contact, where the club is ~11 cm above the
# floor: a grid above it (targets under the floor stop short, test_unreachable_*)
GRID = [(dy, dz) for dy in (-0.2, 0.0, 0.2) for dz in (0.0, 0.1, 0.2)]
REPORT_KEYS = {
    "hit_frame",
    "hit_rule",
    "floor_m",
    "source_effector_height_m",
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
    "stopped_target",
    "short_by_m",
    "frames_shortened",
    "frames_paced",
    "lowest_above_floor_m",
    "joint_speed_ratio",
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


def rotation_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angles (radians) of unit quaternions ``(..., 4)``."""
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


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
    assert 0 <= p.hit - 325 <= 12  # SOURCES.md: impact ≈ frame 325 (peak hand speed; the club bottoms out after)
    assert p.blend[p.hit] == 1.0 and p.blend[0] == 0.0 and p.blend[-1] == 0.0
    d = np.linalg.norm(p.effector_fk - p.effector_fk[p.hit], axis=1)
    mid = slice(120, 380)  # away from the end tapers the blend is the seed's formula exactly
    assert np.allclose(p.blend[mid], np.clip(1 - d[mid] / p.falloff, 0, 1))


# SOURCES.md's approximate impact frames (peak hand speed) of the golf swings
IMPACT = {"64_01": 325, "64_02": 367, "64_03": 284, "64_04": 258, "64_05": 244}


@pytest.mark.parametrize("name", sorted(IMPACT))
def test_hit_frame_is_the_clubs_lowest_pass_near_the_floor(name):
    """Issue 18 item 8: the hit frame is the moment of contact. A golf ball sits on the ground, so
    the contact is the sweet spot's lowest pass in the downswing, not the peak speed 3–5 frames
    earlier with the club 21–29 cm above the floor. Heights are above the floor the feet stand on
    (subject 64's is 2–4 cm below z = 0), which the report gives."""
    from conftest import require_data

    m = bvh.read(require_data() / "cmu_asfamc_converted" / f"{name}.bvh")
    p = hitpoint.setup(m, offset=np.zeros(3), weights="clip")
    z = p.effector_fk[:, 2]
    around = slice(IMPACT[name] - 18, IMPACT[name] + 19)  # ±0.15 s of SOURCES.md's impact
    assert z[p.hit] == z[around].min() and p.hit_rule == "lowest pass", (name, p.hit)
    assert -0.04 <= p.floor <= -0.015  # SOURCES.md: the floor is 2–4 cm below z = 0
    height = z[p.hit] - p.floor
    assert height < 0.17, (name, height)  # the fitted club's lowest pass (it was 0.21–0.29 m at the old frame)
    # a ball given where the club passes 4 frames before the bottom: that frame is the contact
    k = p.hit - 4
    q = hitpoint.setup(m, offset=np.zeros(3), weights="clip", source_ball=p.effector_fk[k], prop=p.prop)
    assert q.hit == k and q.hit_rule == "nearest the ball"
    # the address, where the club rests as low, is not the impact
    assert p.hit > 200
    # at address the head rests in front of the golfer, beyond the hands (64_03's club, held by the
    # right hand because the left flips in the data, used to point behind him)
    pose = kinematics.forward(p.compiled, p.qpos[:1])
    feet = [a for a, _ in m.skeleton.feet().values()]
    mid = pose.joint_positions[0, feet].mean(axis=0)
    head = (pose.site("club/tip")[0] - mid)[:2]
    hands = (pose.joint_positions[0, [m.skeleton.index("lhand"), m.skeleton.index("rhand")]].mean(axis=0) - mid)[:2]
    assert head @ hands > 0 and np.linalg.norm(head) > np.linalg.norm(hands) + 0.3, (name, head, hands)


@pytest.mark.parametrize("solver", ["nlp", "dls"])
def test_grid_of_targets_is_reached_with_the_grip_kept(short, solver):
    s, prop = short
    base = hitpoint.setup(s, offset=np.zeros(3), prop=prop)
    axes = across(base)
    legs = [j for j, n in enumerate(s.skeleton.names) if any(k in n for k in ("hip", "femur", "tibia", "foot", "toes"))]
    reached = 0
    for dy, dz in GRID:
        a = hitpoint.adapt(s, offset=dy * axes[0] + dz * axes[1], prop=prop, solver=solver, style=False)
        r = a.report
        h = a.problem.hit
        if r["reachable"]:
            reached += 1
            assert r["hit_error_m"] < 1e-3 and r["short_by_m"] == 0.0, (dy, dz, r)
        else:  # stopped short where the second hand cannot follow: at the stopped target exactly
            assert r["short_by_m"] > 0 and np.linalg.norm(a.achieved[h] - a.problem.target) < 1e-3, (dy, dz, r)
        assert a.goal_error[h] < 1e-3
        # the goals are met but in the quarter second around the hit, where the joints ramp in and out
        # no faster than twice their own peak in the source (the club sweeps the blend up in 4 frames)
        off_goal = np.flatnonzero(a.goal_error > 1e-3)
        assert np.all(np.abs(off_goal - h) <= 0.125 * s.fps), (dy, dz, off_goal)
        assert r["joint_speed_ratio"] <= 1.1 * hitpoint.JOINT_SPEED_BOUND, (dy, dz, r)
        assert r["grip_error_m"] < 2e-3, (dy, dz, r)
        assert np.array_equal(a.motion.rotations[[0, -1]], s.rotations[[0, -1]])
        assert np.array_equal(a.motion.rotations[:, [0] + legs], s.rotations[:, [0] + legs])
        assert np.array_equal(a.motion.root_positions, s.root_positions)
    assert reached >= 6, reached


def _all_coordinates_within_limits(a) -> float:
    """Largest excursion (radians) of any free coordinate of either chain beyond its limits, any frame."""
    worst = 0.0
    for c in (a.problem.lead, a.problem.second):
        if c is None or not c.n_dof:
            continue
        x = c.coordinates(a.motion.rotations[:, c.joint_indices])
        lo = np.concatenate([j.lower for j in c.joints])
        hi = np.concatenate([j.upper for j in c.joints])
        worst = max(worst, float(np.max(np.maximum(lo - x, x - hi))))
    return worst


@pytest.mark.parametrize("solver", ["nlp", "dls"])
def test_unreachable_target_stops_short_with_the_limits_and_the_grip_kept(short, solver):
    """Issue 18 item 10: a target 2 m across (or 0.5 m down, under the floor) is not chased.

    The target stops short along the offset where the chains can reach it with the second hand on
    the grip and the club off the floor; the result meets that point exactly, keeps every limit
    exactly on the joints' own angles (box bounds on the IK coordinates exceeded them by up to
    111°), moves no joint the source never turns (CMU's clavicles and hip joints), and no chain
    joint turns faster than about twice its own source peak (it was 11–46×).
    """
    s, prop = short
    static = [j for j in range(s.skeleton.n_joints) if np.max(rot.angle_between(s.rotations[:, j], s.rotations[:1, j])) == 0.0]
    assert {"lclavicle", "rclavicle", "lhipjoint", "rhipjoint"} <= {s.skeleton.names[j] for j in static}
    for off in (np.array([0.0, 2.0, 0.0]), np.array([0.0, 0.0, -0.5])):
        a = hitpoint.adapt(s, offset=off, prop=prop, solver=solver, style=False)
        r, h = a.report, a.problem.hit
        assert not r["reachable"] and "stopped" in r["message"], r
        assert r["short_by_m"] > 0.3 and abs(r["hit_error_m"] - r["short_by_m"]) < 2e-3, r
        assert np.linalg.norm(a.achieved[h] - np.array(r["stopped_target"])) < 1e-3
        assert r["grip_error_m"] < 2e-3, r
        assert _all_coordinates_within_limits(a) < 1e-9
        assert np.array_equal(a.motion.rotations[:, static], s.rotations[:, static])
        assert hitpoint.source_kept(a) == (True, True)
        # (DLS, 2 m across: the second arm at the edge of its reach, 2.8×; it cannot be paced further
        # without leaving the grip)
        assert r["joint_speed_ratio"] <= 1.5 * hitpoint.JOINT_SPEED_BOUND, r
        # the club's lowest point (shaft radius included) no lower than the source's own lowest
        assert r["lowest_above_floor_m"] >= -0.02, r


def test_a_hit_shortened_with_its_neighbours_says_how_far_short():
    """Issue 18 item 10: where frames beside the hit cannot meet their goals either, the gradual
    shortening moves the hit with them; the report's stopped target is then what the hit meets and
    ``short_by_m`` how far that is from the asked target (it read 0 with the hit 39 mm off). The
    golf swing 64_03, 40 cm up and 20 cm across (a target of the hit-point grid): 24 frames shortened.
    (The bundled drive no longer shows it: its arms keep room at the hit, synth.body.hit_fill.)"""
    from conftest import require_data

    m = bvh.read(require_data() / "cmu_asfamc_converted" / "64_03.bvh")
    prop = hitpoint.fit_club(m)
    base = hitpoint.setup(m, offset=np.zeros(3), prop=prop)
    offs = np.array(hitpoint.target_grid(base, 0.2))
    off = offs[np.argmin(np.linalg.norm(offs - np.array([-0.04, -0.2, 0.4]), axis=1))]
    a = hitpoint.adapt(m, offset=off, frame=base.hit, solver="dls", prop=prop, style=False)
    r = a.report
    assert r["frames_shortened"] > 0 and not r["reachable"], r
    assert r["short_by_m"] > 0.01 and abs(r["hit_error_m"] - r["short_by_m"]) < 2e-3, r
    assert np.linalg.norm(a.achieved[base.hit] - np.array(r["stopped_target"])) < 1e-3


@pytest.mark.parametrize("solver", ["nlp", "dls", "nlp-shot"])
def test_cone_limits_on_the_local_rotation_angle_hold(short, solver):
    """A per-joint max rotation angle (a model's joint ranges, ``mjmotion.limits.joint_limits``'s
    format) holds exactly at every frame: a joint the source keeps within its cone stays within it,
    one the source takes beyond it goes no further. Synthetic limits: each chain joint's largest
    angle at the hit frame plus 1°, so the IK has to work against them there."""
    s, prop = short
    sl = s[60:110]  # around the hit
    base = hitpoint.setup(sl, offset=np.zeros(3), prop=prop)
    limits = np.full(s.skeleton.n_joints, np.inf)
    joints = [cj.joint for c in (base.lead, base.second) for cj in c.joints if cj.dof]
    angle = rotation_angle(sl.rotations)  # (T, J)
    limits[joints] = angle[base.hit, joints] + np.deg2rad(1.0)
    unlimited = np.full(s.skeleton.n_joints, np.inf)  # (the default is the judge's ranges)
    free = hitpoint.adapt(sl, offset=np.array([0.0, 0.15, 0.1]), prop=prop, solver=solver, style=False, edge=0.05, joint_limits=unlimited)
    a = hitpoint.adapt(sl, offset=np.array([0.0, 0.15, 0.1]), prop=prop, solver=solver, style=False, edge=0.05, joint_limits=limits)
    over = rotation_angle(a.motion.rotations[:, joints]) - np.maximum(limits[joints], angle[:, joints])
    assert over.max() < 1e-8  # IPOPT: to its constraint tolerance (1e-9 on the trace); DLS: exactly
    # without them some joint does go beyond, and with them some joint sits on its cone
    assert (rotation_angle(free.motion.rotations[:, joints]) - limits[joints]).max() > np.deg2rad(1.0)
    assert over.max() > -1e-5


def test_an_adapted_shot_stays_within_the_judges_joint_ranges(tmp_path):
    """By default the chains keep within the joint ranges the judge compiles into the model
    (``mjmotion.limits``) and ``evaluate`` counts: 64_05's hit point 60 cm up (unreachable, so
    the deviation is paced in and out over 260 frames) took ``rwrist`` 10° past its 90° when
    the paced frames stepped between two frames' solutions."""
    from conftest import require_data

    from mjmotion import evaluate, limits

    m = bvh.read(require_data() / "cmu_asfamc_converted" / "64_05.bvh")
    a = hitpoint.adapt(m, offset=np.array([0.0, 0.0, 0.6]), solver="dls", style=False)
    assert a.report["frames_paced"] > 100
    lim = limits.joint_limits(m.skeleton)
    src, out = limits.rotation_angles(m.rotations), limits.rotation_angles(a.motion.rotations)
    assert (out - np.maximum(lim, src)).max() < 1e-9  # no joint beyond its range where the source is within it, none further where it is not
    # as the judge reads the written file (its angles rounded to six decimals)
    bvh.write(a.motion, tmp_path / "a.bvh")
    compiled = mjcf.compile(m.skeleton)
    assert evaluate.limit_violation_ratio(compiled, bvh.read(tmp_path / "a.bvh"))[0] <= evaluate.limit_violation_ratio(compiled, m)[0]


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
    a = hitpoint.adapt(sl, offset=np.array([0.0, 0.1, 0.05]), prop=prop, solver="nlp-shot", falloff=0.4, edge=0.05, style=False)
    r = a.report
    assert r["hit_error_m"] < 1e-3 and r["max_goal_error_m"] < 1e-3 and r["grip_error_m"] < 5e-3, r
    assert np.array_equal(a.motion.rotations[[0, -1]], sl.rotations[[0, -1]])
    # The smoothness term makes the deviation from the source vary more smoothly than per-frame IK.
    b = hitpoint.adapt(sl, offset=np.array([0.0, 0.1, 0.05]), prop=prop, solver="nlp", falloff=0.4, edge=0.05, style=False)

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
    # still in the source (no degree of freedom in CMU's skeleton) → not a freedom of the chain
    assert "lclavicle" in p.lead.names and "lclavicle" not in names
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


def test_the_seeds_solver_ccd_reaches_within_exact_limits(short):
    """CCD (seed 003 §2.2.1) on the impact window: a target 10 cm across and up is met at the hit
    with the grip kept, every free angle within its limits exactly and the joints' pace bounded.
    (Table 2.1's direction, locked wrist vs 2-DOF, is measured over the whole swings by
    experiments/hitpoint_grid.py and reported per solver, whichever way it goes.)"""
    s, prop = short
    sl = s[60:110]
    base = hitpoint.setup(sl, offset=np.zeros(3), prop=prop)
    axes = across(base)
    a = hitpoint.adapt(sl, offset=0.1 * axes[0] + 0.1 * axes[1], prop=prop, solver="ccd", style=False, edge=0.05)
    r = a.report
    assert r["reachable"] and r["hit_error_m"] < 1e-3 and r["grip_error_m"] < 2e-3, r
    assert _all_coordinates_within_limits(a) < 1e-12
    assert r["joint_speed_ratio"] <= 1.1 * hitpoint.JOINT_SPEED_BOUND


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


def test_a_hit_at_the_clips_first_or_last_frame_is_refused_before_solving():
    """The edit keeps a clip's first and last frames (end_taper): a hit there moved nothing and was then
    reported "unreachable, stopped 0.000 m short"."""
    from mjmotion import synth

    drive = synth.drive()
    m = drive.motion
    for frame in (0, m.n_frames - 1):
        with pytest.raises(MjmotionError, match=rf"^frame {frame} is not inside the clip's frames 1\.\.{m.n_frames - 2}"):
            hitpoint.setup(m, offset=np.array([0.0, 0.0, 0.01]), frame=frame, prop=drive.prop)
    assert hitpoint.setup(m, offset=np.array([0.0, 0.0, 0.01]), frame=1, prop=drive.prop).hit == 1
    with pytest.raises(MjmotionError, match=r"^frame 1 is not inside a clip of 2 frames;"):  # it read "frames 1..0"
        hitpoint.setup(m[:2], offset=np.array([0.0, 0.0, 0.01]), frame=1, prop=drive.prop)


def test_a_lock_or_wrist_the_chain_has_no_joint_for_is_refused_and_one_it_has_locks_it():
    """A foot's chain has no wrist and no arm joint: ``wrist`` and ``lock`` of those gave the result of
    leaving them out (a sweep of the CLI). A joint of the chain that is locked keeps the source's rotation."""
    from mjmotion import synth

    kick = synth.kick().motion
    names = kick.skeleton.names
    foot = hitpoint.resolve_effector(kick, "right_foot")[0].joint
    chain = [names[j] for j in kick.skeleton.chain(hitpoint._chain_start(kick.skeleton, foot), foot)]
    arm = next(n for n in names if n not in chain and "Arm" in n)
    with pytest.raises(MjmotionError, match=rf"^wrist swing: the chain {chain[0]} → {chain[-1]} \(.*\) has no wrist joint"):
        hitpoint.setup(kick, offset=np.array([0.1, 0.0, 0.0]), effector="right_foot", wrist="swing")
    with pytest.raises(MjmotionError, match=rf"^lock {arm}: not a joint of the chain {chain[0]} → {chain[-1]}"):
        hitpoint.setup(kick, offset=np.array([0.1, 0.0, 0.0]), effector="right_foot", lock=[arm])
    knee = names.index(chain[-2])
    free = hitpoint.adapt(kick, offset=np.array([0.1, 0.0, 0.0]), effector="right_foot", solver="dls", style=False)
    held = hitpoint.adapt(kick, offset=np.array([0.1, 0.0, 0.0]), effector="right_foot", solver="dls", style=False, lock=[chain[-2]])
    assert not np.allclose(free.motion.rotations[:, knee], kick.rotations[:, knee])
    assert np.allclose(held.motion.rotations[:, knee], kick.rotations[:, knee])


def test_adapt_refuses_numbers_that_are_no_setting():
    """A NaN or negative margin returned "unreachable" having moved nothing; a NaN edge or frame, or a
    target of text, was a raw ValueError; a fractional frame was cut to a whole one."""
    from mjmotion import synth

    drive = synth.drive()
    nan = float("nan")
    for kwargs, message in (
        (dict(margin=nan), "margin=nan: expected a finite number"),
        (dict(margin=-10.0), "margin=-10.0: expected a finite number ≥ 0"),
        (dict(edge=nan), "edge=nan"),
        (dict(frame=nan), "frame=nan: expected a whole frame number"),
        (dict(frame=65.7), "frame=65.7: expected a whole frame number"),
        (dict(smoothness=-1.0), "smoothness=-1.0"),
    ):
        with pytest.raises(MjmotionError, match=message):
            hitpoint.adapt(drive.motion, offset=[0.0, 0.0, 0.1], prop=drive.prop, solver="dls", **kwargs)
    with pytest.raises(MjmotionError, match="target: expected 3 finite numbers"):
        hitpoint.adapt(drive.motion, target="abc", prop=drive.prop, solver="dls")
