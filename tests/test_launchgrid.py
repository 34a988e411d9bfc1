"""Launch grids: the arm re-aimed at new hit points (an operation, outside the judge)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_data

from mjmotion import bvh, kinematics, mjcf
from mjmotion import launchgrid as lg
from mjmotion.skeleton import Motion


def _clip(rel: str) -> Motion:
    return bvh.read(require_data() / rel)


@pytest.mark.parametrize("wrist", ["locked", "world"])
def test_reach_hit_point_meets_the_target_and_stays_local(wrist):
    m = _clip("cmu_asfamc_converted/64_01.bvh")
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    c = mjcf.compile(m.skeleton, (prop,))
    h = 325
    spot = kinematics.forward(c, m).site(prop.site)
    target = spot[h] + [0.03, -0.06, 0.04]
    out = lg.reach_hit_point(m, prop, h, target, falloff=0.25, wrist=wrist)
    got = kinematics.forward(c, out).site(prop.site)
    assert np.allclose(got[h], target, atol=1e-9)
    far = np.abs(np.arange(m.n_frames) - h) > 0.25 * m.fps + 1
    assert np.allclose(out.rotations[far], m.rotations[far])
    assert np.abs(np.diff(got[h - 40 : h + 40], axis=0) - np.diff(spot[h - 40 : h + 40], axis=0)).max() < 0.01


def test_hit_grid_on_a_golf_swing_is_monotone_for_a_translated_club():
    m = _clip("cmu_asfamc_converted/64_01.bvh")
    prop = mjcf.parse_prop_option(m.skeleton, "club:rwrist")
    offsets = lg.grid_offsets(m, prop, 325, 3, 0.05)[3:6]  # the middle row: lateral only
    p = lg.hit_grid(m, prop, 325, offsets, wrist="world")
    assert all(ln.contacted for ln in p.launches)
    assert abs(p.rho_azimuth) == pytest.approx(1.0)
