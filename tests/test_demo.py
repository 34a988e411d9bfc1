"""``mjmotion demo``: tables, plots and videos from the bundled clips."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

from mjmotion import demo
from mjmotion.cli import main


def test_demo_writes_tables_and_two_videos(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--only", "physics_audit", "transitions"]) == 0
    summary = (out / "summary.md").read_text()
    assert "physics_audit/table.md" in summary and "transitions/table.md" in summary
    audit = (out / "physics_audit" / "table.md").read_text()
    assert "| synthesized | walk |" in audit and "cleanup of the linear blend" in audit
    assert "cleanup of the linear blend of bundled walk+run: planted skate" in audit
    assert (out / "physics_audit" / "cleanup_after.png").stat().st_size > 10_000
    assert (out / "transitions" / "weights.png").stat().st_size > 10_000
    for name, expect_frames in (("blend.mp4", 100), ("hitpoint.mp4", None)):
        video = iio.imread(out / name, index=None)  # (frames, H, W, 3)
        assert video.shape[1:] == (360, 640, 3)
        if expect_frames:
            assert video.shape[0] == expect_frames  # 4 s at 25 fps
        # Not a blank picture: the characters differ from the background.
        assert np.ptp(video[len(video) // 2].astype(int)) > 100
    # The README's first picture is a frame of each video: the blend's middle frame over the swing's hit.
    stills = iio.imread(out / "demo_frames.png")
    assert stills.shape == (720, 640, 3)
    assert "demo_frames.png" in summary
    blend = iio.imread(out / "blend.mp4", index=None)
    swing = iio.imread(out / "hitpoint.mp4", index=None)
    hit = int(np.argmin([np.abs(f.astype(int) - stills[360:]).mean() for f in swing]))

    def off(a, b):
        return float(np.abs(a.astype(int) - b.astype(int)).mean())

    # Equal to the decoded frame up to H.264's loss, and farther from other frames of the same video.
    assert off(stills[:360], blend[50]) < 2.0 < off(stills[:360], blend[30])
    assert off(stills[360:], swing[hit]) < 2.0
    hit_s = demo._shot(None)[4]
    frame = hit_s * demo.swing_fps(hit_s)  # the hit's video frame, a whole number
    assert abs(frame - round(frame)) < 1e-9 and abs(hit - frame) <= 1, (hit, frame)


def test_the_swing_video_has_a_frame_at_the_hit():
    for hit_s in (0.3, 1.1, 1.234, 2.019):
        fps = demo.swing_fps(hit_s)
        assert abs(fps - 25.0) <= 0.5 / hit_s + 1e-9  # the nearest such rate: half a frame over the hit time
        assert abs(hit_s * fps - round(hit_s * fps)) < 1e-9
    assert demo.swing_fps(0.0) == 25.0


def test_demo_refuses_unknown_experiments(tmp_path):
    import pytest

    from mjmotion.errors import MjmotionError

    with pytest.raises(MjmotionError, match="unknown experiment"):
        demo.run(tmp_path, names=("no_such",))


def test_experiment_scripts_share_one_command_line(tmp_path, capsys):
    from mjmotion.experiments import script

    out = tmp_path / "tr"
    assert script("transitions", None, ["--bundled", "--quick", "--out", str(out)]) == 0
    assert "whole stream" in (out / "table.md").read_text()
    assert script("transitions", None, ["--data", str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "missing" in err and err.count("\n") == 1


def test_demo_refuses_a_data_folder_without_clips_before_any_work(tmp_path, capsys):
    """An empty --data ran the first experiment, failed on its first clip and left -o behind."""
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "notes.txt").write_text("no clips here")
    out = tmp_path / "out"
    assert main(["demo", "--data", str(empty), "-o", str(out), "--only", "path_search", "--no-video"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --data {empty}: no .bvh files") and err.count("\n") == 1, err
    assert not out.exists()


@pytest.mark.parametrize("where", [".", "results"])
def test_demo_never_writes_among_the_users_clips(tmp_path, capsys, where):
    """`demo --data D -o D --force` wrote its results into the mocap folder and counted the clips as
    written (a hostile-input sweep); inside it likewise."""
    data = tmp_path / "mocap"
    data.mkdir()
    clip = data / "walk.bvh"
    clip.write_bytes(b"HIERARCHY\n")
    out = data / where
    assert main(["demo", "--data", str(data), "-o", str(out), "--only", "path_search", "--no-video", "--force"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: -o {out}: inside --data {data}") and err.count("\n") == 1, err
    assert sorted(p.name for p in data.iterdir()) == ["walk.bvh"] and clip.read_bytes() == b"HIERARCHY\n"


def test_demo_never_counts_the_users_clips_as_written(tmp_path, capsys):
    """`-o` holding `--data` wrote beside the clips and counted them (and the user's notes) as written;
    an `-o` that is a link loop ended in an internal error (Path.resolve raises on a loop)."""
    data = tmp_path / "mocap"
    data.mkdir()
    (data / "walk.bvh").write_bytes(b"HIERARCHY\n")
    assert main(["demo", "--data", str(data), "-o", str(tmp_path), "--only", "path_search", "--no-video", "--force"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: -o {tmp_path}: holds --data {data}") and err.count("\n") == 1, err
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    assert main(["demo", "--data", str(data), "-o", str(loop), "--only", "path_search", "--no-video"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "internal error" not in err and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loop", "mocap"]
