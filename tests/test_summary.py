"""Short reprs and Markdown tables (mjmotion/summary.py) of clips, skeletons and reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjmotion import summary, synth


@pytest.fixture(scope="module")
def walk():
    return synth.walk(seconds=1.0).motion


@pytest.fixture(scope="module")
def run_clip():
    return synth.run(seconds=1.0).motion


def _table(md: str) -> dict[str, str]:
    """``{label: cell}`` of a two-column Markdown table."""
    rows = [ln.strip("|").split("|") for ln in md.strip().splitlines()[2:]]
    return {a.strip(): b.strip() for a, b in rows}


def test_numbers_are_rounded_for_reading():
    assert summary.number(120.0000480000192) == "120"
    assert summary.number(2.881225802775491e-06) == "2.881e-06"
    assert summary.number(123456.7) == "1.235e+05"
    assert summary.number(float("nan")) == "–" and summary.number(None) == "–"
    assert summary.number(True) == "yes" and summary.number(3) == "3"
    assert summary.number([0.26604242, 0.349, 1]) == "(0.266, 0.349, 1)"


def test_a_motion_and_its_skeleton_print_in_a_line(walk):
    text = repr(walk)
    assert text == f"Motion('walk', {walk.skeleton.n_joints} joints, {walk.n_frames} frames at 60 fps, 1 s)"
    assert str(walk) == text  # print(motion) no longer dumps every array
    sk = repr(walk.skeleton)
    assert sk.startswith(f"Skeleton({walk.skeleton.n_joints} joints, root 'Hips'") and len(sk) < 120
    assert "array" not in text + sk


def test_a_clip_at_a_files_rounded_rate(mocap):
    from mjmotion import bvh

    m = bvh.read(mocap / "cmu_asfamc_converted" / "16_15.bvh")
    assert repr(m) == "Motion('16_15', 31 joints, 471 frames at 120 fps, 3.917 s)"


def test_the_judges_report_prints_its_headline_and_tables_every_row(walk):
    from mjmotion import evaluate

    rep = evaluate.evaluate(walk)
    text = repr(rep)
    assert text.startswith("Report('walk', frames=") and len(text) < 250
    assert f"planted_skate_mm_per_s={summary.number(rep.planted_skate_mm_per_s)}" in text
    cells = _table(rep.to_markdown())
    row = rep.row()
    assert set(cells) == set(row)
    for k, v in row.items():
        assert cells[k] == summary.number(v)
        if isinstance(v, float) and math.isfinite(v) and v:
            assert float(cells[k]) == pytest.approx(v, rel=5e-4)  # four significant digits


def test_cleanup_and_registration_results_print_in_a_line(walk, run_clip):
    from mjmotion import blend, cleanup, registration

    res = cleanup.cleanup(blend.blend([walk, run_clip], [0.5, 0.5], method="linear"))
    assert repr(res).startswith(f"CleanupResult('blend', plants={len(res.plants)}, changed_frames={int(res.changed_frames.sum())}")
    cells = _table(res.to_markdown())
    assert cells["plants"] == str(len(res.plants)) and cells["params.h_c"] == summary.number(res.params.h_c)

    pr = registration.register(walk, run_clip)
    na, nb = pr.grid.cost.shape
    assert repr(pr).startswith(f"PairRegistration({na} × {nb} grid, {len(pr.path.cells)}-cell path, method=dp, mean_cost=")
    cells = _table(pr.to_markdown())
    assert cells["path cells"] == str(len(pr.path.cells)) and cells["mean cost (m²)"] == summary.number(pr.path.mean_cost)

    many = registration.register_many([walk, run_clip])
    assert (
        repr(many)
        == f"Registration(2 clips, reference {many.reference}, {len(many.times)} instants, mean_costs=(0, {summary.number(float(np.max(many.mean_costs)))}))"
    )
    assert "reference" in many.to_markdown()


def test_an_adaptation_prints_its_report_in_a_line():
    from mjmotion import hitpoint

    clip = synth.drive()
    a = hitpoint.adapt(
        clip.motion, offset=np.array([0.0, 0.0, 0.05]), frame=clip.hit_frame, effector="club", solver="dls", prop=clip.prop, style=False
    )
    text = repr(a)
    assert text.startswith(f"Adaptation('{a.motion.name}', solver=dls, hit_frame={a.report['hit_frame']}, reachable=yes") and len(text) < 250
    cells = _table(a.to_markdown())
    assert cells["hit_error_m"] == summary.number(a.report["hit_error_m"])


def test_bundled_clips_spaces_paths_skins_and_scenes_print_in_a_line():
    """Each printed dozens of lines of arrays (a SynthClip 121 lines); now what it is, in one short line."""
    from mjmotion import render, skin, style
    from mjmotion.variations import paths

    clip = synth.drive()
    space = style.PoseSpace.fit(clip.motion)
    path = paths.source_path(space, 5)
    short = clip.motion[:3]
    shown = {
        "SynthClip('drive', kind=drive, frames=": repr(clip),
        "PoseSpace('drive', 22 joints, components=": repr(space),
        "ScorePath(": repr(path),
        "SkinnedMotion(": repr(skin.animate(short, normals=False)),
        "Scene(drive; ": repr(render.build_scene([render.Actor(short, "drive")])),
    }
    for start, text in shown.items():
        assert text.startswith(start) and "\n" not in text and len(text) < 200, text
