"""The bundled procedural clips: clean by METRICS.md, exact ground truth, round trips, determinism.

Metrics are computed here from ``shared/docs/METRICS.md`` directly, through MuJoCo's own
kinematics of the compiled model (independent of the NumPy FK the generators use).
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from mjmotion import bvh, kinematics, synth
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.errors import MjmotionError
from mjmotion.skeleton import CM
from mjmotion.synth.library import same_ground_truth

GAITS = ("walk", "walk_fast", "walk_turn_left", "run", "run_turn_right", "sneak", "limp")
H_C = 0.05  # METRICS.md contact height
V_C = 0.5  # METRICS.md contact speed, m/s


@pytest.fixture(scope="module")
def lib() -> dict[str, synth.SynthClip]:
    return synth.library()


class Ground:
    """Per-frame MuJoCo geometry of a clip: METRICS.md foot points and the lowest body-geom point."""

    def __init__(self, clip: synth.SynthClip):
        c = clip.compile()
        m = c.model
        q = kinematics.qpos(c, clip.motion)
        d = mujoco.MjData(m)
        feet = clip.motion.skeleton.feet()
        body = c.body_geom_ids
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        t = len(q)
        self.fps = clip.motion.fps
        self.points = {s: [] for s in ("left", "right")}
        self.lowest_body = np.empty(t)
        for i in range(t):
            d.qpos[:] = q[i]
            mujoco.mj_kinematics(m, d)
            pos, mat, size = d.geom_xpos[body], d.geom_xmat[body].reshape(-1, 3, 3), m.geom_size[body]
            is_box = m.geom_type[body] == mujoco.mjtGeom.mjGEOM_BOX
            box_low = pos[:, 2] - np.einsum("gk,gk->g", np.abs(mat[:, 2, :]), size)
            cap_low = pos[:, 2] - np.abs(mat[:, 2, 2]) * size[:, 1] - size[:, 0]
            self.lowest_body[i] = np.where(is_box, box_low, cap_low).min()
            for s, (ankle, toe) in feet.items():
                g = np.asarray(c.foot_geoms[s])
                corners = d.geom_xpos[g][:, None] + np.einsum("gij,gkj->gki", d.geom_xmat[g].reshape(-1, 3, 3), signs[None] * m.geom_size[g][:, None])
                self.points[s].append(np.vstack([d.xpos[c.body_ids[ankle]], d.xpos[c.body_ids[toe]], corners.reshape(-1, 3)]))
        self.points = {s: np.asarray(v) for s, v in self.points.items()}  # (T, P, 3)

    def height(self, side: str) -> np.ndarray:
        """``(T,)`` lowest foot point above the floor."""
        return self.points[side][:, :, 2].min(axis=1)

    def lowest_speed(self, side: str) -> np.ndarray:
        """``(T,)`` horizontal speed (m/s) of the material point that is lowest (central differences)."""
        p = self.points[side]
        k = np.argmin(p[:, :, 2], axis=1)
        v = np.gradient(p[:, :, :2], 1.0 / self.fps, axis=0)
        return np.linalg.norm(v[np.arange(len(k)), k], axis=1)


@pytest.fixture(scope="module")
def ground(lib) -> dict[str, Ground]:
    return {name: Ground(clip) for name, clip in lib.items()}


def labelled_skate_mm_per_s(clip: synth.SynthClip, g: Ground) -> float:
    """METRICS.md ``skate_mm_per_s`` over labelled contacts (the label at t and t−1)."""
    speeds = []
    for i, side in enumerate(("left", "right")):
        c = clip.contacts[:, i]
        both = np.zeros_like(c)
        both[1:] = c[1:] & c[:-1]
        speeds.append(g.lowest_speed(side)[both])
    return 1000.0 * float(np.mean(np.concatenate(speeds)))


# --- the skeleton --------------------------------------------------------------------------------
def test_skeleton_names_parts_and_writes_standard_y_up_cm_bvh():
    s = synth.skeleton()
    assert 20 <= s.n_joints <= 25
    names = s.names
    assert {n: names[j] for n, j in s.hands().items()} == {"left": "LeftHand", "right": "RightHand"}
    assert {k: (names[a], names[t]) for k, (a, t) in s.feet().items()} == {
        "left": ("LeftFoot", "LeftToe"),
        "right": ("RightFoot", "RightToe"),
    }
    assert 1.6 < s.stature() < 2.0
    # Adult proportions: legs about half the height, arms span about the height (T-pose).
    rest = s.rest_positions()
    assert rest[s.index("Hips"), 2] == pytest.approx(1.0)
    assert 1.5 < s.height() < 1.95
    text = bvh.format_motion(synth.walk(seconds=0.5).motion)
    root_offset = [float(x) for x in text.splitlines()[3].split()[1:]]
    assert root_offset == pytest.approx([0.0, 100.0, 0.0])  # centimetres, Y up
    back = bvh.parse(text)
    assert back.skeleton.scale == CM and np.allclose(back.skeleton.offsets, s.offsets, atol=1e-9)
    # The walk heads along the file's +Z (the world's +X): Zposition grows by speed × time, in cm.
    lines = text.splitlines()
    rows = lines[lines.index("MOTION") + 3 :]
    z0, z1 = float(rows[0].split()[2]), float(rows[-1].split()[2])
    assert z1 - z0 == pytest.approx(100.0 * 1.3 * 0.5, rel=0.1)


def test_planted_flat_foot_rests_on_the_floor_with_nothing_below_it():
    fg = synth.foot_geometry()
    clip = synth.kick()
    g = Ground(clip)
    # Frame 0 stands on both flat feet: the lowest body point is the floor, to MuJoCo's geometry.
    assert g.lowest_body[0] == pytest.approx(0.0, abs=1e-9)
    for side in ("left", "right"):
        ankle = g.points[side][0, 0]
        assert ankle[2] == pytest.approx(fg.ankle_height, abs=1e-9)
        assert g.height(side)[0] < 0.02  # METRICS foot height: the foot box's sole
    assert 0.05 < fg.ankle_height < 0.12 and 0.0 < fg.toe_height < fg.ankle_height


# --- locomotion ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", GAITS)
def test_gait_is_clean_by_the_metrics(lib, ground, name):
    clip, g = lib[name], ground[name]
    assert labelled_skate_mm_per_s(clip, g) < 5.0
    assert -g.lowest_body.min() * 1000.0 < 2.0  # penetrate_mm, worst frame
    for i, side in enumerate(("left", "right")):
        c = clip.contacts[:, i]
        assert c.any() and (~c).any()  # every foot both stands and swings
        h = g.height(side)
        assert np.all(h[c] < H_C)  # labels agree with METRICS contact by height…
        both = np.zeros_like(c)
        both[1:] = c[1:] & c[:-1]
        assert np.all(g.lowest_speed(side)[both] < V_C)  # …and by speed
        assert h[~c].max() > 0.06  # the swing foot leaves the floor
    if not name.startswith("run"):  # walking gaits: always a foot down, no floating (float_mm = 0)
        assert clip.contacts.any(axis=1).all()
        assert g.lowest_body.max() < 0.005


@pytest.mark.parametrize("name", GAITS)
def test_stance_feet_are_on_their_planned_footprints(lib, ground, name):
    clip, g = lib[name], ground[name]
    assert len(clip.footprints) >= 4  # several cycles
    toe_idx = 1
    for f in clip.footprints:
        toe = g.points[f.side][f.start : f.end + 1, toe_idx]
        assert np.abs(toe - np.asarray(f.position)).max() < 1e-3
        i = ("left", "right").index(f.side)
        assert clip.contacts[f.start : f.end + 1, i].all()
    # The heading of the foot in its flat phase is the planned heading.
    skel = clip.motion.skeleton
    pose = kinematics.forward(clip.compile(), clip.motion)
    for f in clip.footprints:
        if f.flat_end < f.start:
            continue
        ankle, toe = skel.feet()[f.side]
        d = pose.joint_positions[f.start : f.flat_end + 1, toe] - pose.joint_positions[f.start : f.flat_end + 1, ankle]
        assert np.allclose(np.arctan2(d[:, 1], d[:, 0]), np.angle(np.exp(1j * f.heading)), atol=1e-6)


def test_walk_always_has_a_foot_down_and_run_has_flight(lib, ground):
    assert lib["walk"].contacts.any(axis=1).all()
    assert (lib["walk"].contacts.all(axis=1)).any()  # double support
    run, g = lib["run"], ground["run"]
    flight = ~run.contacts.any(axis=1)
    assert flight.sum() >= 10
    assert not run.contacts.all(axis=1).any()  # no double support in a run
    # METRICS: both feet above h_c in some frames, and the body clear of the floor in all flight frames.
    both_up = (g.height("left") > H_C) & (g.height("right") > H_C)
    assert both_up.sum() >= 3
    # Every flight phase lifts the whole body clear of the floor (feet lift off and land at rest,
    # so the phase's ends touch it).
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flight.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        assert g.lowest_body[a:b].max() > 0.02 and g.lowest_body[a:b].min() >= 0.0
    # …and ballistic: the pelvis falls freely (z'' = -g) inside each flight.
    z = run.motion.root_positions[:, 2]
    acc = np.gradient(np.gradient(z, 1.0 / run.motion.fps), 1.0 / run.motion.fps)
    inner = flight & np.roll(flight, 2) & np.roll(flight, -2)
    inner[:2] = inner[-2:] = False
    assert inner.sum() >= 10 and np.allclose(acc[inner], -9.81, atol=0.05)


@pytest.mark.parametrize(
    "kind,speed,turn,step",
    [("walk", 1.1, 0.0, None), ("walk", 1.0, 0.0, 0.5), ("walk", 1.3, 30.0, None), ("run", 4.0, -20.0, 1.4), ("sneak", 0.5, 0.0, None)],
)
def test_gait_follows_requested_speed_turn_and_step_length(kind, speed, turn, step):
    clip = getattr(synth, kind)(speed=speed, seconds=4.0, turn_deg_per_s=turn, step_length=step)
    if step is not None:
        assert dict(clip.params)["step_length"] == step
    fps = clip.motion.fps
    # Footprints of the same foot one cycle apart: path length per cycle = speed × period, and
    # the heading advances at the turning rate.
    for side in ("left", "right"):
        fs = [f for f in clip.footprints if f.side == side and f.start > 0]  # touch-down inside the clip
        a, b = fs[0], fs[-1]
        assert b.start > a.start
        dt = (b.start - a.start) / fps
        dpsi = np.angle(np.exp(1j * (b.heading - a.heading)))
        assert np.degrees(dpsi) == pytest.approx(turn * dt, abs=max(0.05 * abs(turn * dt), 1.0))
        if turn == 0:
            chord = np.linalg.norm(np.subtract(b.position, a.position)[:2])
            assert chord == pytest.approx(speed * dt, rel=0.03)
            if step is not None:  # a cycle is two steps
                cycles = round(chord / (2 * step))
                assert cycles >= 1 and chord == pytest.approx(2 * step * cycles, rel=0.01)
    # The pelvis travels at the requested speed (its path length includes a little sway).
    root = clip.motion.root_positions[:, :2]
    length = np.linalg.norm(np.diff(root, axis=0), axis=1).sum()
    assert length / clip.motion.duration == pytest.approx(speed, rel=0.03)
    # The clip starts at the origin heading +X.
    assert np.linalg.norm(clip.motion.root_positions[0, :2]) < 0.05


@pytest.mark.parametrize("name", ["walk", "run"])
def test_arms_counter_swing_and_the_pelvis_bobs_with_the_gait(lib, name):
    clip = lib[name]
    m = clip.motion
    skel = m.skeleton
    rel = _root_frame_pose(m, list(range(m.n_frames)))  # root-relative, heading frame
    for side in ("Left", "Right"):
        hand = rel[:, skel.index(f"{side}Hand"), 0]
        ankle = rel[:, skel.index(f"{side}Foot"), 0]
        assert np.corrcoef(hand, ankle)[0, 1] < -0.7  # the arm swings against its leg
        assert np.ptp(hand) > 0.15
    # Pelvis height: a walk vaults over the stance leg (highest at single support); a run is
    # lowest in stance and highest in flight.
    z = m.root_positions[:, 2]
    single = clip.contacts.sum(axis=1) == 1
    if name == "walk":
        double = clip.contacts.all(axis=1)
        assert z[single].mean() > z[double].mean() + 0.005
    else:
        flight = ~clip.contacts.any(axis=1)
        assert z[flight].mean() > z[single].mean() + 0.01


def test_limp_is_asymmetric_and_variations_are_deterministic():
    limp = synth.limp()
    left, right = limp.contacts.mean(axis=0)
    assert left > right + 0.1  # the painful right leg carries weight for less time
    a, b = synth.walk(seed=3), synth.walk(seed=3)
    assert bvh.format_motion(a.motion) == bvh.format_motion(b.motion)
    assert bvh.format_motion(a.motion) != bvh.format_motion(synth.walk().motion)


def test_bad_gait_requests_are_refused():
    with pytest.raises(MjmotionError, match="speed"):
        synth.walk(speed=5.0)
    with pytest.raises(MjmotionError, match="turn"):
        synth.walk(speed=1.0, turn_deg_per_s=80.0)  # radius 0.7 m
    with pytest.raises(MjmotionError, match="seconds"):
        synth.run(seconds=0.1)
    with pytest.raises(MjmotionError, match="unknown gait"):
        synth.generate("hop")
    with pytest.raises(MjmotionError, match="shorter step"):
        synth.walk(step_length=1.6)  # the feet could not stay planted
    with pytest.raises(MjmotionError, match="seed"):
        synth.drive(seed=-1)


# --- shots ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name,seed", [("drive", 0), ("pull", 0), ("drive", 10), ("pull", 6)])
def test_shot_hits_its_declared_sweet_spot_through_mujoco(lib, ground, name, seed):
    clip = lib[name] if seed == 0 else getattr(synth, name)(seed=seed)
    assert clip.prop is not None and clip.prop.joint == "RightHand" and clip.hit_frame is not None
    compiled = clip.compile()
    pose = kinematics.forward(compiled, clip.motion)
    sweet = pose.site(f"{clip.prop.name}/sweet_spot")
    assert np.linalg.norm(sweet[clip.hit_frame] - clip.sweet_spot) < 1e-3
    # Impact happens in the fast part of the swing, with the bat above the floor throughout.
    speed = np.linalg.norm(np.gradient(sweet, 1.0 / clip.motion.fps, axis=0), axis=1)
    assert speed[clip.hit_frame] > 5.0 and speed[clip.hit_frame] > 0.6 * speed.max()
    assert pose.site(f"{clip.prop.name}/tip")[:, 2].min() > -0.002
    assert 10 < clip.hit_frame < clip.motion.n_frames - 10
    # The face looks along the swing, so the ball is struck along ``hit_normal``; a ball placed by
    # ``hit_ball`` touches the sweet spot (METRICS hit_error_m = 0) and MuJoCo reports the contact.
    site_x = pose.site_rotations[clip.hit_frame, pose.site_names.index(f"{clip.prop.name}/sweet_spot")][:, 0]
    assert np.allclose(clip.hit_normal, -site_x, atol=1e-6)
    v = np.gradient(sweet, 1.0 / clip.motion.fps, axis=0)[clip.hit_frame]
    assert v @ clip.hit_normal > 0.95 * np.linalg.norm(v)
    ball = clip.hit_ball()
    assert np.linalg.norm(sweet[clip.hit_frame] - np.asarray(ball.position)) - ball.radius == pytest.approx(0.0, abs=1e-6)
    with_ball = clip.compile(ball)
    d = mujoco.MjData(with_ball.model)
    d.qpos[:] = kinematics.qpos(with_ball, clip.motion[clip.hit_frame : clip.hit_frame + 1])[0]
    mujoco.mj_forward(with_ball.model, d)
    bat_id = mujoco.mj_name2id(with_ball.model, mujoco.mjtObj.mjOBJ_GEOM, clip.prop.name)
    ball_id = mujoco.mj_name2id(with_ball.model, mujoco.mjtObj.mjOBJ_GEOM, "ball")
    pairs = {frozenset((int(c.geom1), int(c.geom2))) for c in d.contact[: d.ncon]}
    assert frozenset((bat_id, ball_id)) in pairs
    # The top hand stays on the handle: the left hand is a fixed distance from the grip.
    lh = pose.joint_positions[:, clip.motion.skeleton.index("LeftHand")]
    d = np.linalg.norm(lh - pose.site(f"{clip.prop.name}/grip"), axis=1)
    assert np.ptp(d) < 1e-6  # exact IK: a clamped (unreachable) arm would show here
    g = ground[name] if seed == 0 else Ground(clip)
    assert labelled_skate_mm_per_s(clip, g) < 5.0
    assert -g.lowest_body.min() < 0.002
    # A batter always has a foot on the ground, and the body rests on the floor throughout.
    assert clip.contacts.any(axis=1).all()
    assert g.lowest_body.max() < 0.002


def test_shots_start_and_end_in_one_shared_stance(lib):
    drive, pull = lib["drive"].motion, lib["pull"].motion
    for m in (drive, pull):
        assert rot.angle_between(m.rotations[0], m.rotations[-1]).max() < 1e-9
        assert np.abs(m.root_positions[0] - m.root_positions[-1]).max() < 1e-9
    assert rot.angle_between(drive.rotations[0], pull.rotations[0]).max() < 1e-9
    assert np.abs(drive.root_positions[0] - pull.root_positions[0]).max() < 1e-9
    # …and the two swings differ in between (the drive's impact is low, the pull's at the chest).
    assert lib["drive"].sweet_spot[2] < 0.4 and lib["pull"].sweet_spot[2] > 0.8


# --- kick and punch ------------------------------------------------------------------------------
def _root_frame_pose(m, frames) -> np.ndarray:
    """Joint positions relative to the root, in its heading frame, ``(F, J, 3)``."""
    p = kinematics.joint_positions(m[frames[0] : frames[-1] + 1])[np.asarray(frames) - frames[0]]
    fwd = rot.rotate(m.rotations[frames, 0], np.array([1.0, 0.0, 0.0]))
    h = np.arctan2(fwd[:, 1], fwd[:, 0])
    local = p - p[:, :1]
    c, s = np.cos(-h)[:, None], np.sin(-h)[:, None]
    return np.stack([c * local[..., 0] - s * local[..., 1], s * local[..., 0] + c * local[..., 1], local[..., 2]], axis=-1)


@pytest.mark.parametrize("name", ["kick", "punch"])
def test_transitions_start_and_end_near_the_locomotion_stance(lib, ground, name):
    clip, walk = lib[name], lib["walk"]
    m = clip.motion
    assert rot.angle_between(m.rotations[0], m.rotations[-1]).max() < 1e-9
    ends = _root_frame_pose(m, [0])[0]
    # Double-support frames of the walk are the nearest locomotion poses.
    ds = np.flatnonzero(walk.contacts.all(axis=1))
    walk_poses = _root_frame_pose(walk.motion, list(range(ds[0], ds[-1] + 1)))
    dist = np.linalg.norm(walk_poses - ends[None], axis=2).max(axis=1)
    assert dist.min() < 0.3  # every joint within 30 cm of some walking pose (root-relative)
    g = ground[name]
    assert labelled_skate_mm_per_s(clip, g) < 5.0
    assert -g.lowest_body.min() < 0.002 and g.lowest_body.max() < 0.002
    assert clip.contacts.any(axis=1).all()
    skel = m.skeleton
    pose = kinematics.forward(clip.compile(), m)
    if name == "kick":
        foot = pose.joint_positions[:, skel.index("RightFoot")]
        assert foot[:, 2].max() > 0.7 and foot[:, 0].max() - foot[0, 0] > 0.5
        assert clip.contacts[:, 0].all() and not clip.contacts[:, 1].all()
    else:
        hand = pose.joint_positions[:, skel.index("RightHand")]
        chest = pose.joint_positions[:, skel.index("Spine2")]
        assert (hand[:, 0] - chest[:, 0]).max() > 0.4
        assert clip.contacts.all()


# --- warps ---------------------------------------------------------------------------------------
def test_smooth_warp_is_strictly_increasing_and_covers_the_clip():
    w = synth.smooth_warp(241, 200, strength=0.5, seed=3)
    assert w.shape == (200,) and w[0] == 0.0 and w[-1] == pytest.approx(240.0)
    assert np.all(np.diff(w) > 0)
    assert np.ptp(np.diff(w)) > 0.1  # not a linear map
    with pytest.raises(MjmotionError):
        synth.smooth_warp(10, 10, strength=1.5)


def test_warp_carries_the_ground_truth(lib):
    walk = lib["walk"]
    # An integer shift: contacts and footprints move by exactly that many frames.
    shift = 17
    moved = synth.warp(walk, lambda i: i + shift, 0.0, (0.0, 0.0), n_frames=walk.motion.n_frames - shift)
    assert np.array_equal(moved.contacts, walk.contacts[shift:])
    assert np.allclose(moved.motion.rotations, walk.motion.rotations[shift:])
    # A smooth warp plus a rigid move: planted feet sit on the moved footprints.
    ww = lib["walk_warped"]
    assert ww.warp is not None and ww.warp.source == "walk"
    g = Ground(ww)
    for f in ww.footprints:
        toe = g.points[f.side][f.start : f.end + 1, 1]
        assert np.abs(toe[:, :2] - np.asarray(f.position[:2])).max() < 1e-3
    # The truth is the foundation's timewarp + floor_transform of the source.
    from mjmotion.transform import floor_transform, timewarp

    src = ww.warp.source_frames
    expect = floor_transform(timewarp(walk.motion, lambda i: src, len(src)), ww.warp.rotation, ww.warp.translation)
    assert np.allclose(expect.root_positions, ww.motion.root_positions)
    # A warped shot keeps a consistent hit: MuJoCo's sweet spot at the new hit frame.
    drive = lib["drive"]
    w = synth.smooth_warp(drive.motion.n_frames, 140, 0.3, seed=1)
    dw = synth.warp(drive, w, -0.4, (2.0, 1.0))
    pose = kinematics.forward(dw.compile(), dw.motion)
    assert np.linalg.norm(pose.site("bat/sweet_spot")[dw.hit_frame] - dw.sweet_spot) < 1e-3
    assert abs(w[dw.hit_frame] - drive.hit_frame) <= 1.0


# --- files ---------------------------------------------------------------------------------------
def test_library_round_trips_through_bvh_and_manifest_deterministically(tmp_path, lib):
    a, b = tmp_path / "a", tmp_path / "b"
    synth.write_library(a, clips=lib)
    synth.write_library(b)  # freshly generated: the same bytes
    files = sorted(p.name for p in a.iterdir())
    assert files == sorted(p.name for p in b.iterdir()) and "manifest.json" in files
    for name in files:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    loaded = synth.load_library(a)
    assert set(loaded) == set(lib)
    for name, clip in lib.items():
        back = loaded[name]
        assert same_ground_truth(clip, back), name
        assert rot.angle_between(clip.motion.rotations, back.motion.rotations).max() < 1e-6
        assert np.abs(clip.motion.root_positions - back.motion.root_positions).max() < 1e-6
        assert back.motion.fps == clip.motion.fps
        compiled = back.compile()
        assert compiled.model.nq == 7 + 4 * (back.motion.skeleton.n_joints - 1)
        if back.hit_frame is not None:
            pose = kinematics.forward(compiled, back.motion[back.hit_frame : back.hit_frame + 1])
            assert np.linalg.norm(pose.site("bat/sweet_spot")[0] - back.sweet_spot) < 1e-3
    manifest = json.loads((a / "manifest.json").read_text())
    assert manifest["clips"]["drive"]["prop"]["joint"] == "RightHand"
    with pytest.raises(MjmotionError, match="already exists"):
        synth.write_library(a, clips={"walk": lib["walk"]})


def test_load_library_reports_bad_manifests(tmp_path):
    with pytest.raises(MjmotionError, match="no manifest"):
        synth.load_library(tmp_path)
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(MjmotionError, match="JSON"):
        synth.load_library(tmp_path)
    (tmp_path / "manifest.json").write_text(json.dumps({"version": 1, "clips": {"w": {"file": "w.bvh", "n_frames": 3}}}))
    bvh.write(synth.walk(seconds=0.5).motion, tmp_path / "w.bvh")
    with pytest.raises(MjmotionError, match="'w'"):
        synth.load_library(tmp_path)


def test_cli_writes_the_same_clip_and_reports_errors(tmp_path, capsys):
    out = tmp_path / "run.bvh"
    truth = tmp_path / "run.json"
    argv = ["synth", "run", "--speed", "4", "--turn", "-20", "--seconds", "2", "-o", str(out), "--truth", str(truth)]
    assert main(argv) == 0
    clip = synth.run(speed=4.0, turn_deg_per_s=-20.0, seconds=2.0)
    assert out.read_text() == bvh.format_motion(clip.motion)
    entry = json.loads(truth.read_text())
    assert entry["n_frames"] == clip.motion.n_frames and entry["params"]["speed"] == 4.0
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and "already exists" in err
    assert main(["synth", "drive", "--speed", "3", "-o", str(tmp_path / "d.bvh")]) == 2
    err = capsys.readouterr().err
    assert "gaits only" in err and "Traceback" not in err
    assert main(["synth", "library"]) == 2
    assert "folder" in capsys.readouterr().err
    assert main(["synth", "library", str(tmp_path / "lib")]) == 0
    assert set(synth.load_library(tmp_path / "lib")) == set(synth.library())


# --- the judge's joint ranges ---------------------------------------------------------------------
#: The shots' hands cannot be brought inside the wrist's range by bone rolls: their bat keys bend
#: the hand against the forearm (the wrist's swing, not its twist), which no roll changes.
@pytest.mark.parametrize("name", (*GAITS, "walk_warped", "drive", "pull", "kick", "punch"))
def test_every_bundled_clip_stays_inside_the_judges_joint_ranges(lib, name):
    from mjmotion import evaluate, limits

    assert set(lib) == {*GAITS, "walk_warped", "drive", "pull", "kick", "punch"}  # every clip is checked
    m = lib[name].motion
    over = limits.violations(m.skeleton, m.rotations)
    bad = {m.skeleton.names[j]: int(over[:, j].sum()) for j in np.flatnonzero(over.any(axis=0))}
    assert not bad, f"frames beyond range per joint: {bad}"
    ratio, n_limited = evaluate.limit_violation_ratio(lib[name].compile(), m)
    assert ratio == 0.0 and n_limited == m.skeleton.n_joints - 1  # MuJoCo's own ranges agree


def test_a_free_foot_follows_its_shin_and_a_planted_one_keeps_its_plan(lib):
    from mjmotion import limits
    from mjmotion.synth.body import ANKLE_MARGIN, ankle_limited

    skel = synth.skeleton()
    ankle = skel.index("RightFoot")
    ceiling = limits.joint_limits(skel)[ankle] - ANKLE_MARGIN
    # The limit saturates the angle below the range, about the same axis, monotonically.
    a = np.radians(np.linspace(0.0, 175.0, 200))
    axis = np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2])
    q = rot.exp(a[:, None] * axis)
    out = ankle_limited(q, ankle)
    b = 2 * np.arccos(np.clip(np.abs(out[:, 0]), 0, 1))
    assert b.max() < ceiling and np.all(np.diff(b) > 0)
    assert np.allclose(rot.log(out[1:]) / b[1:, None], axis, atol=1e-9)  # about the same axis
    assert np.array_equal(out[a < np.radians(50.0)], q[a < np.radians(50.0)])  # ordinary ankles untouched
    # In the run and kick the limit acts in swing only; stance frames are the plan (footprints hold, tested above).
    for name in ("run", "kick"):
        clip = lib[name]
        ang = limits.rotation_angles(clip.motion.rotations)
        for i, side in enumerate(("Left", "Right")):
            j = skel.index(f"{side}Foot")
            assert ang[:, j].max() < ceiling
            assert ang[clip.contacts[:, i], j].max() < ceiling - np.radians(12.0)


# --- arms holding a prop (synth.body.arm with fit_range) -------------------------------------------
def _angle(q):
    return 2.0 * np.arctan2(rot.norm(q[..., 1:]), np.abs(q[..., 0]))


@pytest.mark.parametrize("side", ["Left", "Right"])
def test_the_twist_share_is_the_brute_force_optimum(side):
    """The roll moved from the wrist into the forearm minimises the two joints' fractions of range in
    the TWIST_NORM power sum (from the rotations themselves, composed by quaternion products): equal
    to a dense search over every roll, and within a few percent of the best largest fraction."""
    from mjmotion.synth import body

    rng = np.random.default_rng(5)
    _, lf, lh = body._ranges(side)
    s = 1.0 if side == "Left" else -1.0
    n = 300
    bend_axis = rng.normal(size=(n, 3))
    bend_axis[:, 1] = 0.0  # the elbow bends about an axis across the bone (local y)
    bend_axis /= np.linalg.norm(bend_axis, axis=1, keepdims=True)
    fore = rot.exp(bend_axis * rng.uniform(0.0, 2.6, (n, 1)))
    hand = rot.exp(rng.normal(size=(n, 3)) * rng.uniform(0.2, 1.6, (n, 1)))
    share = body.twist_share(side, fore, hand)

    def roll(a):
        return rot.exp(np.asarray(a)[..., None] * np.array([0.0, s, 0.0]))

    def fractions(a):
        return _angle(rot.multiply(fore, roll(a))) / lf, _angle(rot.multiply(rot.conjugate(roll(a)), hand)) / lh

    def cost(a):
        f, h = fractions(a)
        return f**body.TWIST_NORM + h**body.TWIST_NORM

    grid = np.linspace(-np.pi, np.pi, 2001)
    brute = np.min([cost(np.full(n, a)) for a in grid], axis=0)
    assert np.all(cost(share) <= brute * (1 + 1e-6) + 1e-12)  # no roll on the grid does better
    best_max = np.min([np.maximum(*fractions(np.full(n, a))) for a in grid], axis=0)
    assert np.all(np.maximum(*fractions(share)) <= best_max * 1.05)  # and the larger fraction nearly the least it can be
    assert np.any(np.abs(share) > 0.3)  # the forearm does take roll (pronation) in many of them
    q = hand * np.sign(hand[:, :1])
    assert np.all(np.abs(share) <= np.abs(2.0 * np.arctan2(s * q[:, 2], q[:, 0])) + 1e-9)  # never more than the hand's twist


def _right_arm(t):
    """A standing body's right arm over ``t`` frames: builder, shoulder and wrist ``(t, 3)``, pole, designed forearm."""
    from mjmotion.synth import body

    pb = body.PoseBuilder(t, np.tile([0.0, 0.0, 1.0], (t, 1)))
    pb.update()
    shoulder = pb.pos("RightArm")
    wrist = shoulder + np.array([0.25, -0.15, -0.3])
    pole = np.tile([-0.3, -0.6, -1.0], (t, 1))
    return pb, shoulder, wrist, pole, body._arm_frames("Right", shoulder, wrist, pole)[1]


def test_a_fitted_arm_keeps_the_designed_elbow_inside_the_ranges_and_leaves_it_beyond():
    """The elbow swivel turns only where the designed one would put a joint past ARM_RANGE_FILL of its range."""
    from mjmotion.synth import body

    t = 90
    pb, shoulder, wrist, pole, fore = _right_arm(t)
    # The hand continues the forearm (no swivel needed), then turns 150° about the vertical over half a second.
    turn = np.radians(150.0) * body.min_jerk((np.arange(t) - 30) / 30.0)
    hand = rot.multiply(body.axis_angle("z", turn), fore)
    parent = pb.wrot("RightShoulder")
    designed = body.arm_fill("Right", parent, shoulder, wrist, pole, hand)
    swivel = body.arm_swivel("Right", parent, shoulder, wrist, pole, hand, 60.0)
    fitted = body.arm_fill("Right", parent, shoulder, wrist, body.swivelled(shoulder, wrist, pole, swivel), hand)
    # Kept where it fits (it starts turning a little ahead of the need, as the step cost asks).
    assert designed[:30].max() < body.ARM_RANGE_FILL and np.abs(swivel[:15]).max() < np.radians(0.5)
    assert designed[60:].min() > 1.0  # the designed elbow puts a joint past its range ...
    # ... the fitted one as far inside as the best swivel of each frame allows (a brute-force search), or the fill.
    best = np.min(
        [
            body.arm_fill("Right", parent, shoulder, wrist, body.swivelled(shoulder, wrist, pole, np.full(t, a)), hand)
            for a in np.radians(np.arange(-180, 180, 2.0))
        ],
        axis=0,
    )
    assert fitted[60:].max() < 1.0 and np.all(fitted[60:] <= np.maximum(best[60:], body.ARM_RANGE_FILL) + 0.02)
    assert np.abs(swivel[60:]).min() > np.radians(10.0)
    # Turning as fast as the hand does (150° in half a second), smoothly: no step or kink from the grid.
    assert np.abs(np.diff(swivel)).max() < np.radians(12.0) and np.abs(np.diff(swivel, 2)).max() < np.radians(2.0)


@pytest.mark.parametrize("name", ["drive", "pull"])
def test_the_shots_arms_fit_their_ranges_and_move_smoothly(lib, name):
    from mjmotion import evaluate, limits

    m = lib[name].motion
    skel = m.skeleton
    arms = [skel.index(f"{side}{part}") for side in ("Left", "Right") for part in ("Arm", "ForeArm", "Hand")]
    fill = limits.rotation_angles(m.rotations[:, arms]) / limits.joint_limits(skel)[arms]
    assert fill.max() < 1.0
    speed = evaluate.joint_angular_speeds(m)[:, arms]
    assert speed.max() < 30.0  # rad/s: the hands swing the bat; a roll flipping in a frame would read hundreds
    accel = evaluate.joint_angular_accelerations(m)[:, arms]
    assert accel.max() < 750.0  # rad/s²: no kink where the swivel or the twist share changes


def test_the_hit_fill_leaves_room_at_the_hit_and_the_swivel_uses_it():
    """body.hit_fill is HIT_FILL at the hit and ARM_RANGE_FILL from HIT_FILL_S away; the elbow swivel
    keeps a per-frame fill: where it is lowered the arm turns to stay within it (as far as the best
    swivel of the frame allows, a brute-force search, to a few %), elsewhere it keeps the designed elbow."""
    from mjmotion.synth import body

    fps, t, hit = 60.0, 90, 45
    f = body.hit_fill(t, hit, fps)
    assert f[hit] == pytest.approx(body.HIT_FILL) and f.max() == pytest.approx(body.ARM_RANGE_FILL)
    far = np.abs(np.arange(t) - hit) >= body.HIT_FILL_S * fps
    assert np.allclose(f[far], body.ARM_RANGE_FILL) and np.all(np.diff(f[: hit + 1]) <= 0) and np.all(np.diff(f[hit:]) >= 0)

    pb, shoulder, wrist, pole, fore = _right_arm(t)
    hand = rot.multiply(body.axis_angle("z", np.full(t, np.radians(75.0))), fore)  # a hand turned against its forearm
    parent = pb.wrot("RightShoulder")
    designed = body.arm_fill("Right", parent, shoulder, wrist, pole, hand)
    assert body.HIT_FILL < designed.min() and designed.max() < body.ARM_RANGE_FILL  # fits the flat fill, not the hit's
    assert np.abs(body.arm_swivel("Right", parent, shoulder, wrist, pole, hand, fps)).max() < np.radians(0.5)
    swivel = body.arm_swivel("Right", parent, shoulder, wrist, pole, hand, fps, f)
    fitted = body.arm_fill("Right", parent, shoulder, wrist, body.swivelled(shoulder, wrist, pole, swivel), hand)
    best = np.min(
        [
            body.arm_fill("Right", parent, shoulder, wrist, body.swivelled(shoulder, wrist, pole, np.full(t, a)), hand)
            for a in np.radians(np.arange(-180, 180, 2.0))
        ],
        axis=0,
    )
    assert best[hit] < body.HIT_FILL and abs(swivel[hit]) > np.radians(10.0)
    # (within a few % of it: the V-shaped fill is followed through the swivel's step cost and smoothing)
    assert fitted[hit] <= body.HIT_FILL + 0.05 and fitted[hit] < designed[hit] - 0.15
    assert np.all(fitted <= np.maximum(f, best) + 0.05)
    assert np.abs(swivel[:5]).max() < np.radians(0.5) and np.abs(swivel[-5:]).max() < np.radians(0.5)  # kept away from the hit


@pytest.mark.parametrize("target", [(0.0, 0.0, 0.2), (-0.2, 0.0, 0.2)])
def test_the_bundled_drive_has_room_to_reach_a_ball_20_cm_higher(target):
    """With its arms inside the judge's ranges the drive still adapts to a ball 20 cm higher (the DLS,
    the locked wrist, the hit-point grid's targets) with the top hand on the grip: the keys leave
    the arms room at the hit (body.HIT_FILL). Keys filling the ranges to 86 % at the hit stopped
    short of one of these and let the top hand off the grip by 12 mm on the other."""
    from mjmotion import hitpoint
    from mjmotion.experiments import hitpoint_grid as hg

    shot = next(s for s in hg.load_shots(None, quick=True) if s.name == "drive")
    offs = hg.grid_offsets(shot, (0.2,))
    off = offs[np.argmin(np.linalg.norm(offs - np.array(target), axis=1))]
    a = hitpoint.adapt(shot.motion, offset=off, frame=shot.hit_frame, effector="club", solver="dls", wrist="locked", prop=shot.prop)
    assert a.report["reachable"] and a.report["hit_error_m"] < 1e-3, a.report.get("message")
    assert a.report["grip_error_m"] < 1e-3 and a.report["lowest_above_floor_m"] > 0.0
