"""The bundled humanoid is recognised wherever it comes from, and the judge stands it on the soles it was made with."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import shared_clip

from mjmotion import bvh, evaluate, feet, humanoid, kinematics, mjcf, synth
from mjmotion.skeleton import Motion


def _scaled(m: Motion, s: float) -> Motion:
    skel = dataclasses.replace(m.skeleton, offsets=m.skeleton.offsets * s, end_offsets=m.skeleton.end_offsets * s)
    return Motion(skel, m.fps, m.root_positions * s, m.rotations, name=f"{m.name}_x{s:g}")


def test_the_bundled_skeleton_is_recognised_read_back_and_rescaled(tmp_path):
    walk = synth.walk(seconds=1.0).motion
    bvh.write(walk, tmp_path / "walk.bvh")  # centimetres, Y up, the file's decimals
    back = bvh.read(tmp_path / "walk.bvh")
    assert humanoid.bundled_scale(back.skeleton) == pytest.approx(1.0, abs=1e-6)
    assert humanoid.bundled_scale(_scaled(back, 1.1).skeleton) == pytest.approx(1.1, abs=1e-6)


def test_other_skeletons_are_not_the_bundled_one():
    ref = humanoid.skeleton()
    longer = ref.offsets.copy()
    longer[ref.index("LeftLeg")] *= 1.02  # one thigh 9 mm longer: another body
    assert humanoid.bundled_scale(dataclasses.replace(ref, offsets=longer)) is None
    renamed = dataclasses.replace(ref, names=("Pelvis", *ref.names[1:]))
    assert humanoid.bundled_scale(renamed) is None
    for rel in ("cmu_cgspeed_daz/07_01.bvh", "cmu_asfamc_converted/16_15.bvh", "cmu_iclone_ccrig/002_01.bvh", "cmu_cgspeed_max/131_01.bvh"):
        assert humanoid.bundled_scale(shared_clip(rel).skeleton) is None


def test_the_designed_sole_is_where_mujoco_finds_the_compiled_feet():
    """humanoid.sole_depth is what synth.foot_geometry measures through MuJoCo on the compiled model
    (the lowest point of the foot and toe geoms below the ankle): the feet the gaits are planned on."""
    assert humanoid.sole_depth(1.0) == pytest.approx(synth.foot_geometry().ankle_height, abs=1e-9)


@pytest.mark.parametrize("scale", [1.0, 1.1])
def test_the_judge_finds_a_bundled_walk_on_the_floor_it_was_made_on(scale):
    """A bundled walk stands on z = 0 by construction: the judge detects its floor there (within 1 mm)
    and, told the floor is z = 0, finds no penetration and no floating. With the proportions of the
    captured rigs (a sole 0.048 x stature under the ankle, 9.1 cm; this body's ankle is 6.8 cm up)
    it read a floor 23 mm down and, on z = 0, 23 mm of penetration."""
    m = _scaled(synth.walk(seconds=3.0).motion, scale)
    detected = evaluate.evaluate(m)
    assert detected.floor_from == "detected" and abs(detected.floor_m) < 1e-3, detected.floor_m
    on_zero = evaluate.evaluate(m, floor=0.0)
    assert on_zero.penetrate_mm < 0.5 and on_zero.float_mm < 0.5, (on_zero.penetrate_mm, on_zero.float_mm)
    # The soles: flat feet's lowest points on z = 0 wherever the walk's ground truth plants them.
    c = mjcf.compile(m.skeleton)
    pose = kinematics.forward(c, m)
    soles = feet.calibrate_soles(m.skeleton, [(pose, m.fps)])
    depth = -(soles.local[:, :4] @ soles.normals[0])
    assert np.allclose(depth, humanoid.sole_depth(scale), atol=2e-3)
