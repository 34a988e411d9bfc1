"""A leading T-pose/transition found once when reading and skipped alike by every verb (issue 18.13)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

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
