"""PCA space and style error (seed 003 §2.5.4–2.5.5, §3.2.1; docs/METRICS.md "Style")."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import random_motion, random_skeleton

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError, SkeletonMismatchError
from mjmotion.style import PoseSpace, pose_parameters, reconstruction_errors, style_rmse


@pytest.fixture(scope="module")
def swing():
    from conftest import require_data

    return bvh.read(require_data() / "cmu_asfamc_converted" / "64_01.bvh")[::2]


def _fk(m):
    return kinematics.forward(mjcf.compile(m.skeleton), m).joint_positions


def test_all_components_reconstruct_the_source_exactly(swing):
    space = PoseSpace.fit(swing)
    rec = space.reconstruct(swing)
    assert np.max(np.abs(_fk(rec) - _fk(swing))) < 1e-6
    # zero-deviation parameters (CMU's hip joints never rotate) are dropped, not standardised
    assert space.kept.sum() < pose_parameters(swing).shape[1]
    assert space.loadings.shape == (space.kept.sum(), space.n_components)


def test_random_skeleton_with_inner_translations_round_trips():
    rng = np.random.default_rng(3)
    skel = random_skeleton(rng, 9)
    m = random_motion(rng, skel, 40)
    space = PoseSpace.fit(m, translations=True)
    rec = space.reconstruct(m)
    assert np.max(np.abs(_fk(rec) - _fk(m))) < 1e-6


def test_reconstruction_error_falls_as_k_grows(swing):
    errs = reconstruction_errors(swing, [1, 2, 3, 5, 10, 20])
    values = list(errs.values())
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(values)), errs
    assert values[0] > 0.05 and values[-1] < 0.02  # metres: 1 component is a caricature, 20 are close


def test_scores_agree_with_an_eigendecomposition_of_the_correlation_matrix(swing):
    space = PoseSpace.fit(swing)
    x = pose_parameters(swing)
    sd = x.std(axis=0, ddof=1)
    keep = sd > 1e-9
    z = (x[:, keep] - x[:, keep].mean(0)) / sd[keep]
    vals, vecs = np.linalg.eigh(np.corrcoef(z, rowvar=False))
    order = np.argsort(vals)[::-1]
    vals, vecs = vals[order], vecs[:, order]
    n = min(10, space.n_components)
    np.testing.assert_allclose(space.variances[:n], vals[:n], rtol=1e-8)
    ref = z @ vecs[:, :n]
    got = space.source_scores[:, :n]
    signs = np.sign(np.sum(ref * got, axis=0))
    np.testing.assert_allclose(got, ref * signs, atol=1e-6)
    # k: the smallest number of components explaining ≥ 70 %
    frac = np.cumsum(vals) / vals.sum()
    assert space.components_for(0.7) == int(np.argmax(frac >= 0.7)) + 1


def test_pose_from_scores_is_the_seed_formula(swing):
    space = PoseSpace.fit(swing)
    s = np.array([[1.5, -0.7, 0.2]])
    p = space.parameters_of_scores(s)[0]
    lk = space.loadings[:, :3]
    expect = space.means.copy()
    expect[space.kept] = (lk @ s[0]) * space.deviations[space.kept] + space.means[space.kept]
    np.testing.assert_allclose(p, expect, atol=1e-12)
    m = space.motion(s)
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-12)


def test_style_rmse_known_answer_for_a_root_shift(swing):
    # every frame shifted by c: the standardised difference is c/D on the root parameters, so the
    # rmse is the length of its projection onto the top-k loadings, the same at every frame
    c = np.array([0.05, -0.03, 0.02])
    shifted = swing.replace(root_positions=swing.root_positions + c)
    rmse, k = style_rmse(swing, shifted)
    space = PoseSpace.fit(swing)
    assert k == space.components_for(0.7)
    d = np.zeros(space.means.size)
    d[:3] = c
    expect = np.linalg.norm(space.loadings[:, :k].T @ (d[space.kept] / space.deviations[space.kept]))
    assert rmse == pytest.approx(expect, rel=1e-9)
    assert rmse > 0.01


def test_style_rmse_is_zero_for_the_source_and_blind_to_quaternion_signs(swing):
    assert style_rmse(swing, swing) == (0.0, PoseSpace.fit(swing).components_for(0.7))
    rng = np.random.default_rng(0)
    flips = rng.choice([-1.0, 1.0], size=swing.rotations.shape[:2])
    flipped = swing.replace(rotations=swing.rotations * flips[..., None])
    assert style_rmse(swing, flipped)[0] < 1e-9


def test_style_rmse_grows_with_the_size_of_a_change(swing):
    space = PoseSpace.fit(swing)
    small = space.motion(space.source_scores * 1.1)
    big = space.motion(space.source_scores * 1.3)
    assert style_rmse(swing, small)[0] < style_rmse(swing, big)[0]


def test_style_rmse_variance_changes_k(swing):
    _, k70 = style_rmse(swing, swing, 0.7)
    _, k95 = style_rmse(swing, swing, 0.95)
    assert k95 > k70 >= 1


def test_bad_inputs_are_clear_errors(swing):
    with pytest.raises(MjmotionError, match="one to one"):
        style_rmse(swing, swing[:10])
    with pytest.raises(MjmotionError, match="variance"):
        style_rmse(swing, swing, 1.5)
    rng = np.random.default_rng(1)
    other = random_motion(rng, random_skeleton(rng, 5), swing.n_frames)
    with pytest.raises(SkeletonMismatchError):
        style_rmse(swing, other)
    still = swing[:1]
    with pytest.raises(MjmotionError, match="at least 2 frames"):
        PoseSpace.fit(still)
    const = swing[:5].replace(
        root_positions=np.zeros((5, 3)),
        rotations=np.broadcast_to(rot.IDENTITY, swing[:5].rotations.shape).copy(),
    )
    with pytest.raises(MjmotionError, match="constant"):
        PoseSpace.fit(const)


def test_rotation_flips_finds_a_branch_jump(swing):
    from mjmotion.style import rotation_flips

    before = set(rotation_flips(swing))
    assert all(name == "lthumb" for _, name in before)  # 64_01's raw thumb glitch near frame 160 only
    q = swing.rotations.copy()
    j = swing.skeleton.index("rradius")
    q[50:, j] = rot.multiply(q[50:, j], rot.exp(np.array([np.pi * 0.95, 0.0, 0.0])))  # a 171° turn from frame 50 on
    after = set(rotation_flips(swing.replace(rotations=q)))
    assert after - before == {(50, "rradius")}
