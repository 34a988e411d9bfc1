"""Quaternion helpers against SciPy and against their own algebra."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mjmotion import rotations as rot


def _random(n, seed=0):
    return rot.normalize(np.random.default_rng(seed).normal(size=(n, 4)))


def test_multiply_and_rotate_agree_with_scipy():
    a, b = _random(50, 1), _random(50, 2)
    v = np.random.default_rng(3).normal(size=(50, 3))
    ab = rot.to_scipy(a) * rot.to_scipy(b)
    assert np.allclose(np.abs(np.sum(rot.multiply(a, b) * rot.from_scipy(ab), -1)), 1.0)
    assert np.allclose(rot.rotate(a, v), rot.to_scipy(a).apply(v))


def test_euler_round_trip_in_every_bvh_order():
    ang = np.random.default_rng(5).uniform(-170, 170, (200, 3))
    ang[:, 1] = np.clip(ang[:, 1], -80, 80)  # away from gimbal lock: angles unique
    for order in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"):
        q = rot.euler_to_quat(ang, order)
        ref = Rotation.from_euler(order, ang, degrees=True)
        assert np.allclose(np.abs(np.sum(q * rot.from_scipy(ref), -1)), 1.0)
        back = rot.quat_to_euler(q, order)
        assert np.allclose(rot.euler_to_quat(back, order) * np.sign(np.sum(q * rot.euler_to_quat(back, order), -1))[:, None], q)


def test_log_exp_inverse_and_continuity():
    q = _random(100, 7)
    assert np.allclose(np.abs(np.sum(rot.exp(rot.log(q)) * q, -1)), 1.0)
    flipped = q.copy()
    flipped[1::2] *= -1
    seq = rot.slerp(q[:1], q[1:2], np.linspace(0, 1, 20)[:, None])[:, 0]
    seq[::3] *= -1
    cont = rot.make_continuous(seq)
    assert np.all(np.sum(cont[1:] * cont[:-1], -1) > 0)


def test_weighted_average_is_sign_invariant_and_geodesic_midpoint():
    a, b = _random(1, 8)[0], _random(1, 9)[0]
    mid = rot.weighted_average(np.stack([a, -b]), np.array([0.5, 0.5]))
    expect = rot.slerp(a, b, 0.5)
    assert np.allclose(abs(np.dot(mid, expect)), 1.0)
    one = rot.weighted_average(np.stack([a, b]), np.array([1.0, 0.0]))
    assert np.allclose(abs(np.dot(one, a)), 1.0)


def test_euler_to_quat_is_the_product_of_axis_quaternions_bit_for_bit():
    """The sparse closed form equals the chain of full Hamilton products it replaced, exactly
    (any number of axes, repeated axes, large angles, ±0)."""
    ang = np.random.default_rng(6).uniform(-720, 720, (300, 3))
    ang[0] = [0.0, -0.0, 180.0]
    for order in ("X", "ZY", "XYZ", "ZXY", "YZX", "XZX", "ZYX"):
        ref = np.tile(rot.IDENTITY, (len(ang), 1))
        for k, axis in enumerate(order):
            half = 0.5 * np.radians(ang[:, k])
            q = np.zeros_like(ref)
            q[:, 0] = np.cos(half)
            q[:, 1 + "XYZ".index(axis)] = np.sin(half)
            ref = rot.multiply(ref, q)
        got = rot.euler_to_quat(ang[:, : len(order)], order)
        assert got.shape == ref.shape and got.flags.c_contiguous
        assert np.array_equal(got, ref), order


def test_to_matrix_agrees_with_scipy_and_normalises():
    r = Rotation.random(2000, rng=5)
    assert np.allclose(rot.to_matrix(rot.from_scipy(r) * 3.0), r.as_matrix(), atol=1e-12)
    q = rot.from_scipy(r).reshape(2, 1000, 4)
    assert rot.to_matrix(q).shape == (2, 1000, 3, 3) and np.allclose(rot.from_matrix(rot.to_matrix(q)), rot.positive_w(q), atol=1e-12)


@pytest.mark.parametrize("shapes", [((50, 7, 3), (50, 7, 3)), ((50, 1, 3), (50, 7, 3)), ((20, 6, 1, 3), (1, 1, 4, 3)), ((3,), (3,))])
def test_cross_is_numpys_bit_for_bit_with_broadcasting(shapes):
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=shapes[0]), rng.normal(size=shapes[1])
    out = rot.cross(a, b)
    assert out.shape == np.broadcast_shapes(a.shape, b.shape) and np.array_equal(out, np.cross(a, b))
    assert np.allclose(np.sum(out * np.broadcast_to(a, out.shape), axis=-1), 0.0)  # perpendicular to its factors


@pytest.mark.parametrize("shape", [(3,), (450, 31, 4), (200, 2, 8, 3), (100, 2), (50, 6), (40, 7), (30, 1), (20, 9), (0, 3)])
def test_norm_is_numpys_bit_for_bit(shape):
    rng = np.random.default_rng(11)
    v = rng.normal(size=shape) * rng.uniform(1e-6, 1e6, size=shape[:-1] + (1,))
    for x in (v, v[..., ::-1], v[..., 1:] if shape[-1] > 1 else v):  # strided views too
        ref = np.linalg.norm(x, axis=-1)
        assert np.array_equal(rot.norm(x), ref)
        assert np.array_equal(rot.norm(x, keepdims=True), np.linalg.norm(x, axis=-1, keepdims=True))
    assert np.array_equal(rot.norm([3.0, 4.0]), 5.0)


@pytest.mark.parametrize("shapes", [((450, 31, 4), (450, 31, 4)), ((100, 4), (4,)), ((60, 3), (60, 3)), ((10, 9), (10, 9)), ((4,), (4,))])
def test_dot_is_numpys_sum_bit_for_bit(shapes):
    rng = np.random.default_rng(12)
    a, b = rng.normal(size=shapes[0]) * 1e3, rng.normal(size=shapes[1])
    assert np.array_equal(rot.dot(a, b), np.sum(a * b, axis=-1))
    assert np.array_equal(rot.dot(a[..., ::-1], b), np.sum(a[..., ::-1] * b, axis=-1))  # a strided view
