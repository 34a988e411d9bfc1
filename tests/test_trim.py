"""A leading T-pose/transition found once when reading and skipped alike by every verb (issue 18.13)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import require_data

from mjmotion import bvh, trim
from mjmotion.cli import main
from mjmotion.commands._common import clip_frame
from mjmotion.errors import MjmotionError

DAZ = "cmu_cgspeed_daz"
#: The shared clips that open with a transient (mocap/SOURCES.md): every daz clip's T-pose and the
#: three frames interpolating out of it; 16_15's zeroed left arm (frames 0-1); 007_04's rest pose
#: elsewhere (frame 0); 16_16's spinning hands and thumbs in frames 2-7 (131-374 rad/s, against
#: 32 rad/s for its 99th-percentile step).
TRANSIENTS = {"cmu_asfamc_converted/16_15": 2, "cmu_asfamc_converted/16_16": 8, "cmu_iclone_ccrig/007_04": 1}


def test_leading_transient_of_every_shared_clip(mocap):
    found = {}
    for f in sorted(Path(mocap).glob("*/*.bvh")):
        key = f"{f.parent.name}/{f.stem}"
        found[key] = trim.leading_transient(bvh.read(str(f)))
    assert len(found) == 42
    for key, k in found.items():
        expected = 4 if key.startswith(DAZ) else TRANSIENTS.get(key, 0)
        assert k == expected, (key, k)


def test_skip_returns_the_clip_from_the_first_captured_frame(mocap):
    m = bvh.read(str(mocap / DAZ / "09_01.bvh"))
    cut, k = trim.skip_leading_transient(m)
    assert k == 4 and cut.n_frames == m.n_frames - 4
    np.testing.assert_array_equal(cut.rotations, m.rotations[4:])
    steady = cut[:20]  # too short to judge: nothing is skipped
    assert trim.skip_leading_transient(steady) == (steady, 0)


@pytest.mark.parametrize("held", [20, 120])
def test_a_t_pose_held_for_many_frames_is_skipped_and_leaves_the_floor_alone(mocap, held):
    """daz's T-pose stands 6 cm under the capture's floor: held 20 frames (0.17 s) before a run it was
    not skipped (only the first 10 steps were looked at) and moved the detected floor 9 cm. A pose
    held and then left smoothly (a subject standing still) is kept."""
    from mjmotion import feet

    m = bvh.read(str(mocap / DAZ / "09_01.bvh"))
    pad = np.repeat(np.arange(1), held)
    longer = m.replace(
        rotations=np.concatenate([m.rotations[pad], m.rotations]), root_positions=np.concatenate([m.root_positions[pad], m.root_positions])
    )
    cut, k = trim.skip_leading_transient(longer)
    assert k == held + 4
    np.testing.assert_array_equal(cut.rotations, m.rotations[4:])
    own = trim.skip_leading_transient(m)[0]
    assert feet.judged_floor(cut).height == pytest.approx(feet.judged_floor(own).height, abs=1e-9)
    still = own.replace(
        rotations=np.concatenate([own.rotations[pad], own.rotations]), root_positions=np.concatenate([own.root_positions[pad], own.root_positions])
    )
    assert trim.leading_transient(still) == 0  # the capture's first pose held: nothing stands out after it


def _note_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("note:")]


def test_every_verb_skips_the_transient_with_one_note_and_keep_start_keeps_it(mocap, tmp_path, capsys, monkeypatch):
    walk, run = str(mocap / DAZ / "07_01.bvh"), str(mocap / DAZ / "09_01.bvh")
    n_walk, n_run = 317, 149

    def call(*argv: str) -> list[str]:
        capsys.readouterr()
        assert main(list(argv)) == 0
        return _note_lines(capsys.readouterr().err)

    for keep in (False, True):
        extra = ["--keep-start"] if keep else []
        k = 0 if keep else 4
        tag = "keep" if keep else "skip"
        # convert and fk write the clip's frames
        notes = call("convert", run, str(tmp_path / f"c_{tag}.bvh"), *extra)
        assert bvh.read(str(tmp_path / f"c_{tag}.bvh")).n_frames == n_run - k
        assert len(notes) == (0 if keep else 1) and (keep or ("frames 0-3" in notes[0] and "09_01.bvh" in notes[0]))
        call("fk", run, "-o", str(tmp_path / f"f_{tag}.npz"), *extra)
        assert np.load(tmp_path / f"f_{tag}.npz")["positions"].shape[0] == n_run - k
        # register's grid and blend's clips
        notes = call("register", walk, run, "--json", str(tmp_path / f"r_{tag}.json"), *extra)
        assert json.loads((tmp_path / f"r_{tag}.json").read_text())["frames"] == [n_walk - k, n_run - k]
        assert len(notes) == (0 if keep else 2)
        notes = call("blend", walk, run, "--weights", "0.5,0.5", "--method", "linear", "-o", str(tmp_path / f"b_{tag}.bvh"), *extra)
        assert bvh.read(str(tmp_path / f"b_{tag}.bvh")).n_frames == n_run - k and len(notes) == (0 if keep else 2)
        # render: the scene gets the trimmed clip (the video itself is render's own test)
        from mjmotion import render

        seen: list = []

        def scene(actors, seen=seen, **kw):
            seen.extend(actors)
            return type("Scene", (), {"n_frames": 0})()

        monkeypatch.setattr(render, "build_scene", scene)
        monkeypatch.setattr(render, "render", lambda *a, **kw: None)
        call("render", run, "-o", str(tmp_path / f"v_{tag}.mp4"), *extra)
        assert seen[0].motion.n_frames == n_run - k
        monkeypatch.undo()
        # a stream script's clips, and evaluate (which lists skipped frames once, after its table)
        script = {
            "duration": 1.0,
            "clips": {"walk": {"file": walk}, "run": {"file": run}},
            "locomotion": ["walk", "run"],
            "commands": [{"time": 0, "weights": {"walk": 1}}],
        }
        (tmp_path / f"s_{tag}.json").write_text(json.dumps(script))
        notes = call("stream", str(tmp_path / f"s_{tag}.json"), "-o", str(tmp_path / f"s_{tag}.bvh"), *extra)
        assert len(notes) == (0 if keep else 2)
        capsys.readouterr()
        assert main(["evaluate", run, "--json", str(tmp_path / f"e_{tag}.json"), *extra]) == 0
        rec = json.loads((tmp_path / f"e_{tag}.json").read_text())[0]
        assert rec["skipped_frames"] == k and rec["report"]["n_frames"] == n_run - k
    # an explicit range is the file's frames: nothing more is skipped
    assert call("register", walk, run, "--frames", "2:", "--json", str(tmp_path / "r_range.json")) == []
    assert json.loads((tmp_path / "r_range.json").read_text())["frames"] == [n_walk - 2, n_run - 2]


def test_frame_options_stay_file_frames():
    assert clip_frame(100, 4, "--frame") == 96
    assert clip_frame(100, 0, "--frame") == 100
    assert clip_frame(-1, 4, "--rest-frame") == -1
    with pytest.raises(MjmotionError, match=r"--frame 2: inside the skipped .*frames 0-3.*--keep-start"):
        clip_frame(2, 4, "--frame")


def test_frame_options_out_of_range_are_refused_in_the_files_numbers():
    """hit --frame 317 of a daz clip (frames 4..316 read) said "--frame 313: the clip has frames 0..312", and
    vary --abort-at 400 "got 396": numbers the user never gave."""
    assert clip_frame(316, 4, "--rest-frame", 313) == 312 and clip_frame(-313, 4, "--rest-frame", 313) == -313
    with pytest.raises(MjmotionError, match=r"^--frame 317: outside the clip's frames 4\.\.316$"):
        clip_frame(317, 4, "--frame", 313)
    with pytest.raises(MjmotionError, match=r"^--rest-frame -314: outside the clip's frames 4\.\.316 \(or -313\.\.-1 from the end\)"):
        clip_frame(-314, 4, "--rest-frame", 313)
    # inner: the first and last frames of the clip as read are refused too, and the reason given
    assert clip_frame(5, 4, "--abort-at", 313, inner=True) == 1 and clip_frame(315, 4, "--abort-at", 313, inner=True) == 311
    for frame in (4, 316):
        with pytest.raises(MjmotionError, match=rf"^--abort-at {frame}: outside the clip's inner frames 5\.\.315; why$"):
            clip_frame(frame, 4, "--abort-at", 313, inner=True, why="; why")
    with pytest.raises(MjmotionError, match=r"^--frame 1: a clip of 2 frames has no frame inside it"):
        clip_frame(1, 0, "--frame", 2, inner=True)


def test_hit_and_vary_refuse_the_clips_end_frames_and_speak_in_file_frames(tmp_path, capsys):
    """A hit at the first or last frame ran the solver, moved nothing (the edit keeps those frames) and
    said "target unreachable … stopped 0.000 m short"; vary's report counted from the trimmed clip."""
    clip = require_data() / "cmu_cgspeed_daz" / "09_06.bvh"
    n = bvh.read(clip).n_frames
    for frame in (4, n - 1):
        out = tmp_path / f"h{frame}.bvh"
        assert main(["hit", str(clip), "--frame", str(frame), "--offset", "0", "0", "0.01", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"--frame {frame}: outside the clip's inner frames 5..{n - 2}" in err and not out.exists(), err
    out = tmp_path / "v.bvh"
    assert main(["vary", str(clip), "--abort-at", "5", "--abort-frames", "10", "-o", str(out)]) == 0
    assert "abort at 5," in capsys.readouterr().out and bvh.read(out).n_frames == 2 + 10
