"""The skinned character: the bind pose, the mesh, the weights, LBS against MuJoCo's own skin, DQS
against a per-vertex reference, the skin in compiled models and renders, and bad skeletons."""

from __future__ import annotations

from functools import cache

import mujoco
import numpy as np
import pytest
from conftest import require_data
from scipy.spatial.transform import Rotation

from mjmotion import bvh, kinematics, mjcf, skin, synth
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.errors import MjmotionError
from mjmotion.skeleton import Motion, Skeleton
from mjmotion.skin import bind, deform, weights

#: One clip of every shared skeleton flavour (and where its capture starts), plus the bundled humanoid.
FLAVOURS = {
    "asf": ("cmu_asfamc_converted/16_15", 2),
    "daz": ("cmu_cgspeed_daz/07_01", 4),
    "max": ("cmu_cgspeed_max/131_01", 0),
    "iclone": ("cmu_iclone_ccrig/002_01", 1),
    "bundled": (None, 0),
}


@cache
def character(name: str) -> tuple[Motion, mjcf.CompiledModel, skin.Skin]:
    rel, start = FLAVOURS[name]
    motion = synth.walk().motion if rel is None else bvh.read(require_data() / f"{rel}.bvh")[start:]
    compiled = mjcf.compile(motion.skeleton)
    return motion, compiled, skin.build(compiled, reference=motion)


def _edges_closed(faces: np.ndarray) -> bool:
    """Every directed edge once and its reverse once: closed and consistently wound."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    keys = directed[:, 0].astype(np.int64) * (faces.max() + 1) + directed[:, 1]
    rev = directed[:, 1].astype(np.int64) * (faces.max() + 1) + directed[:, 0]
    return len(np.unique(keys)) == len(keys) and bool(np.all(np.isin(rev, keys)))


@pytest.mark.parametrize("name", list(FLAVOURS))
def test_bind_pose_is_a_standing_t_pose(name):
    motion, compiled, s = character(name)
    skel = motion.skeleton
    pos, _ = bind.world_pose(skel, s.bind_pose)
    hands, feet = skel.hands(), skel.feet()
    stature = skel.stature()
    left, right = pos[hands["left"]], pos[hands["right"]]
    shoulders = [pos[int(skel.parents[int(skel.parents[hands[side]])])] for side in ("left", "right")]
    # Arms out sideways at shoulder height, left on +y; feet below everything, head above.
    assert left[1] - right[1] > 0.6 * stature
    assert abs(left[2] - shoulders[0][2]) < 0.05 and abs(right[2] - shoulders[1][2]) < 0.05
    assert abs(left[0] - right[0]) < 0.05
    ankles = [pos[feet[side][0]][2] for side in ("left", "right")]
    assert max(ankles) < pos[list(bind._hips(skel))][:, 2].min() - 0.25 * stature
    assert pos[bind._head(skel)][2] > max(left[2], right[2])


@pytest.mark.parametrize("name", list(FLAVOURS))
def test_compile_skin_writes_a_model_mujoco_loads_with_one_to_four_weights_summing_to_one(name, tmp_path, capsys):
    motion, _, _ = character(name)
    rel, _ = FLAVOURS[name]
    src = tmp_path / "clip.bvh"
    if rel is None:
        bvh.write(motion, src)
    else:
        src = require_data() / f"{rel}.bvh"
    out = tmp_path / "model.xml"
    assert main(["compile", str(src), "-o", str(out), "--skin"]) == 0
    assert "a skin of" in capsys.readouterr().out
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nskin == 1 and 3000 <= m.nskinvert <= 20000
    counts = np.bincount(m.skin_bonevertid, minlength=m.nskinvert)
    sums = np.bincount(m.skin_bonevertid, weights=m.skin_bonevertweight, minlength=m.nskinvert)
    assert counts.min() >= 1 and counts.max() <= 4
    assert np.abs(sums - 1.0).max() < 1e-6
    assert _edges_closed(m.skin_face.reshape(-1, 3))
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "first_frame") == 0


def test_skin_in_the_file_is_the_skin_in_memory(tmp_path):
    _, compiled, s = character("bundled")
    c = skin.attach(compiled, s)
    path = tmp_path / "m.xml"
    c.save_xml(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert np.array_equal(m.skin_vert, c.model.skin_vert)
    assert np.array_equal(m.skin_bonebindpos, c.model.skin_bonebindpos)
    assert np.array_equal(m.skin_bonevertweight, c.model.skin_bonevertweight)
    assert np.abs(m.skin_vert.reshape(-1, 3) - s.vertices).max() < 1e-6


def test_lbs_matches_mujocos_skin_deformation_on_a_real_clip():
    motion, compiled, s = character("asf")
    clip = motion[::12][:40]
    c = skin.attach(compiled, s)
    ours, _ = skin.deformed(s, c, clip, "lbs", normals=False)
    m = c.model
    d = mujoco.MjData(m)
    scn = mujoco.MjvScene(m, maxgeom=m.ngeom + 10)
    opt, cam = mujoco.MjvOption(), mujoco.MjvCamera()
    worst = 0.0
    for i, q in enumerate(kinematics.qpos(c, clip)):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mjv_updateScene(m, d, opt, None, cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
        theirs = np.asarray(scn.skinvert).reshape(-1, 3)[: s.n_vertices]
        worst = max(worst, float(np.abs(theirs - ours[i]).max()))
    moved = np.abs(ours - s.vertices).max()
    assert moved > 0.5 and worst < 1e-6  # MuJoCo blends in float32: ~4e-7 m at walking distances


def test_weights_are_local_normalised_and_smoothed():
    _, compiled, s = character("bundled")
    geoms = mjcf.character_geoms(compiled.model, int(compiled.body_ids[0]))
    shapes, _ = skin.mesh.shapes_at(compiled.model, skin.bind_qpos(compiled, s.bind_pose), geoms)
    dist = shapes.body_distances(s.vertices)
    excess = dist - dist.min(axis=1, keepdims=True)
    falloff = skin.Settings().falloff * np.clip(compiled.skeleton.stature(), 0.3, 3.0) / 1.75
    dense = s.weights.dense(len(s.joints))
    assert np.all(dense[excess >= 1.5 * falloff] == 0)  # the distance bound
    assert np.allclose(dense.sum(axis=1), 1.0) and s.weights.counts.min() >= 1 and s.weights.counts.max() <= 4
    rough = weights.from_distances(dist, s.faces, falloff, smoothing=0).dense(len(s.joints))
    edges = np.concatenate([s.faces[:, [0, 1]], s.faces[:, [1, 2]], s.faces[:, [2, 0]]])

    def jump(w):
        return np.abs(w[edges[:, 0]] - w[edges[:, 1]]).sum(axis=1)

    assert np.percentile(jump(dense), 99) < np.percentile(jump(rough), 99)


def test_lbs_normals_are_the_inverse_transpose_of_the_blended_matrix():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(40, 3))
    n = rot.normalize(rng.normal(size=(40, 4)))[:, 1:]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    w = rng.random((40, 3))
    w /= w.sum(axis=1, keepdims=True)
    q = rot.normalize(rng.normal(size=(5, 3, 4)))
    t = rng.normal(size=(5, 3, 3))
    pos, nrm = deform.lbs(v, w, q, t, n)
    r = rot.to_matrix(q)
    for f in range(5):
        for i in range(40):
            a = np.einsum("b,bij->ij", w[i], r[f])
            expect_v = a @ v[i] + w[i] @ t[f]
            expect_n = np.linalg.inv(a).T @ n[i]
            assert np.allclose(pos[f, i], expect_v, atol=1e-12)
            assert np.allclose(nrm[f, i], expect_n / np.linalg.norm(expect_n), atol=1e-9)


def _dqs_reference(v: np.ndarray, bones: np.ndarray, values: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Kavan et al.'s DQS one vertex at a time, with SciPy rotations (an independent implementation)."""
    out = np.empty_like(v)
    for i in range(len(v)):
        real = np.zeros(4)
        dual = np.zeros(4)
        main_q = q[bones[i, 0]]
        for b, w in zip(bones[i], values[i]):
            if b < 0 or w == 0:
                continue
            qb = q[b] if np.dot(q[b], main_q) >= 0 else -q[b]
            real += w * qb
            dual += w * 0.5 * rot.multiply(np.array([0.0, *t[b]]), qb)
        norm = np.linalg.norm(real)
        real, dual = real / norm, dual / norm
        trans = 2.0 * rot.multiply(dual, rot.conjugate(real))[1:]
        out[i] = Rotation.from_quat(real[[1, 2, 3, 0]]).apply(v[i]) + trans
    return out


def test_dqs_matches_a_per_vertex_reference_on_a_real_pose():
    motion, compiled, s = character("max")
    pose = kinematics.forward(compiled, motion[300:302])
    q, t = deform.bone_transforms(pose.joint_positions[:, s.joints], pose.joint_rotations[:, s.joints], s.bind_positions, s.bind_rotations)
    # Flip some bones into the other hemisphere: DQS must not care.
    q = q * np.where(np.arange(q.shape[1]) % 3 == 0, -1.0, 1.0)[None, :, None]
    ours, _ = deform.dqs(s.vertices, s.weights.bones, s.weights.values, q, t, None, s.parents)
    pick = np.random.default_rng(0).choice(s.n_vertices, 300, replace=False)
    ref = _dqs_reference(s.vertices[pick], s.weights.bones[pick], s.weights.values[pick], q[1], t[1])
    assert np.abs(ours[1, pick] - ref).max() < 1e-12
    one = s.weights.counts == 1
    lbs, _ = deform.lbs(s.vertices, s.weights.dense(len(s.joints)), q, t)
    assert np.abs(lbs[:, one] - ours[:, one]).max() < 1e-12  # a single bone: both are that bone's motion


def test_dqs_blends_a_half_twist_into_a_rigid_quarter_turn():
    # Two bones on the x axis, a vertex weighted half and half at radius r: LBS pulls it to the axis
    # at a 180° twist (the candy-wrapper), DQS turns it by 90° at radius r.
    v = np.array([[0.0, 0.05, 0.0]])
    bones, values = np.array([[0, 1, -1, -1]]), np.array([[0.5, 0.5, 0.0, 0.0]])
    q = np.array([[rot.IDENTITY, rot.exp(np.array([np.pi, 0.0, 0.0]))]])
    t = np.zeros((1, 2, 3))
    dq, _ = deform.dqs(v, bones, values, q, t)
    lb, _ = deform.lbs(v, np.array([[0.5, 0.5]]), q, t)
    assert np.allclose(dq[0, 0], [0.0, 0.0, 0.05], atol=1e-12)  # y turned a quarter about x
    assert np.linalg.norm(lb[0, 0]) < 1e-12


def test_dqs_keeps_the_elbow_at_a_180_degree_twist_where_lbs_collapses():
    from mjmotion.experiments import skinning

    arm = skinning.left_arm(synth.walk().motion)
    kept = {}
    for method in ("lbs", "dqs"):
        a0, v0 = skinning.measures(arm, "twist", 0.0, method)
        a1, v1 = skinning.measures(arm, "twist", 180.0, method)
        kept[method] = (a1 / a0, v1 / v0)
    assert kept["dqs"][0] >= 0.9 and kept["dqs"][1] >= 0.9
    assert kept["lbs"][0] < 0.3 and kept["lbs"][1] < 0.6


def test_animate_gives_a_viewer_faces_bind_vertices_and_frames():
    motion, compiled, s = character("bundled")
    clip = motion[:12]
    a = skin.animate(clip)
    assert a.vertices.shape == (12, s.n_vertices, 3) and a.normals is not None and a.normals.shape == a.vertices.shape
    assert np.array_equal(a.faces, s.faces) and np.array_equal(a.bind_vertices, s.vertices)
    expect, _ = skin.deformed(s, compiled, clip, "lbs", normals=False)
    assert np.array_equal(a.vertices, expect)


@pytest.fixture(scope="module")
def gl():
    from mjmotion import render

    try:
        render.open_gl_context(16, 16).free()
    except MjmotionError as e:
        pytest.skip(f"no offscreen OpenGL: {e}")
    return render


def _green(img: np.ndarray) -> np.ndarray:
    img = img.astype(int)
    return (img[..., 1] > img[..., 0] + 60) & (img[..., 1] > img[..., 2] + 60)


@pytest.mark.parametrize("name", list(FLAVOURS))
def test_rendered_skin_covers_the_capsule_figure(gl, name):
    motion, _, _ = character(name)
    clip = motion[40:42]
    masks = []
    for skinned in (False, True):
        scene = gl.build_scene([gl.Actor(clip, color=(0.1, 0.9, 0.1), skin=skinned)], fps=30, view=gl.View(azimuth=120.0))
        with gl.Renderer(scene, 320, 320, labels=False, shadows=False, reflections=False) as r:
            masks.append(_green(r.frame(0)))
    capsules, skinned = masks
    assert capsules.sum() > 2000
    assert (capsules & skinned).sum() / capsules.sum() >= 0.98


def test_render_cli_draws_skin_alone_and_beside_the_capsules(gl, tmp_path, capsys):
    src = tmp_path / "walk.bvh"
    bvh.write(synth.walk().motion[:20], src)
    for mode, n in ((["--skin"], 1), (["--skin", "both"], 2)):
        out = tmp_path / f"{len(mode)}.gif"
        assert main(["render", str(src), *mode, "--fast", "--width", "160", "--height", "96", "-o", str(out)]) == 0
        assert out.stat().st_size > 0 and f"{n} character(s)" in capsys.readouterr().out


def _bvh(path, body: str) -> None:
    path.write_text(
        "HIERARCHY\nROOT hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
        + body
        + "}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n"
        + "\n".join(" ".join(["0"] * (6 + 3 * body.count("JOINT"))) for _ in range(2))
        + "\n"
    )


@pytest.mark.parametrize(
    "body, expect",
    [
        ("  End Site\n  {\n    OFFSET 0 0 0\n  }\n", "no bone"),
        (
            "  JOINT a\n  {\n    OFFSET 0 0 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 0 0\n    }\n  }\n",
            "shorter than 1 cm",
        ),
    ],
    ids=["single-joint", "zero-length-bones"],
)
def test_a_skeleton_with_nothing_to_mesh_is_one_error_naming_the_file(tmp_path, capsys, body, expect):
    src = tmp_path / "bad.bvh"
    _bvh(src, body)
    assert main(["compile", str(src), "-o", str(tmp_path / "x.xml"), "--skin", "--units", "m"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and str(src) in err[0] and expect in err[0]
    assert not (tmp_path / "x.xml").exists()


def test_a_character_too_small_to_mesh_is_refused():
    skel = synth.skeleton()
    tiny = Skeleton(skel.names, skel.parents, skel.offsets * 0.05, skel.channels, skel.end_parents, skel.end_offsets * 0.05, 1.0, "z")
    with pytest.raises(MjmotionError, match="too small for a skin"):
        skin.build(mjcf.compile(tiny))


def test_settings_that_make_no_surface_are_refused_by_name():
    """A voxel of 0 or NaN, a negative margin and a NaN blend were "negative dimensions", a 10 m voxel a
    scikit-image error, influences of 0 or 9 a bare ValueError."""
    nan = float("nan")
    for kwargs, message in (
        (dict(voxel=0.0), "voxel=0.0: expected metres from 0.002 to 0.2"),
        (dict(voxel=nan), "voxel=nan"),
        (dict(voxel=10.0), "voxel=10.0"),
        (dict(margin=-1.0), "margin=-1.0"),
        (dict(blend=nan), "blend=nan"),
        (dict(influences=0), "influences=0: expected a whole number from 1 to 4"),
        (dict(influences=9), "influences=9"),
        (dict(smoothing=2.5), "smoothing=2.5"),
    ):
        with pytest.raises(MjmotionError, match=f"skin.Settings {message}"):
            skin.Settings(**kwargs)
