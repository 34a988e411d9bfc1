"""The judge against known corruptions of clean captured clips, judged with the clean clip as
source (issue 13's "Done when"), and the corruption benchmark's pieces."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_data

from mjmotion import evaluate as ev
from mjmotion.experiments import corruption as C
from mjmotion.limits import joint_classes

#: One clean walk per flavour, and iClone's 007_04: CMU subject 07's floor tilts 1.0-1.1° in both
#: conversions, so measured from a flat floor these two read +35 mm lifted 5 cm (levelled: +43).
WALKS = [
    "cmu_asfamc_converted/16_15.bvh",
    "cmu_cgspeed_daz/07_01.bvh",
    "cmu_iclone_ccrig/002_01.bvh",
    "cmu_iclone_ccrig/007_04.bvh",
    "cmu_cgspeed_max/131_02.bvh",
]


@pytest.fixture(scope="module", params=WALKS, ids=[w.split("/")[0] for w in WALKS])
def judged(request):
    clean = C._clip(require_data() / request.param)
    base = ev.evaluate(clean, sources=[clean.replace()])
    return request.param, clean, base


def test_lifted_and_sunk_against_the_source_float_and_penetrate(judged):
    rel, clean, base = judged
    up = ev.evaluate(C.lifted(clean), sources=[clean])
    down = ev.evaluate(C.sunk(clean), sources=[clean])
    assert up.float_mm >= base.float_mm + 40 and up.floor_from == "source"
    assert up.floor_tilt_deg == base.floor_tilt_deg  # levelled as its source is
    if "07" in rel:
        assert 0.8 <= base.floor_tilt_deg <= 1.4
    assert down.penetrate_mm >= base.penetrate_mm + 35
    # Physically: lifted, nothing can hold it up; sunk, its feet are inside the floor.
    assert up.physics_violation_ratio > base.physics_violation_ratio + 0.45 and down.physics_violation_ratio > base.physics_violation_ratio + 0.45
    # Judged on its own, the lifted copy just finds its new floor.
    assert ev.evaluate(C.lifted(clean)).float_mm < base.float_mm + 5


def test_dragged_reads_planted_skate(judged):
    _, clean, base = judged
    assert ev.evaluate(C.dragged(clean), sources=[clean]).planted_skate_mm_per_s >= base.planted_skate_mm_per_s + 150


def test_played_twice_as_fast_fails_the_physics(judged):
    _, clean, base = judged
    assert base.physics_violation_ratio <= 0.2
    assert ev.evaluate(C.sped_up(clean), sources=[clean]).physics_violation_ratio >= base.physics_violation_ratio + 0.25


def test_one_knee_frame_bent_60_degrees_pops(judged):
    _, clean, base = judged
    popped = C.knee_popped(clean)
    r = ev.evaluate(popped, sources=[clean])
    assert r.pop_frames >= base.pop_frames + 1 and r.worst_joint_speed_ratio >= 2.0
    knee = clean.skeleton.names[joint_classes(clean.skeleton).index("knee")]
    assert r.worst_joint == knee and base.worst_joint_speed_ratio == pytest.approx(1.0)


def test_roc_auc_is_the_mann_whitney_probability():
    assert C.roc_auc([0.0, 1.0], [2.0, 3.0]) == 1.0
    assert C.roc_auc([2.0, 3.0], [0.0, 1.0]) == 0.0
    assert C.roc_auc([1.0, 1.0], [1.0, 1.0]) == 0.5
    assert C.roc_auc([0.0, 2.0], [1.0, 3.0]) == 0.75
    assert C.roc_auc([float("nan")], [0.0]) == 1.0  # NaN ranks lowest


def test_corruptions_do_what_they_say():
    clean = C._clip(require_data() / "cmu_asfamc_converted/16_15.bvh")
    assert np.allclose(C.lifted(clean).root_positions - clean.root_positions, [0, 0, 0.05])
    d = C.dragged(clean).root_positions - clean.root_positions
    assert np.allclose(np.linalg.norm(d[-1]) / clean.duration, 0.3) and np.allclose(d[:, 2], 0)
    fast = C.sped_up(clean)
    assert fast.fps == clean.fps and fast.n_frames == (clean.n_frames + 1) // 2
    popped = C.knee_popped(clean, 60.0, 100)
    changed = np.flatnonzero(np.any(popped.rotations != clean.rotations, axis=(0, 2)))
    assert len(changed) == 1 and clean.skeleton.names[changed[0]] == "ltibia"
    q0, q1 = clean.rotations[100, changed[0]], popped.rotations[100, changed[0]]
    assert 2 * np.degrees(np.arccos(min(1.0, abs(float(np.dot(q0, q1)))))) == pytest.approx(60.0)
