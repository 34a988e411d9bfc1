"""The Studio's skinned character without a browser: what the skin modes upload to viser is
:mod:`mjmotion.skin`'s deformation of the pose the capsules are drawn from."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

from mjmotion import kinematics, mjcf, skin, synth
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError
from mjmotion.studio.scene import CONTACT_RGB, Kinematics
from mjmotion.studio.skinned import BothDrawing, FrameSkinner, SkinDrawing


@pytest.fixture(scope="module")
def scene():
    import viser

    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server.scene
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


@pytest.fixture(scope="module")
def drive():
    clip = synth.drive()
    compiled = mjcf.compile(clip.motion.skeleton, (clip.prop,))
    return clip, compiled, kinematics.qpos(compiled, clip.motion)


def _uploaded(drawing: SkinDrawing) -> np.ndarray:
    """``(V, 3)`` the vertices the mesh handles hold (what viser sends), reassembled from the parts."""
    out = np.full((drawing.skin.n_vertices, 3), np.nan)
    for handle, vids in drawing._parts.values():
        out[vids] = handle.vertices
    return out


@pytest.mark.parametrize("method", ["lbs", "dqs"])
def test_skin_mode_uploads_the_skin_of_the_pose_the_capsules_use(scene, drive, method):
    clip, compiled, q = drive
    d = SkinDrawing(scene, f"/t/{method}", compiled, (77, 140, 217), clip.motion, method)
    try:
        kin = Kinematics(compiled)
        frames = [0, clip.hit_frame, clip.motion.n_frames - 1]
        # the reference: mjmotion.skin over the clip's frames, from its own batch FK
        ref, _ = skin.deformed(d.skin, compiled, clip.motion[frames[0] : frames[-1] + 1], method, normals=False)
        for f in frames:
            d.update(kin.pose(q[f]))
            np.testing.assert_allclose(d.vertices, ref[f - frames[0]], rtol=0, atol=1e-9)
            np.testing.assert_allclose(_uploaded(d), ref[f - frames[0]], rtol=0, atol=1e-6)  # float32 on the wire
        # the parts are the skin's faces, each once, on the shared vertices (closed seams)
        faces = np.concatenate([vids[np.asarray(h.faces)] for h, vids in d._parts.values()])
        assert sorted(map(tuple, np.sort(faces, axis=1))) == sorted(map(tuple, np.sort(d.skin.faces, axis=1)))
        # the bat is drawn (as a primitive) where the capsule figure has it
        assert 19 in d._props._layout.cylinders and not np.isin(d._props._layout.cylinders, compiled.body_geom_ids).any()
    finally:
        d.remove()


def test_dqs_keeps_a_twisted_forearm_that_lbs_collapses(drive):
    """The two methods differ where they should: a 180° forearm twist (seed 000 Fig. 5) shrinks the
    LBS wrist towards the bone while DQS keeps its radius."""
    clip, compiled, q = drive
    s = skin.build(compiled, reference=clip.motion)
    kin = Kinematics(compiled)
    pose = kin.pose(skin.bind_qpos(compiled, s.bind_pose))
    bones = np.asarray(compiled.body_ids)[s.joints]
    pos, quat = pose.body_pos[bones].copy(), pose.body_quat[bones].copy()
    names = list(s.bodies)
    fore, hand = names.index("LeftForeArm"), names.index("LeftHand")
    axis = pos[hand] - pos[fore]
    axis /= np.linalg.norm(axis)
    quat[hand] = rot.multiply(np.r_[0.0, axis], quat[hand])  # 180° about the forearm
    near = np.flatnonzero(np.isin(s.weights.bones[:, :2], [fore, hand]).all(axis=1) & (np.abs(s.weights.values[:, 0] - 0.5) < 0.15))
    assert len(near) > 10

    def radius(v: np.ndarray) -> float:
        rel = v[near] - pos[hand]
        return float(np.median(np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)))

    rest = radius(s.vertices)
    lbs, dqs = (radius(FrameSkinner(s, m)(pos, quat)) for m in ("lbs", "dqs"))
    assert lbs < 0.5 * rest and dqs > 0.8 * rest


def test_a_foot_in_contact_is_coloured_on_the_skin(scene, drive):
    clip, compiled, _ = drive
    d = BothDrawing(scene, "/t/both", compiled, (77, 140, 217), clip.motion)
    try:
        left = compiled.foot_geoms["left"]
        d.set_geom_colors({int(left[0]): CONTACT_RGB})
        colors = {part: tuple(h.color) for part, (h, _) in d.skin._parts.items()}
        assert colors == {"body": (77, 140, 217), "left": CONTACT_RGB, "right": (77, 140, 217)}
        assert d.skin._parts["body"][0].opacity == pytest.approx(0.45)  # over the capsules
        d.set_geom_colors({})
        assert tuple(d.skin._parts["left"][0].color) == (77, 140, 217)
    finally:
        d.remove()


def test_unknown_method_is_refused(drive):
    clip, compiled, _ = drive
    with pytest.raises(MjmotionError, match="'lbs', 'dqs'|lbs, dqs"):
        FrameSkinner(skin.build(compiled, reference=clip.motion), "cubic")
