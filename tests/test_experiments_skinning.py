"""The skinning experiment: its quick version writes the table and figure, LBS collapses under a twist and DQS does not."""

from __future__ import annotations

from mjmotion.experiments import script


def test_skinning_experiment_quick(tmp_path, capsys):
    out = tmp_path / "skinning"
    assert script("skinning", None, ["--bundled", "--quick", "--out", str(out)]) == 0
    rows = [line.split("|")[1:-1] for line in (out / "table.md").read_text().splitlines() if line.startswith("| twist |")]
    cells = {float(r[1]): [float(x) for x in r[2:]] for r in rows}
    lbs_area, dqs_area, lbs_vol, dqs_vol = cells[180.0]
    assert cells[0.0] == [100.0, 100.0, 100.0, 100.0]
    assert dqs_area >= 90 and dqs_vol >= 90 and lbs_area < 30 and lbs_vol < 60
    assert (out / "skinning.png").stat().st_size > 20_000
    assert "at a 180° twist LBS keeps" in capsys.readouterr().out
