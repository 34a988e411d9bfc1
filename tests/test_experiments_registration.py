"""The registration experiments (path_search, timewarp_blend, transitions) in quick mode on the bundled clips."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjmotion.blend import Track
from mjmotion.experiments import Table, path_search, timewarp_blend, transitions

ROOT = Path(__file__).resolve().parents[1]


def records(table: Table) -> list[dict]:
    return [dict(zip(table.columns, row, strict=True)) for row in table.rows]


def check_outputs(table: Table, out: Path) -> None:
    assert (out / "table.md").read_text(encoding="utf-8").startswith(f"## {table.title}")
    assert table.files
    for f in table.files:
        assert Path(f).is_file() and Path(f).stat().st_size > 0, f
        if f.endswith(".png"):
            assert Path(f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- path_search
@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    out = tmp_path_factory.mktemp("path_search")
    return out, path_search.run(out, None, quick=True)


def test_path_search_dp_is_optimal_and_greedy_is_not_better(paths):
    out, table = paths
    check_outputs(table, out)
    rows = records(table)
    sub = [r for r in rows if r["grid"] == "sub-grid"]
    assert sub and all(int(r["cells"]) <= 100 for r in sub)
    exact_mean = {"DP, least mean", "brute force, least mean"}
    for r in rows:
        if r["method"] in ("DP", "brute force"):  # the per-end rule: the cheapest path to where it ends
            assert r["total / least to its end (worst)"] == pytest.approx(1.0, abs=1e-12), r
        if r["method"] in ("DP", "brute force", *exact_mean):
            assert r["solved"].split("/")[0] == r["solved"].split("/")[1]
        if r["method"] in exact_mean or (r["ends"] == "corners" and r["method"] in ("DP", "brute force")):
            assert r["cost / optimum (mean)"] == pytest.approx(1.0, abs=1e-12), r
            assert r["worst"] == pytest.approx(1.0, abs=1e-12), r
    for r in rows:
        if r["solved"] != "0/" + r["solved"].split("/")[1]:
            assert r["cost / optimum (mean)"] >= 1.0 - 1e-12, r  # nothing beats the optimum, at either end rule
    greedy = [r for r in rows if r["method"] == "greedy" and r["ends"] == "corners"]
    assert greedy and max(r["worst"] for r in greedy) > 1.0  # on real grids greedy is not optimal
    for values in ("real", "integer"):
        assert {r["method"] for r in rows if r["values"] == values} >= {"brute force", "DP", "greedy"}
    assert any(r["method"].startswith("threshold") for r in rows)
    detail = (out / "pairs.md").read_text(encoding="utf-8")
    assert "walk × run (241×181)" in detail  # grid sizes are reported
    brute = (out / "brute_force.md").read_text(encoding="utf-8")
    lines = [ln for ln in brute.splitlines() if ln.startswith("| every")]
    assert len(lines) == 4 and all(ln.rstrip(" |").endswith("yes") for ln in lines)  # brute force = DP at every size


def test_sub_grid_and_quantise():
    cost = np.arange(60 * 40, dtype=float).reshape(60, 40)
    sub, k = path_search.sub_grid(cost, 8)
    assert sub.shape == (8, 8) and k == 5 and sub[1, 1] == cost[5, 5]
    q = path_search.quantise(cost)
    assert q.max() == 255 and q.min() == 0 and np.all(q == np.round(q))


# --------------------------------------------------------------------------- timewarp_blend
@pytest.fixture(scope="module")
def blends(tmp_path_factory):
    out = tmp_path_factory.mktemp("timewarp_blend")
    return out, timewarp_blend.run(out, None, quick=True)


def test_registered_blends_skate_less_keep_rhythm_and_speeds_are_monotone(blends):
    out, table = blends
    check_outputs(table, out)
    rows = records(table)
    by = {(r["method"], r["run weight"]): r for r in rows}
    assert sorted({r["run weight"] for r in rows}) == list(timewarp_blend.RUN_WEIGHTS)
    for w in (0.25, 0.5, 0.75):
        assert by["registered", w]["skate@0.05 mm/s"] < by["linear", w]["skate@0.05 mm/s"]
        assert by["registered", w]["planted skate mm/s"] < by["linear", w]["planted skate mm/s"]
    for method in ("linear", "registered"):
        speeds = [by[method, w]["speed m/s"] for w in timewarp_blend.RUN_WEIGHTS]
        assert np.all(np.diff(speeds) > 0), (method, speeds)
    lo, hi = sorted((by["registered", 0.0]["steps/s"], by["registered", 1.0]["steps/s"]))
    cadence = [by["registered", w]["steps/s"] for w in (0.25, 0.5, 0.75)]
    assert all(lo <= c <= hi for c in cadence) and np.all(np.diff(cadence) > 0), (lo, cadence, hi)
    # h_c sensitivity: a higher contact height counts more (swing) frames, so skate grows with it
    for r in rows:
        assert r["skate@0.03 mm/s"] <= r["skate@0.08 mm/s"] + 1e-9 or np.isnan(r["skate@0.03 mm/s"])


def test_bspline_timewarp_recovers_the_known_warp_and_is_smoother(blends):
    out, _ = blends
    text = (out / "timewarp.md").read_text(encoding="utf-8")
    assert "known warp" in text
    lines = [ln.split("|")[1:-1] for ln in text.splitlines() if ln.startswith("| walk")]
    rows = [dict(zip(timewarp_blend.WARP_COLUMNS, (c.strip() for c in ln), strict=True)) for ln in lines]
    known = {r["timewarp"]: r for r in rows if "known warp" in r["pair"]}
    assert set(known) == {"discrete", "bspline"}
    for r in known.values():
        assert float(r["recovery RMS frames"]) < 1.5  # issue 4: within 1.5 frames RMS
    assert float(known["bspline"]["recovery RMS frames"]) <= float(known["discrete"]["recovery RMS frames"])
    for pair in {r["pair"] for r in rows}:
        kinds = {r["timewarp"]: r for r in rows if r["pair"] == pair}
        assert float(kinds["bspline"]["clock jerk frames/frame²"]) < float(kinds["discrete"]["clock jerk frames/frame²"])


def test_blendability_table_calls_alike_pairs_blendable_and_others_not(blends):
    """Issue 18.4's calibration, on the bundled clips: walk with run, fast walk, sneak, limp under the
    threshold; walk with a standing kick, punch or cricket drive over it."""
    out, table = blends
    text = (out / "blendability.md").read_text(encoding="utf-8")
    rows = [[c.strip() for c in ln.split("|")[1:-1]] for ln in text.splitlines() if ln.startswith("| walk")]
    assert len(rows) == len(timewarp_blend.BLENDABILITY_PAIRS_BUNDLED)
    for r in rows:
        rec = dict(zip(timewarp_blend.BLENDABILITY_COLUMNS, r, strict=True))
        assert rec["blendable"] == rec["alike (Sako §7.2)"], rec
    assert str(out / "blendability.md") in table.files


def test_steps_per_s_counts_stance_changes():
    from mjmotion.evaluate import foot_track

    fps, cadence = 60.0, 2.0  # steps per second: the lower foot alternates every 0.5 s
    t = np.arange(int(3 * fps)) / fps
    left = 0.05 * np.clip(np.sin(np.pi * cadence * t), 0, None)
    right = 0.05 * np.clip(-np.sin(np.pi * cadence * t), 0, None)
    pts = np.zeros((len(t), 2, 1, 3))
    pts[:, 0, 0, 2], pts[:, 1, 0, 2] = left, right
    track = foot_track(("left", "right"), pts, fps)
    assert timewarp_blend.steps_per_s(track) == pytest.approx(cadence, rel=0.02)
    pts[:, :, 0, 2] = 0.0  # both feet flat: no stance change, no rhythm
    assert np.isnan(timewarp_blend.steps_per_s(foot_track(("left", "right"), pts, fps)))


# --------------------------------------------------------------------------- transitions
@pytest.fixture(scope="module")
def stream_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("transitions")
    return out, transitions.run(out, None, quick=True)


def test_stream_is_continuous_without_time_blip(stream_table):
    out, table = stream_table
    check_outputs(table, out)
    rows = {r["phase"]: r for r in records(table)}
    whole = rows["whole stream"]
    assert whole["max joint speed ratio"] <= 1.5
    assert whole["per-joint speed ratio"] <= 1.5
    assert whole["root jump m"] <= 1e-6
    assert whole["min clock step"] >= 0.0  # no clock ever runs backwards
    assert whole["hidden jump frames"] <= 1e-9
    assert whole["max heading step °/frame"] <= 1.5 * whole["sources' max °/frame"]
    for name in ("kick back to locomotion", "punch back to locomotion"):  # where seed 000's blip happened
        assert rows[name]["root jump m"] <= 1e-6 and rows[name]["max joint speed ratio"] <= 1.5
    # the same tracks composed in the clips' own coordinates jump: the metric can see a blip
    assert rows["naive: whole stream"]["root jump m"] > 0.05
    # the stream follows its commands: faster in the walk/run blend, nearly still in the kick
    assert rows["walk/run .5"]["speed m/s"] > 1.3 * rows["walk"]["speed m/s"]
    assert rows["kick"]["speed m/s"] < 0.3 * rows["walk"]["speed m/s"]
    # seed 000 §3.3: the fade from the walk/run mix into the kick is longer by its pace; from the walk, nominal
    fades = {}
    for ln in (out / "transitions.md").read_text(encoding="utf-8").splitlines():
        if ln.startswith(("| kick", "| punch")):
            rec = dict(zip(transitions.TRANSITION_COLUMNS, (c.strip() for c in ln.split("|")[1:-1]), strict=True))
            fades[rec["clip"]] = rec
    kick, punch = fades["kick"], fades["punch"]
    assert float(kick["locomotion pace r (in)"]) > 1.1 and int(kick["fade-in frames"]) == round(18 * float(kick["locomotion pace r (in)"]))
    assert float(punch["locomotion pace r (in)"]) == pytest.approx(1.0) and int(punch["fade-in frames"]) == 18
    for rec in (kick, punch):
        assert float(rec["clip frames played"]) == float(rec["clip's last frame"])


def test_clock_checks_catch_a_backward_step_and_a_hidden_jump():
    script = transitions.bundled_script()
    result = transitions.run_stream(script)
    ok = transitions.clock_checks(result)
    assert ok["min_step"].min() >= 0 and ok["hidden"].max() < 1e-9
    tr = result.tracks[0]
    n = int(np.argmax(tr.weights > 0.5)) + 5
    times, steps = tr.times.copy(), tr.steps.copy()
    times[n:] += 30.0  # a jump of 30 frames while weighted: a time blip
    steps[n + 10] = -1.0  # and a step back
    bad = transitions.StreamResult(script, result.motion, (Track(tr.motion, times, steps, tr.weights), *result.tracks[1:]))
    checks = transitions.clock_checks(bad)
    assert checks["hidden"][n] == pytest.approx(30.0)
    assert checks["min_step"][n + 10] == -1.0


def test_experiment_script_runs(tmp_path):
    out = tmp_path / "tr"
    res = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "transitions.py"), "--bundled", "--quick", "--out", str(out)],
        check=False, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "| whole stream |" in res.stdout and (out / "table.md").is_file() and (out / "weights.png").is_file()
