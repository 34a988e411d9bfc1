"""The floor: detected from stance, robust to flight and a T-pose; given > source > detected."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_clip

from mjmotion import floor as floors
from mjmotion import render
from mjmotion.errors import MjmotionError


def test_detect_takes_the_still_lower_foot_and_ignores_flight_and_a_t_pose():
    t = 300
    rng = np.random.default_rng(0)
    z = np.full((t, 2), 0.3)
    speed = np.full((t, 2), 2.0)
    stance = np.arange(t) % 100 < 40  # 40 % stance on the left foot, the rest flight
    z[stance, 0] = 0.031 + rng.normal(0, 0.002, stance.sum())
    speed[stance, 0] = 0.05
    z[:3] = 0.25  # a T-pose standing still on a higher "floor" for three frames
    speed[:3] = 0.0
    assert floors.detect(z, speed) == pytest.approx(0.031, abs=0.002)
    # Nothing still: the 5th percentile of the lower foot.
    assert floors.detect(np.full((50, 2), 0.1), np.full((50, 2), 3.0)) == pytest.approx(0.1)
    with pytest.raises(MjmotionError, match="same"):
        floors.detect(z, speed[:10])


def test_resolve_precedence_and_the_note():
    assert floors.resolve(0.1, [0.2, 0.4], 0.5) == floors.Floor(0.1, "given")
    src = floors.resolve(None, [0.2, 0.4], 0.5)
    assert src.from_ == "source" and src.height == pytest.approx(0.3)
    assert floors.resolve(None, [], 0.5).from_ == "detected"
    assert floors.Floor(0.005, "detected").note() is None and floors.Floor(0.05, "given").note() is None
    note = floors.Floor(-0.034, "detected").note("64_04")
    assert note.startswith("note: 64_04: detected floor -0.034 m (3.4 cm below z = 0)")
    with pytest.raises(MjmotionError):
        floors.Floor(float("nan"), "given")
    with pytest.raises(MjmotionError):
        floors.Floor(0.0, "guessed")


def test_fit_tilt_recovers_a_walks_slope_and_levels_it():
    """A straight walk over a floor rising 2 cm per metre along x: the tilt is found along the walk,
    not across it (where the feet's own height difference would read as slope), and the Level maps
    the stance points onto one level plane."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-2.0, 2.0, 400)
    y = np.where(rng.random(400) < 0.5, 0.1, -0.1)  # two feet, 20 cm apart
    z = 0.03 + 0.02 * x + np.where(y > 0, 0.012, 0.0) + rng.normal(0, 0.002, 400)  # the left foot 12 mm higher
    lv = floors.fit_tilt(np.column_stack([x, y]), z)
    assert lv.tilt_deg == pytest.approx(np.degrees(np.arctan(0.02)), abs=0.02)
    assert lv.rise == pytest.approx((0.02, 0.0), abs=1e-3)  # the 12 mm between the feet is no cross slope
    levelled = lv.positions(np.column_stack([x, y, z - np.where(y > 0, 0.012, 0.0)]))
    assert np.std(levelled[:, 2]) < 0.003 and np.std(z) > 0.02
    back = lv.inverse().positions(levelled)
    assert np.allclose(back, np.column_stack([x, y, z - np.where(y > 0, 0.012, 0.0)]), atol=1e-12)
    # Within the scatter, beyond belief, or too few points: the floor stays as captured.
    assert floors.fit_tilt(np.column_stack([x, y]), 0.03 + 0.005 * x).flat
    assert floors.fit_tilt(np.column_stack([x, y]), 0.03 + 0.1 * x).flat
    assert floors.fit_tilt(np.column_stack([x, y])[:10], z[:10]).flat
    assert floors.fit_tilt(np.column_stack([0.1 * x, y]), z).flat  # 12 cm of walk: no direction to fit along
    note = floors.Floor(0.031, "detected", lv).note("07_01")
    assert f"tilts {lv.tilt_deg:.1f}°" in note and "+2.0 cm/m along x" in note


def test_render_draws_the_clip_on_its_floor():
    """``render.build_scene(floor=...)`` moves every character so the given floor is the drawn one."""
    m = shared_clip("cmu_asfamc_converted/64_04.bvh")[:60]
    base = render.build_scene([render.Actor(m)], fps=30)
    moved = render.build_scene([render.Actor(m)], fps=30, floor=-0.05)
    assert np.allclose(moved.qpos[:, 2] - base.qpos[:, 2], 0.05)
    detected = render.build_scene([render.Actor(m)], fps=30, floor=None)
    from mjmotion.feet import foot_heights_speeds

    assert np.allclose(base.qpos[:, 2] - detected.qpos[:, 2], foot_heights_speeds(None, m).floor)
    with pytest.raises(MjmotionError, match="floor"):
        render.build_scene([render.Actor(m)], fps=30, floor=float("inf"))
