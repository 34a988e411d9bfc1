"""``mjmotion demo``: tables, plots and videos from the bundled clips."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np

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
