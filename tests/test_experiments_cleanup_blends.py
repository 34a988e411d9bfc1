"""The cleanup-of-blends experiment: its cases, its verdicts, and a run on the bundled pair."""

from __future__ import annotations

import math

import pytest

from mjmotion.experiments import cleanup_blends as cb


def _m(skate: float, pen: float = 0.0, ratio: float = 1.0, pops: float = 0.0) -> dict[str, float]:
    return {"planted_skate_mm_per_s": skate, "penetrate_mm": pen, "worst_joint_speed_ratio": ratio, "pop_frames": pops}


@pytest.mark.parametrize(
    "before,after,self_clean,want",
    [
        (_m(100.0), _m(20.0), False, []),  # exactly 80 % less
        (_m(100.0), _m(20.5), False, ["skate"]),
        (_m(100.0), _m(45.0), True, []),  # against itself: half is the bar
        (_m(100.0), _m(10.0, pen=2.5), False, ["penetrate"]),
        (_m(100.0), _m(10.0, ratio=1.31), False, ["joint speed"]),
        (_m(100.0, pops=1.0), _m(10.0, pops=2.0), False, ["pops"]),
        (_m(100.0, pops=2.0), _m(10.0, pops=1.0), False, []),
        (_m(math.nan), _m(math.nan), False, None),  # no planted frame: nothing to cut
        (_m(100.0), _m(math.nan), False, []),  # no contact left: all of it cut
    ],
)
def test_the_bar_is_issue_13s(before, after, self_clean, want):
    assert cb.verdict(before, after, self_clean) == want


def test_the_cases_cover_every_pair_of_a_flavour_at_three_weights(tmp_path):
    for folder, (walks, runs) in cb.CLIPS.items():
        for name in (*walks, *runs):
            (tmp_path / folder).mkdir(exist_ok=True)
            (tmp_path / folder / f"{name}.bvh").write_text("")
    got = cb.cases(tmp_path)
    n = sum(len(w) * len(r) + len(r) * (len(r) - 1) // 2 + len(w) * (len(w) - 1) // 2 for w, r in cb.CLIPS.values())
    assert sum(c.b is not None for c in got) == 3 * n and sum(c.b is None for c in got) == sum(len(w) for w, _ in cb.CLIPS.values())
    assert {(c.folder, c.a, c.b) for c in got if c.kind == "walk/run"} >= {
        ("cmu_cgspeed_daz", "07_01", "09_01"),
        ("cmu_iclone_ccrig", "002_01", "002_03"),
    }
    (tmp_path / "cmu_iclone_ccrig" / "002_03.bvh").unlink()  # a missing clip drops its pairs, not the run
    assert not any(c.b == "002_03" for c in cb.cases(tmp_path))


def test_the_bundled_walk_run_blends_pass(tmp_path):
    table = cb.run(tmp_path, None, jobs=1)
    ((flavour, kind, cases, passed, na, *_),) = table.rows
    assert (flavour, kind, cases, passed, na) == ("bundled", "walk/run", 3, 3, 0)
    from mjmotion.cleanup import ROOT_SHIFT

    assert table.columns[-1] == "largest root shift (m)" and 0.0 <= table.rows[0][-1] <= ROOT_SHIFT  # (legs shorter than 1 m)
    assert (tmp_path / "table.md").read_text().count("3 of 3 judged cases pass") == 1
