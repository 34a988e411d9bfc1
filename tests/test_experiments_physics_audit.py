"""The physics audit's mid-stance footskate: what a foot flat on the floor does while it bears weight."""

from __future__ import annotations

import pytest

from mjmotion import synth
from mjmotion.experiments import corruption
from mjmotion.experiments import physics_audit as pa


def test_mid_stance_skate_is_zero_for_held_feet_and_the_drag_speed_when_dragged():
    """The bundled walk holds its feet on their footprints: ~0 mm/s over the foot-flat middle of
    each stance; dragged at 0.3 m/s along its walking direction, the flat foot slides at 300 mm/s."""
    walk = synth.walk(seconds=3.0).motion
    whole, mid, stances = pa.mid_stance_skate(walk)
    assert stances >= 3 and mid < 1.0 and whole < 1.0, (whole, mid)
    _, dragged, n = pa.mid_stance_skate(corruption.dragged(walk, 0.3))
    assert n >= 3 and dragged == pytest.approx(300.0, abs=5.0)
