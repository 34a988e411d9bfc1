"""Metrics of mjmotion.evaluate on controlled cases with known answers, and sanity on real clips."""

from __future__ import annotations

import dataclasses
import json
import math

import mujoco
import numpy as np
import pytest
from conftest import clip_params, linear_blend, require_data, shared_clip

from mjmotion import bvh, feet, kinematics, mjcf, physics
from mjmotion import evaluate as ev
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.skeleton import Motion
from mjmotion.trim import leading_transient


def _ground(m: Motion, floor: float | None = 0.0, soles=None) -> ev.GroundMetrics:
    """Ground metrics as the judge measures them (soles for feet), from ``floor`` (None: detected)."""
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    tr = ev.foot_heights_speeds(c, m, pose, floor=floor, soles=soles)
    return ev.ground_metrics(ev.lowest_body_point(c, pose, tr.heights.min(axis=1) + tr.floor), tr)


def _on_floor(m: Motion):
    """The clip moved vertically, frame by frame, so its lowest point (soles included) touches z = 0,
    and its soles (calibrated on the clip as captured)."""
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    tr = ev.foot_heights_speeds(c, m, pose, floor=0.0)
    lz = ev.lowest_body_point(c, pose, tr.heights.min(axis=1))
    return m.replace(root_positions=m.root_positions - np.outer(lz, [0, 0, 1])), tr.soles


# ----------------------------------------------------------------- geometry


def test_lowest_point_matches_mujoco_collision():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[100:103]
    sunk = m.replace(root_positions=m.root_positions - [0, 0, 0.04])
    c = mjcf.compile(m.skeleton)
    lz = ev.lowest_body_point(c, kinematics.forward(c, sunk))
    mm = c.model
    d = mujoco.MjData(mm)
    floor = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    for t, q in enumerate(kinematics.qpos(c, sunk)):
        d.qpos[:] = q
        mujoco.mj_forward(mm, d)
        dists = [d.contact[i].dist for i in range(d.ncon) if floor in (d.contact[i].geom1, d.contact[i].geom2)]
        # MuJoCo's plane contacts report the signed distance of the deepest point: minus our height.
        assert min(dists) == pytest.approx(lz[t], abs=1e-6)


def test_box_lowest_point_is_lowest_corner():
    rng = np.random.default_rng(0)
    q = rot.normalize(rng.normal(size=(50, 1, 4)))
    mat = rot.to_matrix(q)
    pos = rng.normal(size=(50, 1, 3))
    half = np.array([[0.1, 0.04, 0.02]])
    corners = ev.box_corners(pos, mat, half)
    s = -np.sign(mat[:, :, 2, :])
    lowest = pos + np.einsum("tbij,tbj->tbi", mat, s * half)
    assert np.allclose(lowest[..., 2], corners[..., 2].min(axis=2))


# ----------------------------------------------------------------- contacts and footskate


def _synthetic_track(heights: np.ndarray, speeds_xy: np.ndarray, fps: float = 100.0) -> ev.FootTrack:
    """One-point feet: heights (T, F), horizontal velocity (T, F, 2) integrated into positions."""
    xy = np.cumsum(speeds_xy, axis=0) / fps
    pts = np.concatenate([xy, heights[..., None]], axis=-1)[:, :, None, :]
    return ev.foot_track(("left", "right")[: heights.shape[1]], pts, fps)


def test_contacts_follow_thresholds():
    t = 40
    h = np.full((t, 1), 0.02)
    h[10:20] = 0.2  # lifted
    v = np.zeros((t, 1, 2))
    v[30:, 0, 0] = 1.0  # sliding fast
    tr = _synthetic_track(h, v)
    con = ev.contacts(tr)[:, 0]
    assert not con[10:21].any()  # frame 20 is low but frame 19 was not
    assert con[2:9].all() and con[22:29].all()
    assert not con[32:38].any()
    assert ev.planted_skate_mm_per_s(tr) == pytest.approx(1000.0 * tr.speeds[con[:, None]].mean())


def test_contact_hysteresis_holds_a_label_at_the_threshold():
    """A foot planted at 2 cm that then hovers around h_c stays in contact until it reaches h_c;
    one that arrives hovering at 4.5 cm never enters (entry needs (1 - 0.2)·h_c = 4 cm). With no
    hysteresis the label is the plain threshold, flickering with the hover."""
    t = 60
    h = np.full((t, 2), 0.02)
    wobble = np.where(np.arange(30) % 2 == 0, 0.045, 0.035)
    h[30:, 0] = wobble  # planted, then wobbling under h_c
    h[:, 1] = np.where(np.arange(t) % 2 == 0, 0.045, 0.055)  # never clearly down
    tr = _synthetic_track(h, np.zeros((t, 2, 2)))
    con = ev.contacts(tr)
    assert con[1:, 0].all() and not con[:, 1].any()
    plain = ev.contacts(tr, hysteresis=0.0)
    assert np.array_equal(plain, ev.low_both(tr) & (tr.speeds < ev.V_C))
    assert plain[1:, 1].sum() == 0 and plain[30:, 0].all()  # frame 0 has no earlier frame to be higher at
    # Every contact frame is below h_c and slower than v_c, hysteresis or not.
    rng = np.random.default_rng(2)
    tr2 = _synthetic_track(rng.uniform(0.0, 0.08, (200, 2)), rng.normal(0, 0.3, (200, 2, 2)))
    c2 = ev.contacts(tr2)
    assert np.all(tr2.heights[c2] < ev.H_C) and np.all(tr2.speeds[c2] < ev.V_C)
    assert not (c2 & ~ev.contacts(tr2, hysteresis=0.0)).any()


def test_skating_ratio_known_fraction():
    t = 100
    h = np.full((t, 2), 0.01)
    v = np.zeros((t, 2, 2))
    v[50:, 0, 0] = 0.8  # left foot skates for the second half
    tr = _synthetic_track(h, v)
    assert ev.skating_ratio(tr) == pytest.approx(0.5, abs=0.03)
    assert ev.skating_ratio(tr, v=1.0) == 0.0
    rows = ev.skate_sensitivity(tr)
    assert [r["h_c"] for r in rows] == [0.03, 0.05, 0.08]
    h[:, :] = 0.04  # between 3 and 5 cm: only the larger thresholds see the feet low
    tr = _synthetic_track(h, v)
    rows = ev.skate_sensitivity(tr)
    # Height-weighted, pooled over feet and frames: the left foot at 800 mm/s for half the frames,
    # the right still, both weighted 2 - 2^(h/h_c).
    assert math.isnan(rows[0]["skate_mm_per_s"])
    for r in rows[1:]:
        assert r["skate_mm_per_s"] == pytest.approx(200 * (2 - 2 ** (0.04 / r["h_c"])), rel=0.03)
    assert ev.skate_weights(np.array([-0.01, 0.0, 0.05, 0.08])).tolist() == [1.0, 1.0, 0.0, 0.0]


def test_foot_dragged_at_0_3_m_s_gives_300_mm_s():
    stand = shared_clip("cmu_asfamc_converted/64_01.bvh")[:120]  # golf address: both feet planted
    base = ev.planted_skate_mm_per_s(stand)
    assert base < 80
    dragged = stand.replace(root_positions=stand.root_positions + np.outer(stand.times, [0.3, 0.0, 0.0]))
    assert ev.planted_skate_mm_per_s(dragged) == pytest.approx(300.0, abs=max(40.0, base))
    assert ev.skating_ratio(dragged) == 0.0  # 0.3 m/s is below GMD's 0.5 m/s
    fast = stand.replace(root_positions=stand.root_positions + np.outer(stand.times, [0.8, 0.0, 0.0]))
    assert ev.skating_ratio(fast) > 0.9


def test_the_bundled_walk_whose_toes_stand_still_reads_no_planted_skate():
    """The procedural walk holds each toe joint exactly on its footprint through stance: measured
    from the plant's own frames it reads ~0 (the swing's speed once leaked into each plant's edges: 16 mm/s)."""
    from mjmotion import synth

    walk = synth.walk(seconds=2.0).motion
    assert ev.planted_skate_mm_per_s(walk) < 1.0


def test_clean_walk_skates_far_less_than_walk_run_blend():
    walk = shared_clip("cmu_iclone_ccrig/002_01.bvh")
    run = shared_clip("cmu_iclone_ccrig/002_03.bvh")
    blend = linear_blend(walk, run)
    w, b = ev.foot_heights_speeds(None, walk[: blend.n_frames]), ev.foot_heights_speeds(None, blend)
    assert ev.skate_mm_per_s(w) < 0.5 * ev.skate_mm_per_s(b)
    assert ev.planted_skate_mm_per_s(w) < 0.5 * ev.planted_skate_mm_per_s(b)


# ----------------------------------------------------------------- ground


def test_shift_down_3cm_penetrates_30mm_and_float_10cm():
    m, soles = _on_floor(shared_clip("cmu_asfamc_converted/16_15.bvh", 2))
    g0 = _ground(m, soles=soles)
    assert g0.penetrate_mm == pytest.approx(0.0, abs=1e-6) and g0.float_mm == pytest.approx(0.0, abs=1e-6)
    down = m.replace(root_positions=m.root_positions - [0, 0, 0.03])
    g = _ground(down, soles=soles)
    assert g.penetrate_mm == pytest.approx(30.0, abs=0.01) and g.float_mm == 0.0 and g.floor_m == 0.0
    assert g.floor_offset_m == pytest.approx(-0.03, abs=0.002)  # its own stance floor, reported
    up = m.replace(root_positions=m.root_positions + [0, 0, 0.10])
    g = _ground(up, soles=soles)
    assert g.float_mm == pytest.approx(95.0, abs=0.01) and g.penetrate_mm == 0.0
    assert g.phys_err_mm >= g.float_mm
    # Measured from its own detected floor, the moved clip reads as it did.
    assert _ground(up, None, soles).float_mm == pytest.approx(_ground(m, None, soles).float_mm, abs=0.5)


def test_floor_is_given_then_from_sources_then_detected():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh", 2)
    up = m.replace(root_positions=m.root_positions + [0, 0, 0.07], name="up")
    own = ev.evaluate(up)
    assert own.floor_from == "detected" and own.floor_m == pytest.approx(ev.evaluate(m).floor_m + 0.07, abs=0.003)
    judged = ev.evaluate(up, sources=[m])
    assert judged.floor_from == "source" and judged.floor_m == pytest.approx(own.floor_m - 0.07, abs=0.003)
    assert judged.float_mm > own.float_mm + 50 and judged.flight_fraction > 0.9
    given = ev.evaluate(up, sources=[m], floor=0.25)
    assert given.floor_from == "given" and given.floor_m == 0.25 and given.penetrate_mm > 100
    note = ev.evaluate(shared_clip("cmu_asfamc_converted/64_04.bvh")).notes()
    assert note and "detected floor -0.0" in note[0] and "below z = 0" in note[0]  # SOURCES.md: subject 64's floor


def test_detected_floor_ignores_a_leading_t_pose_and_flight():
    """cgspeed daz clips open with a T-pose and 3 frames into the capture; a run is mostly flight."""
    walk = shared_clip("cmu_cgspeed_daz/07_01.bvh")
    assert ev.evaluate(walk).floor_m == pytest.approx(ev.evaluate(walk[4:]).floor_m, abs=0.003)
    run = shared_clip("cmu_cgspeed_daz/09_01.bvh", 3)
    r = ev.evaluate(run)
    assert r.flight_fraction > 0.3 and abs(r.floor_m - ev.evaluate(run[: run.n_frames // 2]).floor_m) < 0.01


def test_golf_floor_detected_below_zero():
    # SOURCES.md: subject 64's floor is 2-4 cm below y = 0 (its feet sink through z = 0).
    g = _ground(shared_clip("cmu_asfamc_converted/64_03.bvh"), None)
    assert g.floor_m < -0.02 and g.floor_offset_m == g.floor_m
    assert _ground(shared_clip("cmu_asfamc_converted/64_03.bvh")).penetrate_mm > 10.0  # from z = 0


# ----------------------------------------------------------------- smoothness and limits


def test_joint_speed_ratio_and_root_jump():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh", 2)[:200]
    assert ev.max_joint_speed_ratio(m, m) == pytest.approx(1.0)
    assert ev.root_jump_m(m, m) == pytest.approx(0.0)
    q = m.rotations.copy()
    q[100, 5] = rot.multiply(rot.exp(np.array([0.0, 0.0, np.pi / 2])), q[100, 5])  # a one-frame pop
    root = m.root_positions.copy()
    root[120:] += [0.1, 0.0, 0.0]
    popped = m.replace(rotations=q, root_positions=root)
    assert ev.max_joint_speed_ratio(popped, m) > 1.5
    step = np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1)
    assert ev.root_jump_m(popped, m) == pytest.approx(np.linalg.norm(np.diff(root, axis=0), axis=1).max() - step.max())
    # Slowing a clip down 2x halves its angular speeds.
    slow = m.resample(m.fps * 2).replace(fps=m.fps)
    assert ev.max_joint_speed_ratio(slow, m) == pytest.approx(0.5, abs=0.05)


def test_limit_violation_ratio_counts_frames_beyond_declared_range():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh", 2)[:100]
    c = mjcf.compile(m.skeleton)
    ratio, n = ev.limit_violation_ratio(c, m)
    assert ratio == 0.0 and n == m.skeleton.n_joints - 1  # every ball joint declares a range; the walk stays inside
    j = m.skeleton.index("ltibia")
    jid = mujoco.mj_name2id(c.model, mujoco.mjtObj.mjOBJ_JOINT, "ltibia")
    angle = 2 * np.arccos(np.clip(np.abs(m.rotations[:, j, 0]), 0, 1))
    lim = float(np.median(angle))
    c.model.jnt_range[jid] = [0.0, lim]
    ratio, n = ev.limit_violation_ratio(c, m)
    assert ratio == pytest.approx(float((angle > lim).mean()))


def test_worst_joint_speed_ratio_sees_a_knee_pop_under_a_glitchy_finger():
    """The whole-body ratio is blind to a knee at 3x its own speed when the source has a fast
    glitch elsewhere (16_15's left arm is zeroed in frames 0-1); per joint it is not."""
    src = shared_clip("cmu_asfamc_converted/16_15.bvh")[:300]
    j = src.skeleton.index("ltibia")
    q = src.rotations.copy()
    t = np.arange(100, 120)
    axis = rot.log(q[:, j]).sum(axis=0)
    axis /= np.linalg.norm(axis)
    # 20 frames where the knee sweeps 1.2 rad extra and back: far faster than it ever moves.
    q[t, j] = rot.multiply(q[t, j], rot.exp(np.outer(np.sin(np.linspace(0, np.pi, 20)) * 1.2, axis)))
    res = src.replace(rotations=q)
    assert ev.max_joint_speed_ratio(res, src) <= 1.0
    worst, joint = ev.worst_joint_speed_ratio(res, src)
    assert joint == "ltibia" and worst > 2.0
    assert ev.worst_joint_speed_ratio(src, src)[0] == pytest.approx(1.0)
    # Pops: the captured glitch (the arm zeroed in frames 0-1) is found; past it the clip against
    # itself has (almost) none, and a one-frame 60° knee bend pops its three frames.
    assert ev.pop_frames(src)[:3].any()
    clean = src[2:]
    assert ev.pop_frames(clean, clean).sum() <= 2
    one = clean.rotations.copy()
    one[150, j] = rot.multiply(one[150, j], rot.exp(axis * np.radians(60)))
    popped = ev.pop_frames(clean.replace(rotations=one), clean)
    assert popped[149:152].all() and popped.sum() <= 3 + ev.pop_frames(clean, clean).sum()
    assert ev.joint_angular_accelerations(src)[[0, -1]].max() == 0.0


def test_joint_angular_speeds_and_accelerations_are_in_radians_per_second():
    """A joint turning with a known angular acceleration (10 rad/s² about x, then about a tilted axis)
    reads it, and its speed, in true units (the acceleration read twice its value until 2026-12)."""
    from mjmotion import synth

    m = synth.walk(seconds=1.0).motion
    t = np.arange(m.n_frames) / m.fps
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])):
        q = m.rotations.copy()
        q[:, 3] = rot.exp((0.5 * 10.0 * t * t)[:, None] * axis)
        turned = m.replace(rotations=q)
        assert ev.joint_angular_accelerations(turned)[1:-1, 3] == pytest.approx(10.0, rel=1e-6)
        assert ev.joint_angular_speeds(turned)[:, 3] == pytest.approx(10.0 * (t[:-1] + 0.5 / m.fps), rel=1e-6)


def test_leading_transient_finds_daz_tpose():
    m = shared_clip("cmu_cgspeed_daz/07_01.bvh")
    assert 3 <= leading_transient(m) <= 4
    assert leading_transient(shared_clip("cmu_asfamc_converted/16_01.bvh")) == 0


# ----------------------------------------------------------------- the report on real clips


def test_the_sensitivity_row_at_h_c_is_the_headline_with_any_skate_window():
    """The sensitivity rows took the skating ratio's default 5-frame window whatever the report's
    was, so with another window the row at the report's h_c disagreed with its headline."""
    walk = shared_clip("cmu_cgspeed_daz/07_01.bvh", 4)
    for window in (5, 15):
        rep = ev.evaluate(walk, params=ev.Params(skate_window=window))
        (row,) = [r for r in rep.sensitivity if r["h_c"] == rep.params.h_c]
        assert row["skating_ratio"] == rep.skating_ratio
    assert ev.evaluate(walk, params=ev.Params(skate_window=15)).skating_ratio != ev.evaluate(walk).skating_ratio


def test_jump_has_flight_with_small_residual_and_runs_fly():
    rep = ev.evaluate(shared_clip("cmu_asfamc_converted/16_01.bvh"))
    assert rep.flight_fraction > 0.08
    assert rep.flight_residual < 0.3
    d = rep.to_dict()
    assert d["params"]["h_c"] == 0.05 and len(d["sensitivity"]) == 3
    json.dumps(d)
    walk = ev.evaluate(shared_clip("cmu_asfamc_converted/16_15.bvh", 2))
    assert walk.flight_fraction < 0.02


#: A clean walk of every flavour, and whether it meets planted skate ≤ 80 mm/s. The cgspeed daz
#: conversion puts every subject on one 1.63 m skeleton, and its stance feet slide with the
#: pelvis (07_01 204 mm/s; the same CMU trial 07_04 reads 145 in daz and 76 in iClone); the
#: cgspeed 3dsMax flavour's only walks are stylised ("Michael Jackson") start-walk-stops.
CLEAN_WALKS = [
    ("cmu_asfamc_converted/16_15.bvh", True),
    ("cmu_iclone_ccrig/002_01.bvh", True),
    ("cmu_cgspeed_daz/07_01.bvh", False),
    ("cmu_cgspeed_max/131_02.bvh", False),
]


@pytest.mark.parametrize(("rel", "skate_ok"), CLEAN_WALKS, ids=[r.split("/")[0] for r, _ in CLEAN_WALKS])
def test_clean_walks_read_clean(rel, skate_ok):
    m = shared_clip(rel)
    m = m[leading_transient(m) :]
    r = ev.evaluate(m)
    assert r.flight_fraction <= 0.15 and r.physics_violation_ratio <= 0.2, (r.flight_fraction, r.physics_violation_ratio)
    assert r.limit_violation_ratio == 0.0 and r.pop_frames <= 5
    assert (r.planted_skate_mm_per_s <= 80) == skate_ok, r.planted_skate_mm_per_s
    assert r.planted_skate_mm_per_s < 250


@pytest.mark.parametrize("rel", ["cmu_cgspeed_daz/09_01.bvh", "cmu_iclone_ccrig/002_03.bvh", "cmu_cgspeed_max/102_01.bvh"])
def test_runs_still_show_their_flight(rel):
    m = shared_clip(rel)
    assert ev.evaluate(m[leading_transient(m) :]).flight_fraction > 0.2


@pytest.mark.parametrize("rel", ["cmu_cgspeed_daz/09_11.bvh", "cmu_cgspeed_max/102_01.bvh"])
def test_clean_runs_pass_the_physics_and_fail_it_played_twice_as_fast(rel):
    """Flights judged by their ballistic fit, the support of the filtered wrench taken over its
    filter window, toe-less feet pushing on their toes: a daz run and the 3dsMax jog pass (they
    read 0.46 and 0.14 when every flight frame carried the 6 Hz filter's spread of the stance push);
    twice as fast they fail clearly."""
    from mjmotion.experiments import corruption

    m = shared_clip(rel)
    m = m[leading_transient(m) :]
    clean = ev.evaluate(m, sources=[m.replace()])
    fast = ev.evaluate(corruption.sped_up(m), sources=[m])
    assert clean.physics_violation_ratio <= 0.2 and clean.flight_fraction > 0.2, clean.physics_violation_ratio
    assert fast.physics_violation_ratio >= clean.physics_violation_ratio + 0.25


@pytest.mark.parametrize("path", clip_params())
def test_every_shared_clip_evaluates_sanely(path):
    if path is None:
        require_data()
    m = bvh.read(path)
    m = m[leading_transient(m) :]
    rep = ev.evaluate(m)
    row = rep.row()
    assert 0.0 <= rep.skating_ratio <= 1.0 and 0.0 <= rep.physics_violation_ratio <= 1.0
    assert rep.penetrate_mm < 50 and rep.float_mm < 40  # measured from the clip's own floor
    assert abs(rep.floor_m) < 0.1 and rep.floor_from == "detected" and rep.soles_calibrated
    assert rep.limit_violation_ratio == 0.0 or m.name == "007_04"  # its frame 0 is a rest pose elsewhere
    # Standing support: the median required force is about body weight.
    assert 0.7 < rep.root_force_ratio_mean < 2.0
    assert all(k in row for k in ("planted_mm_s", "skate_mm_s", "penetrate_mm", "phys_err_mm", "floor_m", "floor_from", "pops"))


# ----------------------------------------------------------------- CLI


def test_cli_evaluate_file_json_and_csv(tmp_path, capsys):
    d = require_data()
    out = tmp_path / "r.json"
    assert main(["evaluate", str(d / "cmu_asfamc_converted/16_01.bvh"), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "skate_mm_s" in text and "parameters: h_c=0.05" in text
    doc = json.loads(out.read_text())
    assert doc[0]["report"]["flight_residual"] < 0.3
    assert main(["evaluate", str(d / "cmu_asfamc_converted/16_01.bvh"), "--json", str(out)]) == 2  # exists
    assert main(["evaluate", str(d / "cmu_asfamc_converted/16_01.bvh"), "--csv"]) == 0
    assert capsys.readouterr().out.splitlines()[0].startswith("clip,frames,fps")


def test_cli_evaluate_folder(tmp_path, capsys):
    d = require_data()
    sub = tmp_path / "clips" / "nested"
    sub.mkdir(parents=True)
    for name in ("16_01.bvh", "16_15.bvh"):
        (sub / name).write_bytes((d / "cmu_asfamc_converted" / name).read_bytes())
    assert main(["evaluate", str(tmp_path / "clips")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("16_01") and lines[2].startswith("16_15")


def test_cli_evaluate_errors(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path / "missing.bvh")]) == 2
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["evaluate", str(tmp_path / "empty")]) == 2


def test_cli_evaluate_hit_and_grid(tmp_path, capsys):
    d = require_data()
    f = str(d / "cmu_asfamc_converted/64_01.bvh")
    m = bvh.read(f)
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    spot = kinematics.forward(mjcf.compile(m.skeleton, (prop,)), m).site(prop.site)[325]
    out = tmp_path / "hit.json"
    args = ["evaluate", f, "--prop", "club:rwrist", "--ball", *map(str, spot), "--frame", "325", "--hit-grid", "2", "--json", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "hit_error_m=-0.036" in text and "contact=True" in text and "hit grid, wrist locked" in text
    doc = json.loads(out.read_text())[0]
    assert doc["report"]["hit"]["launch_contacted"] and set(doc["hit_grid"]) == {"locked", "world"}
    assert main(["evaluate", f, "--ball", "0", "0", "0"]) == 2
    assert "--frame" in capsys.readouterr().err
    # A hit frame without a ball measured nothing and said nothing.
    assert main(["evaluate", f, "--frame", "325"]) == 2
    err = capsys.readouterr().err
    assert "--frame 325" in err and "--ball" in err and "Traceback" not in err
    with pytest.raises(ev.MjmotionError, match="hit_frame=325 without a ball"):
        ev.evaluate(m, hit_frame=325)


def test_grip_error_zero_for_the_source_and_sees_a_moved_hand():
    m = shared_clip("cmu_asfamc_converted/64_01.bvh")[200:260]
    assert ev.grip_error_m(m, m, "rwrist", "lwrist") == pytest.approx(0.0, abs=1e-12)
    # Rigidly turning and moving the whole clip keeps the grip.
    q = rot.exp(np.array([0.0, 0.0, 0.7]))
    turned = m.replace(
        rotations=np.concatenate([rot.multiply(q, m.rotations[:, :1]), m.rotations[:, 1:]], axis=1),
        root_positions=rot.rotate(q, m.root_positions) + [1.0, 2.0, 0.0],
    )
    assert ev.grip_error_m(turned, m, "rwrist", "lwrist") == pytest.approx(0.0, abs=1e-9)
    # Bending the left elbow moves the left hand away from the grip.
    j = m.skeleton.index("lradius")
    bent = m.rotations.copy()
    bent[:, j] = rot.multiply(bent[:, j], rot.exp(np.array([0.3, 0.0, 0.0])))
    assert ev.grip_error_m(m.replace(rotations=bent), m, "rwrist", "lwrist") > 0.03


def test_short_and_footless_clips_give_clear_errors_or_results():
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")
    assert ev.evaluate(m[10:15]).n_frames == 5  # the difference stencil shrinks to fit
    with pytest.raises(ev.MjmotionError, match="at least 3 frames"):
        ev.evaluate(m[10:12])
    from conftest import random_motion, random_skeleton

    rng = np.random.default_rng(1)
    skel = random_skeleton(rng, 5)
    with pytest.raises(ev.MjmotionError, match="no feet"):
        ev.evaluate(random_motion(rng, skel, 10))


def test_cli_evaluate_report_never_replaces_a_clip_it_reads(tmp_path, capsys):
    """--json naming the clip (or one of a folder's clips, by any spelling or a link) is refused
    before any work, even with --force; another path inside the folder is fine."""
    folder = tmp_path / "clips"
    folder.mkdir()
    clip = folder / "walk.bvh"
    bvh.write(shared_clip("cmu_asfamc_converted/16_15.bvh")[10:40], clip)
    data = clip.read_bytes()
    (tmp_path / "link.bvh").symlink_to(clip)
    for path, target in ((clip, clip), (clip, folder / "." / "walk.bvh"), (clip, tmp_path / "link.bvh"), (folder, clip)):
        assert main(["evaluate", str(path), "--json", str(target), "--force"]) == 2
        err = capsys.readouterr().err
        assert "is an input of this command" in err and "Traceback" not in err
        assert clip.read_bytes() == data
    report = folder / "report.json"
    assert main(["evaluate", str(folder), "--json", str(report), "--jobs", "1"]) == 0
    assert json.loads(report.read_text())[0]["report"]["n_frames"] == 30


@pytest.mark.parametrize(
    "extra",
    [("--h-c", "-1"), ("--h-c", "0"), ("--v-c", "nan"), ("--v-c", "-0.5"), ("--grid-step", "inf"), ("--grid-step", "-0.05"),
     ("--ball-radius", "0"), ("--jobs", "0"), ("--hit-grid", "1"), ("--ball-velocity", "0", "nan", "0")],
)  # fmt: skip
def test_cli_evaluate_refuses_bad_numbers_by_option(extra, tmp_path, capsys):
    clip = tmp_path / "walk.bvh"
    bvh.write(shared_clip("cmu_asfamc_converted/16_15.bvh")[10:40], clip)
    out = tmp_path / "r.json"
    assert main(["evaluate", str(clip), "--json", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {extra[0]} ") and "expected" in err and "Traceback" not in err
    assert not out.exists()


def test_params_refuse_non_physical_thresholds():
    for field, value in (("h_c", -1.0), ("v_c", float("nan")), ("float_tol", 0.0), ("residual_tol", -0.1), ("skate_window", 0), ("hysteresis", 1.0)):
        with pytest.raises(ev.MjmotionError, match=f"Params.{field}"):
            ev.Params(**{field: value})
    with pytest.raises(ev.MjmotionError, match="h_c_sensitivity"):
        ev.Params(h_c_sensitivity=(0.03, -1.0))
    assert ev.Params(h_c=0.03, v_c=0.2).h_c == 0.03


def test_cli_evaluate_floor_and_source(tmp_path, capsys):
    d = require_data()
    walk = d / "cmu_asfamc_converted/16_15.bvh"
    m = bvh.read(walk)
    up = tmp_path / "up.bvh"
    bvh.write(m.replace(root_positions=m.root_positions + [0, 0, 0.05]), up)
    out = tmp_path / "r.json"
    assert main(["evaluate", str(up), "--source", str(walk), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "against 1 source(s): worst_joint_speed_ratio 1.00" in text
    rep = json.loads(out.read_text())[0]["report"]
    assert rep["floor_from"] == "source" and rep["float_mm"] > 40 and rep["sources"] == 1
    assert main(["evaluate", str(up), "--floor", "0.05"]) == 0
    assert " given" in capsys.readouterr().out


@pytest.mark.parametrize("case", ["floor nan", "floor inf", "other skeleton", "other fps", "itself", "a copy of itself", "folder", "too short"])
def test_cli_evaluate_refuses_a_bad_floor_or_source(case, tmp_path, capsys):
    d = require_data()
    clip = tmp_path / "walk.bvh"
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[10:80]
    bvh.write(m, clip)
    extra = {
        "floor nan": ["--floor", "nan"],
        "floor inf": ["--floor", "inf"],
        "other skeleton": ["--source", str(d / "cmu_cgspeed_daz/07_01.bvh")],
        "other fps": ["--source", str(tmp_path / "slow.bvh")],
        "itself": ["--source", str(clip)],
        "a copy of itself": ["--source", str(tmp_path / "copy.bvh")],
        "folder": ["--source", str(clip)],
        "too short": ["--source", str(tmp_path / "short.bvh")],
    }[case]
    bvh.write(m.resample(60.0), tmp_path / "slow.bvh")
    # (3 frames: the judge takes it as a clip, but as a reference it read a thumb at 377x its "peak")
    bvh.write(m[:3], tmp_path / "short.bvh")
    (tmp_path / "copy.bvh").write_bytes(clip.read_bytes())
    target = str(tmp_path) if case == "folder" else str(clip)
    assert main(["evaluate", target, *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {extra[0]} ") and err.count("\n") == 1 and "Traceback" not in err, err
    # A copy is named as a copy (it said "is the result itself" of another file).
    if case in ("itself", "a copy of itself"):
        assert ("is the result itself" in err) == (case == "itself") and ("a copy" in err) == (case != "itself"), err
    if case == "too short":  # named: it blamed the judged clip ("walk.bvh: a clip needs at least 2 frames")
        assert "short.bvh: 3 frames" in err and "needs at least 21 frames" in err, err


def test_sources_the_judge_cannot_take_are_refused_by_name_and_the_commands_want_one_low_pass_period():
    # A 1-frame source read as an error of the judged clip ("a clip needs at least 2 frames for foot speeds").
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[10:80]
    with pytest.raises(ev.MjmotionError, match=r"source 1 \(.*\): 2 frames; the judge needs at least 3 frames of a source"):
        ev.evaluate(m, sources=[m[:2]])
    assert ev.evaluate(m, sources=[m[:3]]).sources == 1  # the API takes what the judge takes; the commands ask more
    # One period of the 6 Hz low-pass between first and last frame, however the frame time rounds 1/120.
    assert feet.min_source_frames(120.0) == feet.min_source_frames(1 / 0.0083333) == 21 and feet.min_source_frames(60.0) == 11
    assert feet.source_too_short(m[:20]) is not None and feet.source_too_short(m[:21]) is None
    assert feet.source_too_short(m[:3], speed_reference=False) is None


def test_a_clip_resampled_to_its_sources_rate_as_written_is_judged_against_it(tmp_path, capsys):
    """cgspeed writes Frame Time .0083333 (120.0005 fps): `convert --fps 120` of such a clip was refused as
    its source ("120 fps, r120.bvh 120 fps; resample one first"), and resampling could not help."""
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[10:130]
    src, r120 = tmp_path / "src.bvh", tmp_path / "r120.bvh"
    src.write_text(bvh.format_motion(m).replace(f"Frame Time: {bvh.frame_time_text(m.fps)}", "Frame Time: .0083333"))
    assert bvh.read(src).fps != 120.0
    assert main(["convert", str(src), str(r120), "--fps", "120"]) == 0
    assert main(["evaluate", str(r120), "--source", str(src)]) == 0, capsys.readouterr().err
    assert main(["convert", str(src), str(tmp_path / "r119.bvh"), "--fps", "119.9"]) == 0  # another rate is still refused
    assert main(["evaluate", str(tmp_path / "r119.bvh"), "--source", str(src)]) == 2
    assert "119.9 fps; resample one first" in capsys.readouterr().err


def test_the_judge_reuses_a_compiled_model_only_for_an_equal_skeleton_and_props(tmp_path):
    """evaluate compiles a skeleton once per process (judge_model): an equal skeleton read again
    gets the same model, other props or another skeleton a new one, and the report is the same
    as from a fresh compile."""
    from mjmotion import synth

    walk = synth.walk(seconds=1.0).motion
    bvh.write(walk, tmp_path / "walk.bvh")
    walk = bvh.read(tmp_path / "walk.bvh")
    again = bvh.read(tmp_path / "walk.bvh")  # an equal skeleton, another object
    ev._models.clear()
    first = ev.judge_model(walk.skeleton)
    assert ev.judge_model(again.skeleton) is first
    assert ev.judge_model(walk.skeleton, (mjcf.Prop(name="bat", joint="RightHand", **mjcf.PROP_PRESETS["bat"]),)) is not first
    longer = walk.skeleton.offsets.copy()
    longer[1:] *= 1.1
    assert ev.judge_model(dataclasses.replace(walk.skeleton, offsets=longer)) is not first
    warm = json.dumps(ev.evaluate(walk).to_dict())
    ev._models.clear()
    assert json.dumps(ev.evaluate(again).to_dict()) == warm


def test_a_walk_on_a_tilted_floor_is_levelled_before_it_is_judged(tmp_path):
    """The bundled walk (a level floor) turned 1.2° about y, so its floor rises 2.1 cm per metre
    along x: the judge finds the tilt and reads what it reads on the level original; measured from
    a flat floor (--floor) the ends of the walk would sink into it and float above it."""
    from mjmotion import floor as floors
    from mjmotion import synth
    from mjmotion.feet import level_motion

    walk = synth.walk(seconds=4.0).motion
    phi = -np.radians(1.2)
    tilt = floors.Level((float(np.cos(phi / 2)), 0.0, float(np.sin(phi / 2)), 0.0), (0.0, 0.0, 0.0), 1.2)
    tilted = level_motion(tilt, walk)
    flat, judged = ev.evaluate(walk), ev.evaluate(tilted)
    assert flat.floor_tilt_deg == 0.0
    assert judged.floor_tilt_deg == pytest.approx(1.2, abs=0.1) and judged.floor_rise[0] == pytest.approx(np.tan(np.radians(1.2)), abs=2e-3)
    for k in ("planted_skate_mm_per_s", "penetrate_mm", "float_mm", "flight_fraction", "physics_violation_ratio"):
        assert getattr(judged, k) == pytest.approx(getattr(flat, k), abs=2.0 if k.endswith("_s") or k.endswith("mm") else 0.03), k
    assert any("tilts 1.2°" in n for n in judged.notes())
    level_z = ev.evaluate(tilted, floor=judged.floor_m)  # a given floor is level
    assert level_z.floor_tilt_deg == 0.0 and level_z.penetrate_mm + level_z.float_mm > flat.penetrate_mm + flat.float_mm + 10
    # A ball is given in the captured frame: the hitting metrics are those of the clip as captured.
    ball = mjcf.Ball(position=tuple(float(v) for v in kinematics.forward(mjcf.compile(tilted.skeleton), tilted).joint_positions[100, 20]))
    with_ball = ev.evaluate(tilted, ball=ball, hit_frame=100, launch=False)
    assert json.dumps(with_ball.hit) == json.dumps(physics.hit_metrics(tilted, ball, 100, launch=False))
    # Judged against its tilted source, a copy lifted 5 cm floats by the 5 cm (less the 5 mm tolerance).
    up = tilted.replace(root_positions=tilted.root_positions + [0.0, 0.0, 0.05])
    assert ev.evaluate(up, sources=[tilted]).float_mm >= judged.float_mm + 42


def test_errors_name_the_file_once(tmp_path, capsys):
    """The judge's own errors spoke of "a clip" (which one, in a folder?); a reader's error already
    naming its file was named twice in a folder's list."""
    from mjmotion import bvh
    from mjmotion.cli import main
    from mjmotion.synth import walk

    folder = tmp_path / "clips"
    folder.mkdir()
    bvh.write(walk(seconds=1.0).motion[:1], folder / "one.bvh")
    (folder / "nan.bvh").write_text(
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xposition\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\nnan\n"
    )
    assert main(["evaluate", str(folder / "one.bvh")]) == 2
    assert (
        capsys.readouterr().err
        == f"error: {folder / 'one.bvh'}: 1 frame(s); the judge needs at least 3 frames (speeds and accelerations are differences between frames)\n"
    )
    # One minimum, said the same way for 2 frames (it failed on foot speeds for 1 and on inverse dynamics for 2),
    # by --frames when that is what left too few, and by cleanup, which judges before and after.
    bvh.write(walk(seconds=1.0).motion[:2], tmp_path / "two.bvh")
    assert main(["evaluate", str(tmp_path / "two.bvh")]) == 2
    assert "2 frame(s); the judge needs at least 3 frames" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path / "two.bvh"), "--frames", "0:1"]) == 2
    assert capsys.readouterr().err.startswith("error: --frames 0:1: 1 frame(s) of ")
    assert main(["cleanup", str(folder / "one.bvh"), "-o", str(tmp_path / "c.bvh")]) == 2
    assert "1 frame(s); the judge needs at least 3 frames" in capsys.readouterr().err
    assert main(["evaluate", str(folder)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert sorted(e.split(": ")[1].split(":")[0] for e in err) == [str(folder / "nan.bvh"), str(folder / "one.bvh")], err
    assert all(e.count(str(folder)) == 1 for e in err), err


def test_a_rate_beyond_the_judges_windows_is_refused_at_once():
    """At 10,000 fps a million-frame clip ran two minutes into a 30 GB allocation (a MemoryError as an
    internal error): the judge's windows are durations, their frames grow with the rate."""
    import time

    from mjmotion.errors import MjmotionError
    from mjmotion.synth import walk
    from mjmotion.thresholds import MAX_JUDGED_FPS

    m = walk(seconds=1.0).motion
    fast = m.resample(2 * MAX_JUDGED_FPS)
    t0 = time.perf_counter()
    with pytest.raises(MjmotionError, match=r"2000 fps; the judge takes clips up to 1000 fps .*mjmotion convert --fps"):
        ev.evaluate(fast)
    assert time.perf_counter() - t0 < 1.0
    assert ev.evaluate(m.resample(MAX_JUDGED_FPS)).n_frames == fast.n_frames // 2 + 1  # the limit itself is judged


def test_a_source_that_is_a_folder_is_called_one(tmp_path, capsys):
    from mjmotion import bvh
    from mjmotion.cli import main
    from mjmotion.synth import walk

    clip = tmp_path / "w.bvh"
    bvh.write(walk(seconds=1.0).motion, clip)
    assert main(["evaluate", str(clip), "--source", str(tmp_path)]) == 2
    assert capsys.readouterr().err == f"error: --source {tmp_path}: not a file (a .bvh clip is expected)\n"  # (it said "no such file")


def test_a_stature_no_person_has_is_noted_with_the_units_option(capsys):
    """``--units m`` on a centimetre clip read a 178 m person and empty ground metrics without a word of why."""
    from mjmotion.cli import main

    clip = str(require_data() / "cmu_asfamc_converted/16_15.bvh")
    assert main(["evaluate", clip, "--units", "m"]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if "stature" in line]
    assert notes == ["note: 16_15: stature 178 m, no person's (0.5-3 m): its units are probably not what --units m reads "
                     "(mjmotion info shows the stature each --units gives)"]  # fmt: skip
    assert main(["evaluate", clip]) == 0
    assert "stature" not in capsys.readouterr().out


def test_skate_weights_of_a_tiny_contact_height_raise_no_overflow_warning():
    """--h-c 1e-10 printed numpy's "overflow encountered in power" (2^(h/h_c)) under the report."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w = ev.skate_weights(np.array([-0.01, 0.0, 0.02, 1.0]), 1e-10)
    assert w.tolist() == [1.0, 1.0, 0.0, 0.0]
    assert ev.skate_weights(np.array([0.025]), 0.05)[0] == pytest.approx(2 - 2**0.5)


def test_the_whole_body_speed_ratio_of_a_still_source_is_no_ratio_of_rounding_noise():
    # cleanup of a clip holding one pose read max_joint_speed_ratio 0.00 -> 3.67: noise over noise.
    m = shared_clip("cmu_asfamc_converted/16_15.bvh")[10:80]
    still = m.replace(rotations=np.repeat(m.rotations[:1], m.n_frames, axis=0), root_positions=np.repeat(m.root_positions[:1], m.n_frames, axis=0))
    noise = np.random.default_rng(0).normal(0.0, 1e-9, still.rotations.shape)
    a, b = still.replace(rotations=still.rotations + noise), still.replace(rotations=still.rotations - noise)
    assert ev.max_joint_speed_ratio(a, [b]) < 1e-3
    assert ev.max_joint_speed_ratio(m, [m]) == pytest.approx(1.0)  # a moving clip against itself: exactly its own peak
