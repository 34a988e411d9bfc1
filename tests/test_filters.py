"""Smoothing before differentiating: what passes unbent, what is removed."""

from __future__ import annotations

import numpy as np
import pytest

from mjmotion import filters
from mjmotion import rotations as rot


def test_lowpass_passes_a_parabola_to_the_ends_and_removes_noise():
    fps = 120.0
    t = np.arange(96) / fps
    x = 1.0 + 4.0 * t - 4.905 * t**2
    y = filters.lowpass(x, fps, 6.0)
    acc = np.gradient(np.gradient(y, 1 / fps), 1 / fps)
    assert np.abs(y - x).max() < 1e-5 and np.abs(acc[2:-2] + 9.81).max() < 0.01
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 0.001, (600, 3))
    assert filters.lowpass(noise, fps, 6.0).std() < 0.35 * noise.std()
    assert filters.lowpass(noise, fps, None) is noise and filters.lowpass(noise[:3], fps, 6.0) is not None


def test_velocity_is_exact_for_quadratics_and_keeps_a_start_from_rest_sharp():
    fps = 120.0
    t = np.arange(200) / fps
    x = np.column_stack([3 * t**2 - t, 0.5 * t])
    assert np.allclose(filters.velocity(x, fps, 0.1), np.column_stack([6 * t - 1, np.full_like(t, 0.5)]), atol=1e-9)
    # A foot at rest that starts moving at 2 m/s: 6 frames (half the window) before, the speed is
    # exactly 0; a 6 Hz low-pass reads it moving (backwards, ringing) 14 frames before.
    step = np.where(t > 1.0, 2.0 * (t - 1.0), 0.0)
    v = filters.velocity(step, fps, 0.1)
    k = int(1.0 * fps)
    assert np.abs(v[: k - 5]).max() < 1e-9
    lp = np.gradient(filters.lowpass(step, fps, 6.0), 1 / fps)
    assert np.abs(lp[k - 14 : k - 5]).max() > 0.04
    assert np.allclose(filters.velocity(x[:3], fps, 0.1), np.gradient(x[:3], 1 / fps, axis=0))


def test_lowpass_quaternions_stay_unit_and_ignore_sign_flips():
    rng = np.random.default_rng(3)
    q = rot.exp(np.cumsum(rng.normal(0, 0.01, (200, 2, 3)), axis=0))
    flipped = q * np.where(rng.random((200, 2, 1)) < 0.3, -1.0, 1.0)
    out = filters.lowpass_quaternions(flipped, 120.0, 6.0)
    assert np.allclose(np.linalg.norm(out, axis=-1), 1.0)
    same = np.abs(np.sum(out * filters.lowpass_quaternions(q, 120.0, 6.0), axis=-1))
    assert same.min() == pytest.approx(1.0, abs=1e-9)
