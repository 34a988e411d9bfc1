"""A delivered ball bouncing on a MuJoCo floor (seed 003 §2.3.2), and the hit verb's delivery options."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjmotion import delivery as D
from mjmotion.errors import MjmotionError


def test_flight_is_a_parabola_then_bounces_with_its_restitution():
    dv = D.Delivery((0.0, 0.0, 2.0), (3.0, 0.0, 1.0), restitution=0.5)
    f = D.fly(dv, duration=2.0)
    before = f.times < f.bounce_time - 0.01
    t = f.times[before]
    want = np.column_stack([3.0 * t, 0 * t, 2.0 + t - 0.5 * D.GRAVITY * t**2])
    assert np.abs(f.positions[before] - want).max() < 1e-3  # free flight: the known parabola
    # first touch where the parabola meets the floor (ball centre one radius up)
    t_hit = (1.0 + np.sqrt(1.0 + 2 * D.GRAVITY * (2.0 - dv.radius))) / D.GRAVITY
    assert abs(f.bounce_time - t_hit) < 2e-3
    # the vertical speed out of the bounce is about e times the speed in; the pace along is kept
    i = int(np.searchsorted(f.times, f.bounce_time))
    v_in, v_out = f.velocities[i - 2], f.velocities[i + 20]
    assert v_out[2] / -v_in[2] == pytest.approx(0.5, abs=0.1)
    assert v_out[0] == pytest.approx(3.0, abs=1e-6)
    # nearest point of the path to a point on it: itself
    tt, p, v, dist = f.nearest(want[5])
    assert dist < 1e-6 and tt == pytest.approx(t[5], abs=1e-9)


@pytest.mark.parametrize("preset", sorted(D.PRESETS))
def test_aimed_delivery_pitches_in_front_and_passes_through_the_point(preset):
    point = np.array([0.3, 0.4, 0.45])
    dv = D.aimed(point, bowler=(0.0, 1.0), preset=preset)
    f = D.fly(dv)
    t, p, v, dist = f.nearest(point)
    assert dist < 2e-3
    assert f.bounce is not None and f.bounce_time < t  # it pitched before it got there …
    assert f.bounce[1] > point[1] and abs(f.bounce[0] - point[0]) < 1e-6  # … in front, on the line from the bowler
    assert np.linalg.norm(dv.velocity) == pytest.approx(D.PRESETS[preset]["speed"])
    assert v[1] < 0 and abs(v[0]) < 1e-6  # coming at the batsman from the bowler's end


def test_bad_deliveries_are_refused():
    with pytest.raises(MjmotionError, match="unknown delivery"):
        D.aimed(np.zeros(3) + 0.3, preset="yorker!")
    with pytest.raises(MjmotionError, match="can reach"):
        D.aimed(np.array([0.0, 0.0, 6.0]))  # over the batsman's head after a bounce
    with pytest.raises(MjmotionError, match="three finite"):
        D.Delivery((0.0, 0.0, float("nan")), (1.0, 0.0, 0.0))
    with pytest.raises(MjmotionError, match="below its radius"):
        D.Delivery((0.0, 0.0, 0.01), (1.0, 0.0, 0.0))


def test_hit_meets_a_delivered_ball_and_reports_its_launch(tmp_path, capsys):
    """``hit --delivery``: the drive adapted to a ball delivered at it, the launch of that ball."""
    from mjmotion import bvh, synth
    from mjmotion.cli import main

    clip = synth.drive()
    src = tmp_path / "drive.bvh"
    bvh.write(clip.motion, src)
    out, rep = tmp_path / "out.bvh", tmp_path / "r.json"
    args = ["hit", str(src), "--frame", str(clip.hit_frame), "--prop", "bat", "--solver", "dls"]
    assert main([*args, "--offset", "0", "0.05", "0", "--delivery", "medium", "-o", str(out), "--json", str(rep)]) == 0
    r = json.loads(rep.read_text())["delivery"]
    assert r["miss_m"] < 2e-3 and r["launch"]["contacted"], r
    assert r["incoming_velocity"][1] < -20 and r["launch"]["speed"] > 1.0
    # an explicit release: the target is where its path passes nearest the source's hit point (seed §2.5.1)
    rel = np.array(r["release"])
    vel = np.array(r["release_velocity"])
    assert main([*args, "--ball-release", *map(str, rel), "--release-velocity", *map(str, vel), "-o", str(out), "--json", str(rep), "--force"]) == 0
    r2 = json.loads(rep.read_text())
    assert r2["reachable"] and r2["delivery"]["miss_m"] < 2e-3
    assert main([*args, "-o", str(tmp_path / "x.bvh")]) == 2  # neither a target nor a ball
    assert "error:" in capsys.readouterr().err
    # a ball thrown straight up never pitches before the hit: reported as such (its None crashed the line)
    up = ["--ball-release", "0.3", "18", "2.1", "--release-velocity", "0", "0", "100"]
    assert main([*args, *up, "-o", str(out), "--json", str(rep), "--force"]) in (0, 2)
    printed = capsys.readouterr()
    assert "internal error" not in printed.err and "no bounce before the hit" in printed.out
    assert json.loads(rep.read_text())["delivery"]["pitched_m_before"] is None


def test_evaluate_takes_a_delivered_ball(tmp_path, capsys):
    """``evaluate --ball … --delivery``: the ball arrives with the delivery's velocity where it passes
    --ball (a bat that misses it leaves it flying on at that velocity, back along the pitch)."""
    from mjmotion import bvh, synth
    from mjmotion.cli import main

    clip = synth.drive()
    src = tmp_path / "drive.bvh"
    bvh.write(clip.motion, src)
    ball = [f"{x:.4f}" for x in clip.sweet_spot]
    base = ["evaluate", str(src), "--prop", "bat:RightHand", "--ball", *ball, "--frame", str(clip.hit_frame)]
    assert main([*base, "--delivery", "medium"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("hit:"))
    got = dict(kv.split("=") for kv in line[5:].split(", "))
    assert got["launch_contacted"] == "False" and float(got["launch_speed"]) == pytest.approx(30.0, abs=0.5)
    assert float(got["launch_azimuth_deg"]) == pytest.approx(-90.0, abs=0.5)
    assert main([*base, "--ball-release", "0", "18", "2"]) == 2
    assert "--release-velocity" in capsys.readouterr().err
    # a release whose ball flies away from the batter never reaches --ball: refused (it read "contact=True")
    assert main([*base, "--ball-release", "0.3", "18", "2.1", "--release-velocity", "0", "30", "2"]) == 2
    assert "passes 17." in capsys.readouterr().err
