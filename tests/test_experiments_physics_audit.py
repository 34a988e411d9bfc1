"""The physics audit's mid-stance footskate: what a foot flat on the floor does while it bears weight."""

from __future__ import annotations

import numpy as np
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


def test_head_sway_reads_a_known_sideways_shake():
    """The bundled walk's head barely sways; its root shaken sideways by 1 cm at 2 Hz adds an
    acceleration of amplitude 0.01·(4π)² = 1.58 m/s² (RMS 1.12, a 6 Hz low-pass keeps 99 % of it)."""
    import numpy as np

    walk = synth.walk(seconds=4.0).motion
    base = pa.head_sway(walk)
    t = walk.times
    side = corruption.walking_direction(walk)[[1, 0]] * np.array([-1.0, 1.0])
    shaken = walk.replace(root_positions=walk.root_positions + np.outer(0.01 * np.sin(4 * np.pi * t), [*side, 0.0]))
    expected = 0.01 * (4 * np.pi) ** 2 / np.sqrt(2)
    assert base < 0.3 * expected
    assert pa.head_sway(shaken) == pytest.approx(np.hypot(base, expected), rel=0.05)


def test_cleanup_of_each_clip_names_the_clips_over_the_bar(tmp_path, monkeypatch):
    """The audit's cleanup line counts the clips within 1.3x their own joint peaks, gives the
    largest, and names the rest: two clean ASF walks pass (16_16's hip reached 1.54x at its first
    toe-off before the toe was low-passed, 1.25 before the held foot's turn was; both now read at most
    1.03), one read as 1.6x does not, and a file
    cleanup cannot read is named as failed, not dropped."""
    from conftest import require_data

    d = require_data() / "cmu_asfamc_converted"
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT x\n")
    walks = [str(d / "16_15.bvh"), str(d / "16_16.bvh")]
    (line,) = pa.cleanup_of_clips_line([*walks, str(bad)], jobs=1)
    import re

    largest = re.search(r"≤ 1\.3 on 2 of 2 \(largest (\d\.\d\d), asfamc_converted 16_1[56] [a-z]+\)", line)
    assert "(2 clips," in line and largest and float(largest.group(1)) <= 1.03, line
    assert "above it" not in line and "; failed: " in line and "broken: " in line, line
    real = pa.cleanup_of_clip
    monkeypatch.setattr(
        pa, "cleanup_of_clip", lambda p: {**real(p), "worst_joint_speed_ratio": 1.6, "worst_joint": "lfemur"} if p.endswith("16_16.bvh") else real(p)
    )
    (line,) = pa.cleanup_of_clips_line(walks, jobs=1)
    assert "≤ 1.3 on 1 of 2 (largest 1.60, asfamc_converted 16_16 lfemur), above it: asfamc_converted 16_16 1.60 (lfemur)" in line, line
    # The rows made once (run() shares them with the clean walks' lines) give the same note, and the
    # clean walk's line reads them instead of cleaning the walk again.
    done = pa.cleanup_of_clips(walks, jobs=1)
    assert pa.cleanup_of_clips_line([], done=done) == [line]
    monkeypatch.setattr(pa, "cleanup_of_clip", lambda p: pytest.fail(f"{p} cleaned again"))
    monkeypatch.setattr(pa, "CLEAN_WALKS", ("cmu_asfamc_converted/16_15.bvh",))
    monkeypatch.setattr(pa, "BLEND_PAIRS", ())
    lines, _ = pa.cleanup_of_blends(d.parent, cleaned=done[0])
    assert any(x.startswith("cleanup of the clean walk cmu_asfamc_converted/16_15.bvh: planted skate") for x in lines), lines


def test_the_tolerance_scan_loosens_monotonically_and_sees_a_walk_played_fast(tmp_path):
    """A looser residual_tol never fails more frames of a clip (the decision at each tolerance is exact),
    and a walk played twice as fast fails more than itself at the judge's tolerance."""
    import numpy as np

    from mjmotion import bvh

    path = tmp_path / "walk.bvh"
    bvh.write(synth.walk(seconds=3.0).motion, path)
    clean = pa.tolerance_scan(str(path), sped_up=False)
    faster = pa.tolerance_scan(str(path), sped_up=True)
    assert len(clean) == len(pa.SCAN_TOLS) and np.all(np.diff(clean) <= 0.0)
    assert faster[0] >= 0.25 and np.all(np.diff(np.add(faster, clean)) <= 0.0)


def test_flight_falls_reads_g_on_a_captured_jump_and_4g_played_twice_as_fast(mocap):
    """The ASF jump 16_01's one long flight falls at g as judged; played twice as fast every
    acceleration is 4x (the daz runs' flights read 1.2-1.8 g: the note this function makes)."""
    from mjmotion.experiments.corruption import sped_up

    jump = pa._read(mocap / "cmu_asfamc_converted" / "16_01.bvh")
    (fall,) = pa.flight_falls(jump)
    assert fall == pytest.approx(-1.0, abs=0.05)
    fast = pa.flight_falls(sped_up(jump))
    assert len(fast) == 1 and fast[0] == pytest.approx(4 * fall, rel=0.05)


def test_flight_falls_of_the_root_follow_the_pelvis_alone(mocap):
    """Over the same flight the root joint of the jump also falls at g; bend its knees over the
    flight by up to 90° (the legs drawn up and let down again, the pelvis untouched) and the centre of mass
    falls otherwise while the root still reads g: the brackets of the note tell the legs from the pelvis."""
    from mjmotion import rotations as rot

    jump = pa._read(mocap / "cmu_asfamc_converted" / "16_01.bvh")
    (pelvis,) = pa.flight_falls(jump, root=True)
    assert pelvis == pytest.approx(-1.0, abs=0.05)
    knees = [jump.skeleton.parents[a] for a, _ in jump.skeleton.feet().values()]
    t = np.arange(jump.n_frames)
    bend = np.where((t >= 132) & (t < 174), np.sin(np.pi * (t - 132) / 42) ** 2, 0.0) * np.radians(90)
    q = jump.rotations.copy()
    for k in knees:
        q[:, k] = rot.multiply(q[:, k], rot.exp(np.outer(bend, [1.0, 0.0, 0.0])))
    tucked = jump.replace(rotations=q)
    (com,), (root,) = pa.flight_falls(tucked), pa.flight_falls(tucked, root=True)
    assert root == pytest.approx(pelvis, abs=1e-6) and abs(com - pelvis) > 0.1
