"""Shot variations in PCA space (seed 003 §3): score paths, synthesis, cleanup, plots, the vary verb."""

from __future__ import annotations

import dataclasses
import itertools
import json
import warnings

import numpy as np
import pytest
from conftest import require_data

from mjmotion import bvh, evaluate, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion import variations as V
from mjmotion.cli import main
from mjmotion.errors import MjmotionError
from mjmotion.style import PoseSpace

# impact frames from mocap/SOURCES.md (64_01: address 0–160, top ≈ 240–280, impact ≈ 325, finish ≈ 440)
IMPACT = {"64_01": 325, "64_02": 367, "64_03": 284, "64_04": 258, "64_05": 244}
# the swing segment: backswing through follow-through around the impact
SWINGS = {name: (max(0, hit - 165), hit + 115) for name, hit in IMPACT.items()}


def _swing(name: str):
    return bvh.read(require_data() / "cmu_asfamc_converted" / f"{name}.bvh")


@pytest.fixture(scope="module", params=list(SWINGS))
def golf(request):
    src = _swing(request.param)
    space = PoseSpace.fit(src)
    k = space.components_for(V.DEFAULT_VARIANCE)
    return request.param, src, space, V.source_path(space, k)


@pytest.fixture(scope="module")
def swing01():
    src = _swing("64_01")
    return src, PoseSpace.fit(src)


def _shot(name: str):
    """An ASF shot from its first captured frame, its pose space (translations too, as ``vary`` fits it) and
    its own score path with the default number of controlled components."""
    from mjmotion.trim import leading_transient

    src = _swing(name)
    src = src[leading_transient(src) :]
    space = PoseSpace.fit(src, translations=True)
    return src, space, V.source_path(space, space.components_for(V.DEFAULT_VARIANCE))


def _fk(m):
    return kinematics.forward(mjcf.compile(m.skeleton), m).joint_positions


# --- reconstruction ----------------------------------------------------------------------------
def test_all_components_scale_one_reconstructs_the_source(swing01):
    src, space = swing01
    pure = V.source_path(space, space.n_components, detail=False)
    out = V.synthesise(space, V.scaled_path(pure, 1.0))
    assert np.max(np.abs(_fk(out) - _fk(src))) < 1e-6
    # with the detail components kept, any k at scale 1 is the source too
    kept = V.synthesise(space, V.scaled_path(V.source_path(space, 2), 1.0))
    assert np.max(np.abs(_fk(kept) - _fk(src))) < 1e-6


def test_pure_k_component_reconstruction_error_falls_with_k(swing01):
    src, space = swing01
    ref = _fk(src)
    errs = [
        np.sqrt(
            np.mean(
                np.sum(
                    (_fk(V.synthesise(space, V.source_path(space, k, detail=False))) - ref) ** 2,
                    -1,
                )
            )
        )
        for k in (1, 2, 4, 8, 16)
    ]
    assert all(b < a for a, b in itertools.pairwise(errs)), errs


# --- score paths -------------------------------------------------------------------------------
def test_scaled_path_is_a_homothety_about_the_centre(swing01):
    _, space = swing01
    base = V.source_path(space, 3)
    out = V.scaled_path(base, 1.3)
    w = V.end_weights(base.controlled)
    full = w == 1.0
    assert full.mean() > 0.3  # the swing itself is scaled at full strength
    c = base.controlled[w > 0].mean(0)
    np.testing.assert_allclose(out.controlled[full] - c, 1.3 * (base.controlled[full] - c), atol=1e-12)
    np.testing.assert_array_equal(out.scores[:, 3:], base.scores[:, 3:])  # detail untouched
    np.testing.assert_array_equal(out.scores[[0, -1]], base.scores[[0, -1]])  # the ends untouched


def test_end_weights_ramp_in_and_out_over_the_given_frames():
    """A path moving up to its last frame (a kick's recovery): its distance-based weight fell from 0.44
    to 0 in the last four frames (10_01 ×1.3: the root 15 cm in them); with ``ramp`` frames the weight
    changes by at most 1 / ramp a frame, never exceeds the distance-based one, is 0 at the first and
    last frames, and is the distance-based weight where that changes slowly (most of the path)."""
    t = np.linspace(0.0, 1.0, 200)
    path = np.stack([t**20, np.sin(3 * t)], axis=1)  # moving fastest at its end
    plain, ramped = V.end_weights(path), V.end_weights(path, ramp=30)
    assert np.abs(np.diff(plain[-10:])).max() > 0.15  # (what the ramp is for)
    assert ramped[0] == 0.0 and ramped[-1] == 0.0 and np.all(ramped <= plain + 1e-15)
    assert np.abs(np.diff(ramped)).max() <= 1 / 30 + 1e-12
    assert np.mean(ramped == plain) > 0.5 and ramped[-30] < plain[-30]


def test_the_kick_reaches_its_last_pose_without_a_jump_of_its_root():
    """10_01 ×1.3 (vary passes the clip's rate): over its last eight frames the variant's root moves
    no faster than the source's fastest (it moved 3.8x as fast, 8 cm in one frame, without the ramp)."""
    src, space, base = _shot("10_01")
    path = V.scaled_path(base, 1.3, fps=src.fps)
    raw = V.synthesise(space, path)
    speed = lambda m: np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1)
    assert speed(raw)[-8:].max() <= speed(src).max()
    np.testing.assert_allclose(raw.root_positions[-1], src.root_positions[-1], atol=1e-9)


def test_scaling_with_the_clips_rate_exaggerates_the_motion_not_a_one_frame_glitch():
    """A path that moves slowly with a one-frame spike (a capture glitch): scaled with the clip's rate,
    the smooth motion is exaggerated as the homothety does (to 1 % of its added deviation) while the
    spike is not (it is 10x smaller than in the homothety, which scales it with the rest)."""
    t = np.arange(240) / 120.0
    smooth = np.stack([np.sin(2 * np.pi * 0.5 * t), np.cos(2 * np.pi * 0.3 * t)], axis=1)
    glitch = smooth.copy()
    glitch[120, 0] += 3.0
    frames = np.arange(len(t))
    path = V.ScorePath(glitch, 2, frames, frames, np.zeros(len(t)), "glitch")
    exact, rated = V.scaled_path(path, 1.3), V.scaled_path(path, 1.3, fps=120.0)
    added_exact, added = exact.scores - glitch, rated.scores - glitch
    assert abs(added[120, 0] - added[119, 0]) < 0.1 * abs(added_exact[120, 0] - added_exact[119, 0])
    far = np.abs(frames - 120) > 30
    assert np.abs(added - added_exact)[far].max() < 0.01 * np.abs(added_exact).max()


def test_the_kicks_scaled_variants_do_not_jitter_their_root():
    """10_01's left hand jumps 12 standard deviations for two frames (598-600); the controlled components
    carry it to the root, and scaling them by 1.3 or 0.7 moved the root 3.8x and 4.3x as fast as the
    source's fastest there, its 99th-percentile acceleration 6x the source's. Scaled with the clip's
    rate (variations.SCALE_CUTOFF_HZ) the variants' root is no jerkier than the source's."""
    src, space, base = _shot("10_01")
    speed = lambda m: np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1)
    jerk = lambda m: np.percentile(np.linalg.norm(np.diff(m.root_positions, 2, axis=0), axis=1), 99)
    for f in (1.3, 0.7):
        raw = V.synthesise(space, V.scaled_path(base, f, fps=src.fps))
        assert speed(raw).max() < 2.0 * speed(src).max(), f
        assert jerk(raw) < 1.5 * jerk(src), f


def test_a_path_too_short_to_weight_any_frame_scales_to_itself(swing01):
    """Two frames are the start and the end pose, which scaling keeps: the path comes back as it was,
    finite (it was NaN, from the mean of no weighted frame, and `vary` refused a 2-frame clip as
    "non-finite values")."""
    _, space = swing01
    base = V.source_path(space, 3)
    short = dataclasses.replace(base, scores=base.scores[:2], frame_a=base.frame_a[:2], frame_b=base.frame_b[:2], weight=base.weight[:2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = V.scaled_path(short, 1.3)
    np.testing.assert_array_equal(out.scores, short.scores)


def test_scaled_variants_keep_the_common_start_and_end_poses(golf):
    """Issue 18 item 11 (seed 003 §2.2.5: the shots begin and end in the same pose): exaggerated and
    muted variants, cleaned up, start and end exactly where the source does (they moved 0.11–0.50 m)."""
    name, src, space, path = golf
    ref = _fk(src)
    for f in (1.3, 0.7):
        p = V.scaled_path(path, f)
        out, _ = V.clean_up(src, V.synthesise(space, p), p)
        got = _fk(out)
        for t in (0, -1):
            assert np.max(np.linalg.norm(got[t] - ref[t], axis=-1)) < 1e-3, (name, f, t)


def test_segment_scaling_leaves_the_rest_of_the_path_alone(swing01):
    _, space = swing01
    base = V.source_path(space, 2)
    out = V.scaled_path(base, 0.6, (160, 440))
    np.testing.assert_array_equal(out.scores[:160], base.scores[:160])
    np.testing.assert_array_equal(out.scores[440:], base.scores[440:])
    w = V.segment_weights(base.n_frames, (160, 440))
    full = w == 1.0
    c = base.controlled[160:440].mean(0)
    np.testing.assert_allclose(out.controlled[full] - c, 0.6 * (base.controlled[full] - c), atol=1e-12)
    # the tapers are smooth: no step larger than the source's own steps allow
    step = np.abs(np.diff(w))
    assert step.max() < 0.05 and w[160] < 0.05 and w[439] < 0.05


def test_aborted_path_follows_then_reaches_the_rest_scores(swing01):
    src, space = swing01
    base = V.source_path(space, 2)
    p = V.aborted_path(base, 280, 60, fps=src.fps)
    assert p.n_frames == 281 + 60
    np.testing.assert_array_equal(p.scores[:281], base.scores[:281])
    np.testing.assert_allclose(p.scores[-1], base.scores[-1], atol=1e-12)
    # leaves with the source's velocity: the change of velocity at the turn is no bigger than
    # the source's own frame-to-frame changes (no kink), unlike a straight line to the rest scores
    v_in = base.controlled[280] - base.controlled[279]
    v_out = p.controlled[281] - p.controlled[280]
    src_acc = np.linalg.norm(np.diff(base.controlled, 2, axis=0), axis=1).max()
    straight = (base.controlled[-1] - base.controlled[280]) / 60
    assert np.linalg.norm(v_out - v_in) <= src_acc < np.linalg.norm(straight - v_in) * 10
    with pytest.raises(MjmotionError, match="abort frame"):
        V.aborted_path(base, src.n_frames + 5)
    # refused before anything is allocated (10**9 frames got the process killed for its memory; 2e6 made a
    # clip over the frame cap); a fractional frame or a rate that is no rate was a raw error
    for kwargs, message in (
        (dict(n_frames=10**9), "more than the limit of 1,000,000 frames"),
        (dict(n_frames=2_000_000), "more than the limit of 1,000,000 frames"),
        (dict(fps=1e9), "fps 1000000000.0: expected a frame rate"),
        (dict(fps=float("nan")), "fps nan: expected a frame rate"),
        (dict(frame=60.5), "abort frame 60.5: expected a whole frame number"),
    ):
        with pytest.raises(MjmotionError, match=message):
            V.aborted_path(base, **{"frame": 280, **kwargs}, space=space)


def test_explicit_paths_from_npy_and_csv(swing01, tmp_path):
    src, space = swing01
    s = space.source_scores[:, :3]
    np.save(tmp_path / "p.npy", s)
    (tmp_path / "p.csv").write_text("pc1,pc2,pc3\n" + "\n".join(",".join(f"{v:.17g}" for v in row) for row in s))
    for f in ("p.npy", "p.csv"):
        arr = V.read_scores(tmp_path / f)
        np.testing.assert_allclose(arr, s, atol=1e-12)
        p = V.explicit_path(space, arr)
        assert p.k == 3
        assert np.max(np.abs(_fk(V.synthesise(space, p)) - _fk(src))) < 1e-6
    short = V.explicit_path(space, s[::4], detail=True)  # another length: a pure reconstruction
    assert np.all(short.scores[:, 3:] == 0) and short.frame_b.max() <= src.n_frames - 1
    (tmp_path / "bad.csv").write_text("1,2\n3,x\n")
    with pytest.raises(MjmotionError, match="bad.csv"):
        V.read_scores(tmp_path / "bad.csv")
    with pytest.raises(MjmotionError, match="components"):
        V.explicit_path(space, np.zeros((10, space.n_components + 1)))


# --- cleanup -----------------------------------------------------------------------------------
def test_two_bone_ik_reaches_a_reachable_target(swing01):
    src, _ = swing01
    m = src[200:230]
    skel = m.skeleton
    compiled = mjcf.compile(skel)
    pose = kinematics.forward(compiled, m)
    ankle = skel.feet()["left"][0]
    rng = np.random.default_rng(0)
    hip = pose.joint_positions[:, skel.parents[skel.parents[ankle]]]
    reach = pose.joint_positions[:, ankle] - hip  # the stance leg is near straight: aim a little closer in
    d = reach + rng.normal(0, 0.08, reach.shape)
    d *= (np.linalg.norm(reach, axis=1) * rng.uniform(0.85, 0.97, m.n_frames) / np.linalg.norm(d, axis=1))[:, None]
    target = hip + d
    target_rot = rot.normalize(pose.joint_rotations[:, ankle] + rng.normal(0, 0.1, (m.n_frames, 4)))
    local, err = V.two_bone_ik(
        skel,
        pose.joint_positions,
        pose.joint_rotations,
        m.rotations,
        ankle,
        target,
        target_rot,
    )
    after = kinematics.forward(compiled, m.replace(rotations=local))
    assert np.max(err) == 0.0
    assert np.max(np.linalg.norm(after.joint_positions[:, ankle] - target, axis=-1)) < 1e-6
    assert np.max(rot.angle_between(after.joint_rotations[:, ankle], target_rot)) < 1e-6
    # only the leg changed
    leg = {skel.parents[skel.parents[ankle]], skel.parents[ankle], ankle}
    others = [j for j in range(skel.n_joints) if j not in leg]
    np.testing.assert_allclose(local[:, others], m.rotations[:, others])


def _leg(skel, ankle):
    # hip, knee, ankle and everything below: what the foot cleanup may move
    return [
        int(skel.parents[skel.parents[ankle]]),
        int(skel.parents[ankle]),
        *skel.descendants(int(skel.parents[ankle])),
    ]


def _variants(src, path):
    return {
        "scale 1.3": V.scaled_path(path, 1.3),
        "scale 0.7": V.scaled_path(path, 0.7),
        "abort": V.aborted_path(path, 280, fps=src.fps, space=PoseSpace.fit(src)),
    }


def test_scaling_lengthens_and_shortens_the_hand_path_in_the_swing(golf):
    name, src, space, path = golf
    seg = SWINGS[name]
    j = src.skeleton.hands()["left"]
    base = V.effector_path_length(src, j, seg)
    lengths = {}
    for f in (1.3, 0.7):
        p = V.scaled_path(path, f)
        out, _ = V.clean_up(src, V.synthesise(space, p), p)
        lengths[f] = V.effector_path_length(out, j, seg)
    assert lengths[1.3] > 1.05 * base > base > 0.95 * base > lengths[0.7], (
        base,
        lengths,
    )


def _foot_height_error(src, out, p):
    # mean |height| difference of the feet from the source's where the source's foot is down
    h = evaluate.foot_heights_speeds(None, out).heights
    hs = V.fixes._source_at(evaluate.foot_heights_speeds(None, src).heights, p)
    return float(np.mean(np.abs(h - hs)[hs < evaluate.H_C]))


def test_cleanup_keeps_feet_planted_and_hands_on_the_grip(golf):
    name, src, space, path = golf
    skate_src = evaluate.skate_mm_per_s(src)
    for label, p in _variants(src, path).items():
        raw = V.synthesise(space, p)
        assert V.grip_error_m(src, raw, p) > 0.01  # the raw variant does lose the grip (§3.3)
        # the general footskate cleanup ("plants") is offered for the scaled variants; an abort's
        # return needs the source's footprints (steps), which only "source" knows
        for feet in ("source", "plants") if label.startswith("scale") else ("source",):
            out, rep = V.clean_up(src, raw, p, first_hand="left", feet=feet)
            skate = evaluate.skate_mm_per_s(out)
            assert skate <= 2.0 * skate_src, (name, label, feet, skate, skate_src)
            assert V.grip_error_m(src, out, p) < 0.005, (name, label, feet)
            if feet == "source":
                assert rep.held_frames["left"] > 0.5 * p.n_frames
            if feet == "source" and label.startswith("scale"):  # (an abort's return may step: no height reference)
                # feet back at the source's height where it is down: floating repaired, not just sliding
                before, after = (
                    _foot_height_error(src, raw, p),
                    _foot_height_error(src, out, p),
                )
                assert after < 0.6 * before or after < 0.003, (
                    name,
                    label,
                    before,
                    after,
                )


def test_scaling_lengthens_and_shortens_the_club_path(swing01):
    pytest.importorskip("mjmotion.hitpoint")
    src, space = swing01
    club = V.fitted_club(src)
    assert club is not None
    seg = SWINGS["64_01"]
    base_len = V.effector_path_length(src, frames=seg, prop=club)
    path = V.source_path(space, space.components_for(V.DEFAULT_VARIANCE))
    got = {}
    for f in (1.3, 0.7):
        p = V.scaled_path(path, f)
        out, _ = V.clean_up(src, V.synthesise(space, p), p, first_hand=V.first_hand_for(src))
        got[f] = V.effector_path_length(out, frames=seg, prop=club)
    assert got[1.3] > base_len > got[0.7], (base_len, got)


def test_abort_follows_the_source_and_ends_at_the_rest_pose_smoothly(golf):
    name, src, space, path = golf
    hit = IMPACT[name]
    for f in (
        hit - 100,
        hit - 30,
        hit + 20,
    ):  # in the backswing, the downswing, the follow-through
        p = V.aborted_path(path, f, fps=src.fps, space=space)
        out, _ = V.clean_up(src, V.synthesise(space, p), p)
        got, ref = _fk(out), _fk(src)
        assert np.max(np.abs(got[: f + 1] - ref[: f + 1])) < 1e-6, (name, f)
        # the rest pose, where the feet stand (a golfer's stance barely moves)
        assert np.linalg.norm(p.shift_b) < 0.1 and p.shift_b[2] == 0.0
        last = np.abs(got[-1] - p.shift_b - ref[-1])
        legs = [j for side in src.skeleton.feet().values() for j in _leg(src.skeleton, side[0])]
        upper = [j for j in range(src.skeleton.n_joints) if j not in legs]
        # the feet stay planted where they stood (their plant's shift): legs within 2 cm
        assert last[upper].max() < 1e-6 and last.max() < 0.02, (name, f, last.max())
        assert evaluate.max_joint_speed_ratio(out, src) <= 1.5, (name, f)


# --- plots and CLI -----------------------------------------------------------------------------
def test_an_interrupted_vary_leaves_none_of_its_outputs(tmp_path, monkeypatch, capsys):
    """The clip was written first, then measured and drawn for seconds: Ctrl-C there left it without its
    report and plot (and a rerun was refused: the clip existed)."""
    from mjmotion import plots, synth

    src = tmp_path / "drive.bvh"
    bvh.write(synth.drive().motion, src)
    drawn = []

    def interrupted(*args, **kwargs):
        drawn.append(args)
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "score_paths", interrupted)
    argv = ["vary", str(src), "--scale", "1.2", "-o", str(tmp_path / "v.bvh"), "--json", str(tmp_path / "v.json"), "--plot", str(tmp_path / "v.png")]
    assert main(argv) == 130 and drawn
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.bvh"]
    monkeypatch.undo()
    assert main(argv) == 0, capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.bvh", "v.bvh", "v.json", "v.png"]


def test_vary_cli_report_and_errors(tmp_path, capsys):
    src_file = require_data() / "cmu_asfamc_converted" / "64_01.bvh"
    out, js, png = tmp_path / "v.bvh", tmp_path / "v.json", tmp_path / "v.png"
    assert (
        main(
            [
                "vary",
                str(src_file),
                "--scale",
                "1.3",
                "-o",
                str(out),
                "--json",
                str(js),
                "--plot",
                str(png),
            ]
        )
        == 0
    )
    rep = json.loads(js.read_text())
    assert rep["k"] == PoseSpace.fit(bvh.read(src_file), translations=True).components_for(0.9)
    assert rep["variance_explained"] >= 0.9 and rep["style_rmse"]["k"] == 2 and rep["style_rmse"]["rmse"] > 0
    assert rep["reconstruction_error_falls_with_k"] is True
    # the judge's headline footskate, as `evaluate --source` reads the clip written (it reported the
    # height-weighted skate, each clip on its own floor)
    fs = rep["planted_skate_mm_per_s"]
    assert fs["result"] <= 2 * fs["source"]
    judged = evaluate.evaluate(bvh.read(out), sources=[bvh.read(src_file)])
    assert fs["result"] == pytest.approx(judged.planted_skate_mm_per_s, rel=1e-3, abs=0.05)
    assert fs["source"] == pytest.approx(evaluate.evaluate(bvh.read(src_file)).planted_skate_mm_per_s, rel=1e-9)
    assert rep["grip_error_m"]["result"] < 0.005
    assert rep["effector_path_m"]["result"] > rep["effector_path_m"]["source"]
    assert bvh.read(out).n_frames == bvh.read(src_file).n_frames and png.stat().st_size > 0
    # the per-joint judge beside the whole-body ratio (which read 0.96 over 54 pop frames), as evaluate --source reads it
    judged = evaluate.evaluate(bvh.read(out), sources=[bvh.read(src_file)])
    assert rep["worst_joint_speed_ratio"]["result"]["ratio"] == pytest.approx(judged.worst_joint_speed_ratio)
    assert rep["pop_frames"]["result"] == judged.pop_frames and "pop_frames source" in capsys.readouterr().out
    # aborted, raw: the written clip is the synthesis with no cleanup
    ab = tmp_path / "a.bvh"
    assert (
        main(
            [
                "vary",
                str(src_file),
                "--abort-at",
                "250",
                "--abort-frames",
                "50",
                "--no-cleanup",
                "-o",
                str(ab),
            ]
        )
        == 0
    )
    assert bvh.read(ab).n_frames == 251 + 50
    capsys.readouterr()
    assert main(["vary", str(src_file), "--scale", "1.3", "-o", str(out)]) == 2  # exists, no --force
    assert (
        main(
            [
                "vary",
                str(src_file),
                "--abort-at",
                "250",
                "--segment",
                "1:9",
                "-o",
                str(tmp_path / "b.bvh"),
            ]
        )
        == 2
    )
    assert main(["vary", str(src_file), "--scale", "-1", "-o", str(tmp_path / "c.bvh")]) == 2
    d = str(tmp_path / "d.bvh")
    assert main(["vary", str(src_file), "--scale", "1.2", "--rest-frame", "5", "-o", d]) == 2
    assert (
        main(
            [
                "vary",
                str(src_file),
                "--abort-at",
                "100",
                "--rest-frame",
                "99999",
                "-o",
                d,
            ]
        )
        == 2
    )
    # a clip shorter than the root-smoothing window (0.3 s) still works
    short = tmp_path / "short.bvh"
    bvh.write(bvh.read(src_file)[200:230], short)
    assert main(["vary", str(short), "--scale", "1.5", "-o", str(tmp_path / "e.bvh")]) == 0
    err = capsys.readouterr().err
    assert "--rest-frame goes with --abort-at" in err and "outside the clip" in err
    assert "already exists" in err and "--segment goes with --scale" in err and "positive" in err
    assert main(["vary", str(src_file), "--scale", "1.1", "--segment", "100:50", "-o", str(tmp_path / "s.bvh")]) == 2
    assert capsys.readouterr().err.startswith("error: --segment 100:50: selects no frames")  # (it said --frames)
    assert "Traceback" not in err
    # More components than the clip's pose space has: named by option or file (was "number of components must be 1…99")
    assert main(["vary", str(src_file), "--scale", "1.1", "--pcs", "1000", "-o", str(tmp_path / "p.bvh")]) == 2
    assert capsys.readouterr().err.startswith("error: --pcs 1000: this clip's pose space has ")
    np.save(tmp_path / "wide.npy", np.zeros((10, 1000)))
    assert main(["vary", str(src_file), "--scores", str(tmp_path / "wide.npy"), "-o", str(tmp_path / "p.bvh")]) == 2
    assert capsys.readouterr().err.startswith(f"error: {tmp_path / 'wide.npy'}: 1000 columns of scores; this clip's pose space has ")


# --- the bundled shots (mjmotion.synth) --------------------------------------------------------
@pytest.fixture(scope="module", params=["drive", "pull"])
def shot(request):
    synth = pytest.importorskip("mjmotion.synth")
    clip = getattr(synth, request.param)()
    src = clip.motion
    space = PoseSpace.fit(src)
    return (
        request.param,
        clip,
        src,
        space,
        V.source_path(space, space.components_for(V.DEFAULT_VARIANCE)),
    )


def test_bundled_shots_exaggerate_mute_and_abort(shot):
    name, clip, src, space, path = shot
    from mjmotion.skeleton import side_of

    hand = side_of(clip.prop.joint)
    seg = (
        max(0, clip.hit_frame - 40),
        min(src.n_frames, clip.hit_frame + 40),
    )  # backlift to follow-through
    base = V.effector_path_length(src, frames=seg, prop=clip.prop)
    skate_src = evaluate.skate_mm_per_s(src)
    lengths = {}
    for f in (1.3, 0.7):
        p = V.scaled_path(path, f)
        out, _ = V.clean_up(src, V.synthesise(space, p), p, first_hand=hand)
        lengths[f] = V.effector_path_length(out, frames=seg, prop=clip.prop)
        assert evaluate.skate_mm_per_s(out) <= 2.0 * skate_src + 1e-9, (name, f)
        assert V.grip_error_m(src, out, p, hand) < 0.005
    assert lengths[1.3] > base > lengths[0.7], (name, base, lengths)
    p = V.aborted_path(path, clip.hit_frame - 10, fps=src.fps, space=space)
    out, _ = V.clean_up(src, V.synthesise(space, p), p, first_hand=hand)
    got, ref = _fk(out), _fk(src)
    f = clip.hit_frame - 10
    assert np.max(np.abs(got[: f + 1] - ref[: f + 1])) < 1e-6
    assert evaluate.max_joint_speed_ratio(out, src) <= 1.5
    assert evaluate.skate_mm_per_s(out) <= 2.0 * skate_src + 1e-9, name
    assert V.grip_error_m(src, out, p, hand) < 0.005


def test_repairs_do_not_make_joints_pop(golf):
    """The feet and the grip repaired without popping joints the raw variant did not pop: the
    collarbone turned only on the frames a hand was out of reach (a step of degrees in a frame, the
    clavicle at 5-13x its captured speed), a foot's target jumped from one plant's shift to the
    next (15 cm in a frame), and a knee bent the other way for a frame (108 rad/s) through a
    captured glitch (the repaired variants read 4.8-18x and up to 131 pop frames). Near a straight
    elbow the exact grip still carries the raw variant's hand jitter: 64_03 ×1.3's right elbow at
    5.1x, 42 pop frames more than the raw variant's 4."""
    name, src, space, path = golf
    for factor in (1.3, 0.7):
        p = V.scaled_path(path, factor)
        raw = V.synthesise(space, p)
        out, _ = V.clean_up(src, raw, p)
        worst, joint = evaluate.worst_joint_speed_ratio(out, src)
        raw_pops, pops = int(evaluate.pop_frames(raw, src).sum()), int(evaluate.pop_frames(out, src).sum())
        assert worst <= 5.5, (name, factor, worst, joint)
        assert pops <= raw_pops + 0.12 * out.n_frames, (name, factor, raw_pops, pops)


@pytest.mark.parametrize(("name", "factor"), [("10_02", 1.3), ("124_01", 1.5)])
def test_exaggerated_variants_stay_inside_the_judges_joint_ranges(name, factor):
    """The judge's ranges hold for variations as for hit (issue 13): 10_02 ×1.3 turned lhumerus to
    161.8° (range 160°), 124_01 ×1.5 past its ranges on 1.9 % of frames; raw and repaired variants stay inside."""
    from mjmotion import limits

    src = bvh.read(require_data() / "cmu_asfamc_converted" / f"{name}.bvh")
    space = PoseSpace.fit(src, translations=True)
    path = V.scaled_path(V.source_path(space, space.components_for(V.DEFAULT_VARIANCE)), factor)
    raw = V.synthesise(space, path)
    out, _ = V.clean_up(src, raw, path, first_hand=V.first_hand_for(src))
    assert not limits.violations(src.skeleton, raw.rotations).any() and not limits.violations(src.skeleton, out.rotations).any()
    lvr, _ = evaluate.limit_violation_ratio(evaluate.judge_model(src.skeleton), bvh.parse(bvh.format_motion(out)))
    assert lvr == 0.0  # as evaluate reads the clip once written


def test_a_held_foot_out_of_reach_does_not_snap_the_knee_straight():
    """The kick 10_01 exaggerated ×1.3: its support foot is held on the source's footprint while the
    variant's body, 15-30 cm from the source's in the last quarter second, returns to the source's
    last pose; out of reach, the knee went fully straight (0.2°) for five frames and bent 24° in the
    next (ltibia at 6.3x its source peak). The leg now slows to its limit (cleanup.soft_reach)."""
    src, space, base = _shot("10_01")
    path = V.scaled_path(base, 1.3)
    out, rep = V.clean_up(src, V.synthesise(space, path), path, first_hand=None)
    worst, joint = evaluate.worst_joint_speed_ratio(out, src)
    assert worst < 3.0, (worst, joint)
    knee = int(src.skeleton.parents[src.skeleton.feet()["left"][0]])
    assert np.degrees(rot.norm(rot.log(out.rotations[:, knee]))).min() > 5.0
    assert rep.foot_reach_error_m > 0.0  # (it stopped short instead)


def test_the_foot_repair_does_not_crouch_the_body_to_hold_a_foot():
    """The kick 10_01 exaggerated ×2: its feet held on the source's footprints while the variant's body
    leaves them, the repair lowered the root 0.59 m (1.07 m in all) towards them. It moves the root at
    most cleanup.ROOT_SHIFT of the leg's length, as the footskate cleanup does; the foot stops short."""
    from mjmotion import cleanup

    src, space, base = _shot("10_01")
    path = V.scaled_path(base, 2.0, fps=src.fps)
    raw = V.synthesise(space, path)
    out, rep = V.clean_up(src, raw, path, first_hand=None)
    p = _fk(src)[0]
    ankle = src.skeleton.feet()["left"][0]
    knee, hip = int(src.skeleton.parents[ankle]), int(src.skeleton.parents[src.skeleton.parents[ankle]])
    leg = np.linalg.norm(p[knee] - p[hip]) + np.linalg.norm(p[ankle] - p[knee])
    moved = np.linalg.norm(out.root_positions - raw.root_positions, axis=1)
    assert moved.max() <= cleanup.ROOT_SHIFT * leg + 1e-9, (moved.max(), leg)
    assert rep.foot_reach_error_m > 0.0


def test_an_aborted_swing_steps_its_foot_back_over_the_whole_return():
    """64_05 aborted at frame 122 returns to its finish pose in 44 frames and its trail foot steps (its
    footprint moves 6 cm and its heel rises). Carried in the middle 40 % of the return, the step bent the
    knee 80° and back in 0.17 s: rtibia at 6.5x its captured p99 speed and 18 pop frames. Lifted over the
    whole return and carried over its middle 80 % (fixes.STEP_CARRY): 5.2x and 4. The return still ends
    exactly in the rest pose where the character stands."""
    src, space, base = _shot("64_05")
    path = V.aborted_path(base, 122, fps=src.fps, space=space)
    out, _ = V.clean_up(src, V.synthesise(space, path), path, first_hand=V.first_hand_for(src))
    worst, joint = evaluate.worst_joint_speed_ratio(out, src)
    pops = int(np.count_nonzero(evaluate.pop_frames(out, [src])))
    assert worst < 5.6 and pops <= 8, (worst, joint, pops)


def test_a_path_of_another_length_does_not_step_between_neighbouring_frames():
    """An explicit path 1.37x the kick 10_02's length stands each frame between two neighbouring source
    frames. The step of an abort's return (lift, carry, put down by the fraction of the way) was taken
    there too wherever the foot moved over 5 cm between them: its height jumped with each frame's
    fraction (59.5 mm in a frame, the raw variant's largest 30.4). It is an abort's return alone now."""
    src, space, base = _shot("10_02")
    k, s = space.components_for(V.DEFAULT_VARIANCE), space.source_scores
    x = np.linspace(0, len(s) - 1, int(len(s) * 1.37))
    path = V.explicit_path(space, np.stack([np.interp(x, np.arange(len(s)), s[:, c]) for c in range(k)], axis=1))
    raw = V.synthesise(space, path)
    out, _, _ = V.hold_source_feet(src, raw, path)
    ankles = [a for a, _ in src.skeleton.feet().values()]
    step = lambda m: np.abs(np.diff(_fk(m)[:, ankles, 2], axis=0)).max()
    assert step(out) < 1.5 * step(raw), (step(out), step(raw))


def test_close_gaps_fills_only_short_gaps_between_runs():
    from mjmotion.variations.fixes import _close_gaps

    m = np.array([0, 1, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 1, 0], dtype=bool)
    assert _close_gaps(m, 2).astype(int).tolist() == [0, 1, 1, 1, 1, 1, 0, 0, 0, 0, 1, 1, 1, 1, 0]
    assert _close_gaps(m, 4).astype(int).tolist() == [0] + [1] * 13 + [0]  # (the clip's ends are no gaps)
    assert not _close_gaps(np.zeros(4, dtype=bool), 3).any() and _close_gaps(np.zeros(0, dtype=bool), 3).size == 0


def test_a_foot_hovering_at_the_plant_height_stays_held():
    """64_05's trail foot hovers at 78-81 mm through its finish, about the 80 mm under which the source's
    foot counts as down (fixes.PLANT_HEIGHT): five runs of frames under it were five plants, each with
    its own shift, and the ×0.7 variant's foot target stepped between them (rfemur at 2.1x its captured
    peak, 8 pop frames). Gaps shorter than two fades between plants are held through: 1.03x, 2 pops."""
    src, space, base = _shot("64_05")
    path = V.scaled_path(base, 0.7, fps=src.fps)
    out, _ = V.clean_up(src, V.synthesise(space, path), path, first_hand=V.first_hand_for(src))
    worst, joint = evaluate.worst_joint_speed_ratio(out, src)
    pops = int(np.count_nonzero(evaluate.pop_frames(out, [src])))
    assert worst <= 1.3 and pops <= 3, (worst, joint, pops)


def test_two_bone_ik_stops_a_target_out_of_reach_short_of_a_straight_limb(swing01):
    src, _ = swing01
    m = src[200:230]
    skel = m.skeleton
    pose = kinematics.forward(mjcf.compile(skel), m)
    ankle = skel.feet()["left"][0]
    knee, hip = int(skel.parents[ankle]), int(skel.parents[skel.parents[ankle]])
    p = pose.joint_positions
    length = np.linalg.norm(p[:, knee] - p[:, hip], axis=1) + np.linalg.norm(p[:, ankle] - p[:, knee], axis=1)
    far = p[:, hip] + (p[:, ankle] - p[:, hip]) * (1.2 * length / np.linalg.norm(p[:, ankle] - p[:, hip], axis=1))[:, None]
    local, err = V.two_bone_ik(skel, p, pose.joint_rotations, m.rotations, ankle, far, pose.joint_rotations[:, ankle], reach=0.995)
    got = kinematics.forward(mjcf.compile(skel), m.replace(rotations=local)).joint_positions
    dist = np.linalg.norm(got[:, ankle] - got[:, hip], axis=1)
    assert np.all(dist <= 0.995 * length + 1e-9) and np.all(dist > 0.99 * length)
    np.testing.assert_allclose(err, 1.2 * length - dist, atol=1e-6)


def test_the_vary_help_states_the_end_ramp_the_code_uses():
    import argparse

    from mjmotion import cli

    sub = next(a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    text = " ".join(sub.choices["vary"].format_help().split())
    assert f"faster than over {V.END_RAMP_S:g} s)" in text and f"low-passed at {V.SCALE_CUTOFF_HZ:g} Hz" in text
