"""BVH reading and writing: format variants, validation, and lossless round trips."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import clip_params, random_motion, random_skeleton, require_data
from reference_fk import file_to_world, reference_fk

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import BvhError

SMALL = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 90 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 20 0
\t\tCHANNELS 3 Zrotation Yrotation Xrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 0 0
\t\t}
\t}
\tJOINT Leg
\t{
\t\tOFFSET 10 -5 0
\t\tCHANNELS 6 Xrotation Yrotation Zrotation Xposition Yposition Zposition
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
}
MOTION
Frames:\t2
Frame Time: .0083333
1 2 3 10 20 30 5 6 7 8 9 10 1 2 3
4 5 6 -10 -20 -30 -5 -6 -7 -8 -9 -10 -1 -2 -3
"""


def _fk_world(motion):
    return kinematics.forward(mjcf.compile(motion.skeleton), motion).joint_positions


def test_small_file_reads_every_feature():
    m = bvh.parse(SMALL, "small.bvh")
    s = m.skeleton
    assert s.names == ("Hips", "Chest", "Leg")
    assert list(s.parents) == [-1, 0, 0]
    assert s.channels[2] == ("Xrotation", "Yrotation", "Zrotation", "Xposition", "Yposition", "Zposition")
    assert len(s.end_parents) == 2 and np.allclose(s.end_offsets[0], 0.0)  # zero-length End Site kept
    assert m.fps == pytest.approx(1 / 0.0083333)
    assert s.scale == 0.01  # 120-unit-tall skeleton: centimetres
    # Position channels add to OFFSET (seed 004 §6.3.5): root at (0+1, 90+2, 0+3) cm, Y up → world (z, x, y).
    assert np.allclose(m.root_positions[0], [0.03, 0.01, 0.92])
    # The inner 6-channel joint's translation is offset + channels.
    assert np.allclose(m.translations[0, 2], np.array([0 + 3, 10 + 1, -5 + 2]) * 0.01)
    names, ref = reference_fk(SMALL)
    assert np.abs(_fk_world(m) - file_to_world(ref, 0.01)).max() < 1e-12


@pytest.mark.parametrize(
    "variant",
    [
        lambda t: t.replace("\n", "\r\n"),
        lambda t: "\ufeff" + t,
        lambda t: t.replace("\t", "    "),
        lambda t: t.replace("\t", " \t "),
        lambda t: t.replace("Frames:\t2", "Frames: 2"),
        lambda t: t + "\n\n",
    ],
    ids=["crlf", "bom", "spaces", "mixed-whitespace", "frames-space", "trailing-blank-lines"],
)
def test_format_variants_read_the_same(variant):
    base = bvh.parse(SMALL, "a.bvh")
    other = bvh.parse(variant(SMALL).encode("utf-8"), "b.bvh")
    assert other.skeleton.names == base.skeleton.names
    assert np.allclose(_fk_world(other), _fk_world(base), atol=1e-12)


@pytest.mark.parametrize(
    "mutate, line, words",
    [
        (lambda t: t.replace("1 2 3 10 20 30 5 6 7 8 9 10 1 2 3", "1 2 3 10 20 30 5 6 7 8 9 10 1 2"), 28, "14 values"),
        (lambda t: t.replace("Frames:\t2", "Frames:\t3"), None, "Frames: 3"),
        (lambda t: t.replace("4 5 6 -10", "4 5 nan -10"), 29, "finite"),
        (lambda t: t.replace("4 5 6 -10", "4 5 x -10"), 29, "not a number"),
        (lambda t: t.replace("CHANNELS 3 Zrotation", "CHANNELS 4 Zrotation"), 9, "CHANNELS says 4"),
        (lambda t: t.replace("Yrotation Xrotation\n", "Yrotation Wrotation\n"), 9, "unknown channel"),
        (lambda t: t.replace("Frame Time: .0083333", "Frame Time: 0"), 27, "positive"),
        (lambda t: t.replace("JOINT Leg", "JOINT Chest"), 15, "duplicate joint name"),
        (lambda t: t.replace("MOTION", "MOTON"), 25, "unexpected"),
    ],
    ids=["short-line", "frames-mismatch", "nan", "non-numeric", "channel-count", "unknown-channel", "frame-time", "duplicate", "no-motion"],
)
def test_errors_name_file_line_and_problem(mutate, line, words):
    with pytest.raises(BvhError) as e:
        bvh.parse(mutate(SMALL), "bad.bvh")
    msg = str(e.value)
    assert msg.startswith("bad.bvh:")
    if line is not None:
        assert e.value.line == line, msg
    assert words in msg


@pytest.mark.parametrize("path", clip_params())
def test_round_trip_every_shared_clip(path, tmp_path):
    if path is None:
        require_data()
    m = bvh.read(path)
    out = tmp_path / "rt.bvh"
    bvh.write(m, out)
    back = bvh.read(out)
    s, b = m.skeleton, back.skeleton
    assert b.names == s.names and np.array_equal(b.parents, s.parents)
    assert b.channels == s.channels
    assert b.scale == s.scale and b.up == s.up
    assert np.allclose(b.offsets, s.offsets, atol=1e-12)
    assert np.allclose(b.end_offsets, s.end_offsets, atol=1e-12)
    assert back.fps == m.fps  # the frame time is written so that it reads back exactly
    # FK of write(read(f)) against the independent FK of f itself.
    _, ref = reference_fk(path.read_text())
    err = np.abs(_fk_world(back) - file_to_world(ref, s.scale)).max()
    assert err < 1e-6 * s.stature(), f"round-trip FK error {err} m"


@pytest.mark.parametrize("seed", range(8))
def test_round_trip_random_skeletons(seed, tmp_path):
    rng = np.random.default_rng(100 + seed)
    skel = random_skeleton(rng, int(rng.integers(1, 30)))
    m = random_motion(rng, skel, int(rng.integers(1, 12)))
    text = bvh.format_motion(m)
    back = bvh.parse(text, "r.bvh", scale=1.0, up="z")
    assert back.skeleton.channels == skel.channels
    err = np.abs(_fk_world(back) - _fk_world(m)).max()
    assert err < 1e-6 * max(skel.height(), 1e-3)
    # Writing again is a fixed point of the text.
    assert bvh.format_motion(back) == text


def test_new_rotations_write_with_original_channel_order(mocap):
    m = bvh.read(mocap / "cmu_cgspeed_daz" / "07_01.bvh")[4:40]
    # An operation: rotate every joint a little more about a random axis.
    extra = rot.exp(np.random.default_rng(0).normal(0, 0.2, m.rotations.shape[:-1] + (3,)))
    changed = m.replace(rotations=rot.multiply(m.rotations, extra))
    text = bvh.format_motion(changed)
    back = bvh.parse(text, "x.bvh")
    assert back.skeleton.channels == m.skeleton.channels  # mixed ZYX root / ZXY joints kept
    assert np.abs(_fk_world(back) - _fk_world(changed)).max() < 1e-6 * m.skeleton.stature()


def test_writer_widens_channels_it_needs():
    # A joint with only a Z rotation channel that is given a rotation about X gets the missing channels.
    text = SMALL.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 1 Zrotation")
    text = text.replace("5 6 7 8 9 10 1 2 3", "5 8 9 10 1 2 3").replace("-5 -6 -7 -8", "-5 -8")
    m = bvh.parse(text, "z.bvh")
    assert m.skeleton.channels[1] == ("Zrotation",)
    assert bvh.format_motion(m).count("CHANNELS 1 Zrotation") == 1  # representable: kept
    tilt = rot.exp(np.array([0.0, 0.3, 0.0]))  # about world y = the file's X axis
    q = m.rotations.copy()
    q[:, 1] = rot.multiply(q[:, 1], tilt)
    changed = m.replace(rotations=q)
    back = bvh.parse(bvh.format_motion(changed), "w.bvh")
    assert back.skeleton.channels[1][0] == "Zrotation" and len(back.skeleton.channels[1]) == 3
    assert np.abs(_fk_world(back) - _fk_world(changed)).max() < 1e-8


def test_refuses_to_write_nan(tmp_path):
    m = bvh.parse(SMALL, "s.bvh")
    q = m.rotations.copy()
    q[1, 1, 0] = np.nan
    with pytest.raises(Exception, match="non-finite"):
        bvh.write(m.replace(rotations=q), tmp_path / "nan.bvh")
    assert not (tmp_path / "nan.bvh").exists()


def test_explicit_scale_and_up_override():
    m = bvh.parse(SMALL, "s.bvh", scale=0.02, up="z")
    assert m.skeleton.scale == 0.02 and m.skeleton.up == "z"
    # Z up: file Y stays world Y.
    assert np.allclose(m.root_positions[0], np.array([1, 92, 3]) * 0.02)
