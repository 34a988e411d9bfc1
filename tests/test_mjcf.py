"""The MJCF compiler: structure, masses, feet, props, the ball, names, and the XML round trip."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import clip_params, random_motion, random_skeleton, require_data

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError
from mjmotion.skeleton import Skeleton


@pytest.mark.parametrize("path", clip_params())
def test_every_shared_clip_compiles_with_realistic_mass_and_feet(path):
    if path is None:
        require_data()
    m = bvh.read(path)
    c = mjcf.compile(m.skeleton)
    mass = float(c.model.body_mass[c.body_ids].sum())
    assert 40.0 < mass < 110.0
    assert c.model.nq == 7 + 4 * (m.skeleton.n_joints - 1)
    assert set(c.foot_geoms) == {"left", "right"}


def test_xml_round_trip_has_same_kinematics_with_hostile_names(tmp_path):
    rng = np.random.default_rng(4)
    skel = random_skeleton(rng, 9)
    names = ('root <&> "x"', "joint:with:colons", "has space", "tab'quote", "ünïcode", "a/b", "x&y", "<z>", "j8")
    skel = Skeleton(names, skel.parents, skel.offsets, skel.channels, skel.end_parents, skel.end_offsets, 1.0, "z")
    motion = random_motion(rng, skel, 6)
    compiled = mjcf.compile(skel, [mjcf.default_prop(skel, "bat", names[4])], mjcf.Ball())
    path = tmp_path / "model.xml"
    compiled.save_xml(path)
    loaded = mujoco.MjModel.from_xml_path(str(path))
    assert loaded.nq == compiled.model.nq and loaded.nbody == compiled.model.nbody
    q = kinematics.qpos(compiled, motion)
    d1, d2 = mujoco.MjData(compiled.model), mujoco.MjData(loaded)
    for row in q:
        d1.qpos[:] = row
        d2.qpos[:] = row
        mujoco.mj_kinematics(compiled.model, d1)
        mujoco.mj_kinematics(loaded, d2)
        assert np.allclose(d1.xpos, d2.xpos, atol=1e-9)
        assert np.allclose(d1.site_xpos, d2.site_xpos, atol=1e-9)
    for n in names:
        assert mujoco.mj_name2id(loaded, mujoco.mjtObj.mjOBJ_BODY, n) >= 0


def test_prop_sweet_spot_follows_the_hand(mocap):
    m = bvh.read(mocap / "cmu_asfamc_converted" / "64_01.bvh")[:50]
    prop = mjcf.default_prop(m.skeleton, "club", "rwrist")
    c = mjcf.compile(m.skeleton, [prop])
    pose = kinematics.forward(c, m)
    j = m.skeleton.index("rwrist")
    grip = pose.site("club/grip")
    sweet = pose.site("club/sweet_spot")
    # The grip stays a fixed distance from the wrist and the sweet spot a fixed distance along the shaft.
    d_grip = np.linalg.norm(grip - pose.joint_positions[:, j], axis=1)
    assert np.ptp(d_grip) < 1e-9
    assert np.allclose(np.linalg.norm(sweet - grip, axis=1), prop.sweet_spot)


def test_foot_boxes_sit_on_the_sole_in_the_rest_pose(mocap):
    m = bvh.read(mocap / "cmu_asfamc_converted" / "16_15.bvh")
    skel = m.skeleton
    c = mjcf.compile(skel)
    d = mujoco.MjData(c.model)
    d.qpos[:] = c.model.qpos0
    mujoco.mj_kinematics(c.model, d)
    ankle, toe = skel.feet()["left"]
    toe_tip = skel.rest_end_positions()[list(skel.end_parents).index(toe)]
    g = c.foot_geoms["left"][0]
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * c.model.geom_size[g]
    world = d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T
    # Rest pose: the skeleton stands nearly along z, so the box bottom is at the toe tip's height
    # (qpos0 lifts the rest pose by the root's height so that it stands on the floor).
    lift = c.model.qpos0[2]
    assert world[:, 2].min() == pytest.approx(toe_tip[2] + lift, abs=0.01)
    assert world[:, 2].max() <= skel.rest_positions()[ankle][2] + lift + 0.01


@pytest.mark.parametrize(("names", "clash"), [(("root", "ball"), "ball"), (("world", "hip"), "world")])
def test_name_clash_with_added_elements_is_refused(names, clash):
    # "world" is MuJoCo's body 0: a BVH root of that name failed inside MuJoCo ("repeated name").
    skel = Skeleton(names, np.array([-1, 0]), np.zeros((2, 3)), (("Xrotation",), ("Xrotation",)))
    with pytest.raises(MjmotionError, match=rf"\['{clash}'\] clash"):
        mjcf.compile(skel)


def test_unknown_prop_kind_is_refused(mocap):
    m = bvh.read(mocap / "cmu_asfamc_converted" / "64_01.bvh")
    with pytest.raises(MjmotionError, match="unknown prop"):
        mjcf.parse_prop_option(m.skeleton, "racket:rwrist")
    with pytest.raises(MjmotionError, match="no joint named"):
        mjcf.parse_prop_option(m.skeleton, "club:nowhere")


@pytest.mark.parametrize("clip", ["cmu_asfamc_converted/16_15", "cmu_cgspeed_daz/07_01", "cmu_cgspeed_max/131_01", "cmu_iclone_ccrig/002_05"])
def test_segment_masses_follow_de_leva(mocap, clip):
    skel = bvh.read(mocap / f"{clip}.bvh").skeleton
    c = mjcf.compile(skel)
    masses = c.model.body_mass[c.body_ids]
    total = masses.sum()
    by: dict[str, float] = {}
    for mass, seg in zip(masses, mjcf.segments(skel)):
        key = {"neck": "head", "girdle": "trunk"}.get(seg, seg)
        by[key] = by.get(key, 0.0) + mass
    for seg, frac in mjcf.SEGMENT_MASS.items():
        expect = frac * (1 if seg in ("head", "trunk") else 2)
        assert by[seg] / total == pytest.approx(expect, abs=2e-4), seg  # zero-length bones weigh 0.1 g each


def test_no_body_geom_reaches_below_the_foot_sole_in_the_rest_pose(mocap):
    # Standing in the rest pose with the soles at z = 0, nothing of the body may be lower.
    skel = bvh.read(mocap / "cmu_asfamc_converted" / "16_15.bvh").skeleton
    c = mjcf.compile(skel)
    d = mujoco.MjData(c.model)
    d.qpos[:] = c.model.qpos0
    mujoco.mj_kinematics(c.model, d)
    from mjmotion.evaluate import box_corners

    def lowest(g):
        size, pos, mat = c.model.geom_size[g], d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3)
        if c.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            return box_corners(pos[None, None], mat[None, None], size[None])[..., 2].min()
        return pos[2] - abs(mat[2, 2]) * size[1] - size[0]

    sole = min(lowest(g) for side in c.foot_geoms.values() for g in side)
    others = [lowest(g) for g in c.body_geom_ids if all(g not in side for side in c.foot_geoms.values())]
    assert min(others) >= sole - 1e-9


# --- standing, keyframes, servos ----------------------------------------------------------------
STANDING = {
    "asf": ("cmu_asfamc_converted/16_15", 2),
    "daz": ("cmu_cgspeed_daz/07_01", 4),
    "max": ("cmu_cgspeed_max/131_01", 0),
    "iclone": ("cmu_iclone_ccrig/002_05", 1),
}


def _lowest(c, qpos):
    d = mujoco.MjData(c.model)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(c.model, d)
    return mjcf.lowest_point(c.model, d, mjcf.character_geoms(c.model, int(c.body_ids[0])))


def _clip(name):
    rel, start = STANDING[name]
    return bvh.read(require_data() / f"{rel}.bvh")[start:]


def _corners_lowest(c, qpos):
    """The lowest point of the character's geoms, independently: box corners and capsule end caps."""
    m = c.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    low = np.inf
    for g in mjcf.character_geoms(m, int(c.body_ids[0])):
        mat, size, pos = d.geom_xmat[g].reshape(3, 3), m.geom_size[g], d.geom_xpos[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * size
            low = min(low, float((pos + corners @ mat.T)[:, 2].min()))
        else:
            ends = pos + np.outer([-1.0, 1.0], mat[:, 2] * size[1])
            low = min(low, float(ends[:, 2].min() - size[0]))
    return low


@pytest.mark.parametrize("name", list(STANDING))
def test_rest_pose_stands_on_the_floor_and_the_keyframe_touches_it(name, tmp_path):
    motion = _clip(name)
    c = mjcf.compile(motion.skeleton)
    assert abs(_corners_lowest(c, c.model.qpos0)) < 1e-9
    q = kinematics.qpos(c, motion[:1])[0]
    q[2] += 0.37  # wherever the clip's first frame is, the keyframe is put on the floor
    keyed = mjcf.add_keyframe(c, q, name="first_frame")
    path = tmp_path / "k.xml"
    keyed.save_xml(path)
    loaded = mujoco.MjModel.from_xml_path(str(path))
    assert np.allclose(loaded.qpos0, c.model.qpos0)
    assert loaded.nkey == 1 and abs(_corners_lowest(keyed, loaded.key_qpos[0])) < 0.01
    assert np.allclose(loaded.key_qpos[0, 3:], q[3:], atol=1e-6) and np.allclose(loaded.key_qpos[0, :2], q[:2], atol=1e-6)


def test_servo_lengths_are_rotation_vectors_from_the_neutral_pose():
    from mjmotion import synth

    skel = synth.skeleton()
    rng = np.random.default_rng(5)
    neutral = rot.normalize(rng.normal(size=(skel.n_joints, 4)))
    c = mjcf.add_actuators(mjcf.compile(skel), neutral)
    assert c.model.nu == 3 * (skel.n_joints - 1)
    q = c.model.qpos0.copy()
    local = rot.normalize(rot.multiply(neutral, rot.exp(rng.normal(scale=0.8, size=(skel.n_joints, 3)))))
    for j in range(1, skel.n_joints):
        q[c.qpos_adr[j] : c.qpos_adr[j] + 4] = local[j]
    d = mujoco.MjData(c.model)
    d.qpos[:] = q
    mujoco.mj_forward(c.model, d)
    expect = rot.log(rot.multiply(rot.conjugate(neutral[1:]), local[1:])).ravel()
    assert np.allclose(d.actuator_length, expect, atol=1e-9)


@pytest.mark.parametrize("name", list(STANDING))
def test_servos_hold_the_keyframe_for_two_seconds_without_instability(name):
    from mjmotion.skin import bind

    motion = _clip(name)
    c = mjcf.compile(motion.skeleton)
    served = mjcf.add_keyframe(mjcf.add_actuators(c, bind.bind_rotations(motion.skeleton, motion)), kinematics.qpos(c, motion[:1])[0])
    free = mjcf.add_keyframe(c, kinematics.qpos(c, motion[:1])[0])
    worst = {}
    for label, model in (("servos", served.model), ("free", free.model)):
        d = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, d, 0)
        start = d.qpos.copy()
        dev = 0.0
        for step in range(int(round(2.0 / model.opt.timestep))):
            mujoco.mj_step(model, d)
            if step % 25 == 0:
                dev = max(dev, max(float(np.degrees(rot.angle_between(d.qpos[a : a + 4], start[a : a + 4]))) for a in c.qpos_adr[1:]))
        worst[label] = dev
        if label == "servos":
            assert np.all(np.isfinite(d.qpos)) and all(w.number == 0 for w in d.warning), [w.number for w in d.warning]
    # Every joint within 25° of its keyframe angle for 2 s (the body, unbalanced, may tip over); without servos it folds up.
    assert worst["servos"] < 25.0 and worst["free"] > 45.0


def test_foot_boxes_given_replace_the_rest_pose_boxes_and_bad_ones_are_refused():
    from mjmotion import synth

    skel = synth.skeleton()
    ankle, toe = skel.feet()["left"]
    box = (np.array([0.02, 0.0, -0.05]), np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.1, 0.04, 0.02]))
    c = mjcf.compile(skel, foot_boxes={ankle: {"foot/left": box}})
    g = c.model.geom("foot/left")
    assert np.allclose(g.pos, box[0]) and np.allclose(g.size, box[2])
    assert len(c.foot_geoms["left"]) == 1 and "right" not in c.foot_geoms  # only what was given
    for bad, joint in (("shoe/left", ankle), ("foot/middle", ankle), ("foot/left", 0)):
        with pytest.raises(MjmotionError, match="foot box"):
            mjcf.compile(skel, foot_boxes={joint: {bad: box}})


def test_a_ball_or_prop_that_is_no_thing_is_refused_where_it_is_made():
    """A NaN ball gave NaN hit metrics read as a hit (and 100,000 MuJoCo warnings in MUJOCO_LOG.TXT); a
    negative prop length or a zero quaternion was taken; two props of one name failed in MuJoCo's compiler."""
    nan = float("nan")
    for kwargs, message in (
        (dict(position=(nan, 0.5, 0.2)), "Ball position: expected 3 finite numbers"),
        (dict(position=(1.0, 0.0)), "Ball position: expected 3 finite numbers"),
        (dict(radius=0.0), "Ball radius: expected a finite number > 0"),
        (dict(mass=nan), "Ball mass: expected a finite number > 0"),
    ):
        with pytest.raises(MjmotionError, match=message):
            mjcf.Ball(**kwargs)
    for kwargs, message in (
        (dict(length=-1.0), "Prop club length"),
        (dict(length=nan), "Prop club length"),
        (dict(quat=(0.0, 0.0, 0.0, 0.0)), "Prop club quat: expected a rotation"),
        (dict(pos=(nan, 0.0, 0.0)), "Prop club pos"),
        (dict(mass=-1.0), "Prop club mass"),
        (dict(sweet_spot=float("inf")), "Prop club sweet_spot"),
    ):
        with pytest.raises(MjmotionError, match=message):
            mjcf.Prop("club", "RightHand", **kwargs)
    from mjmotion import evaluate, synth

    drive = synth.drive()
    skel = drive.motion.skeleton
    with pytest.raises(MjmotionError, match="two props named 'bat'"):
        mjcf.compile(skel, (drive.prop, drive.prop))
    for kwargs, message in (
        (dict(hit_frame=66.5), r"hit_frame=66\.5: expected a whole frame number"),
        (dict(hit_frame=66, ball_velocity=(nan, 0.0, 0.0)), "ball_velocity: expected 3 finite numbers"),
        (dict(hit_frame=66, ball_velocity=(0.0, 0.0)), "ball_velocity: expected 3 finite numbers"),
    ):
        with pytest.raises(MjmotionError, match=message):
            evaluate.evaluate(drive.motion, props=[drive.prop], ball=mjcf.Ball((0.3, 0.5, 0.2)), **kwargs)


@pytest.mark.parametrize("rel", ["cmu_asfamc_converted/64_04", "cmu_cgspeed_daz/05_01", "cmu_cgspeed_daz/07_01"])
def test_compile_puts_the_judges_floor_at_the_models_floor(rel, tmp_path):
    """The issue asks renders and compile to use the judge's floor: compile's keyframe stood on the
    rest-pose boxes, and the judge's floor of golf 64_04 lay 6.3 cm below the model's floor (daz 05_01:
    1.8 cm above it)."""
    from mjmotion import evaluate, feet, trim
    from mjmotion.cli import main

    path = require_data() / f"{rel}.bvh"
    clip = trim.skip_leading_transient(bvh.read(path))[0]
    judged = feet.judged_floor(clip)
    out = tmp_path / "m.xml"
    assert main(["compile", str(path), "-o", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_kinematics(model, data)
    lv = judged.level  # a tilted floor (daz 07_01, 1.1°): its height under the first frame
    under = judged.height + (0.0 if lv.flat else float(np.dot(lv.rise, clip.root_positions[0, :2] - np.asarray(lv.pivot[:2]))))
    lift = data.xpos[1][2] - clip.root_positions[0, 2]  # how compile moved the first frame (and only moved it)
    assert abs(under + lift) < 1e-3, (under, lift)
    np.testing.assert_allclose(data.qpos[3:7], clip.rotations[0, 0], atol=1e-6)
    # its feet are the judge's: the boxes render draws (calibrated on the clip)
    drawn = feet.judged_model(clip)
    for side in ("left", "right"):
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"foot/{side}")
        np.testing.assert_allclose(model.geom_size[gid], drawn.model.geom(f"foot/{side}").size, atol=1e-5)  # (the XML keeps 6 digits)
    # --floor 0 keeps the clip where it was captured
    assert main(["compile", str(path), "-o", str(out), "--force", "--floor", "0"]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    assert abs(model.key_qpos[0, 2] - clip.root_positions[0, 2]) < 1e-6
    assert evaluate.evaluate(clip, floor=0.0).floor_from == "given"


def test_compile_takes_a_short_source_for_its_floor(tmp_path, capsys):
    """A --source gives compile and render a floor, not a speed reference: 12 frames are enough (refused
    when the commands asked every source for one low-pass period)."""
    from mjmotion.cli import main

    walk = bvh.read(require_data() / "cmu_cgspeed_daz/07_01.bvh")[4:]
    clip, src, out = tmp_path / "walk.bvh", tmp_path / "src12.bvh", tmp_path / "m.xml"
    bvh.write(walk[:200], clip)
    bvh.write(walk[200:212], src)
    assert main(["compile", str(clip), "--source", str(src), "-o", str(out)]) == 0, capsys.readouterr().err
    bvh.write(walk[200:202], src)
    assert main(["compile", str(clip), "--source", str(src), "-o", str(out), "--force"]) == 2
    assert capsys.readouterr().err.startswith(f"error: --source {src}: 2 frames; the judge needs at least 3 frames of a source")
