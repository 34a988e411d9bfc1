"""The motion-stream controller: walk → walk/fast blend → kick → walk without jumps or spikes."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from mjmotion import bvh, evaluate
from mjmotion import stream as S
from mjmotion.commands._common import parse_frames
from mjmotion.errors import MjmotionError

ASF = "cmu_asfamc_converted"
KICK = (500, 720)  # 10_01: approach, right-foot kick near frame 596, recovery (SOURCES.md)


def _load(path: str, frames: str | None, field: str):
    m = bvh.read(path)
    return m[parse_frames(frames, m.n_frames, field)] if frames else m


def _script(mocap, **extra) -> dict:
    d = mocap / ASF
    data = {
        "duration": 7.0,
        "clips": {
            "walk": {"file": str(d / "16_15.bvh"), "frames": "2:"},  # frames 0-1: zeroed left arm (SOURCES.md)
            "fast": {"file": str(d / "16_24.bvh")},
            "kick": {"file": str(d / "10_01.bvh"), "frames": f"{KICK[0]}:{KICK[1]}"},
        },
        "locomotion": ["walk", "fast"],
        "commands": [
            {"time": 0.0, "weights": {"walk": 1}},
            {"time": 1.0, "weights": {"walk": 0.4, "fast": 0.6}, "ramp": 0.8},
            {"time": 3.0, "play": "kick", "blend": 0.3},
            {"time": 4.0, "weights": {"walk": 1}, "ramp": 0.5},
        ],
    }
    data.update(extra)
    return data


@pytest.fixture(scope="module")
def streamed():
    from conftest import require_data

    mocap = require_data()
    script = S.parse_script(_script(mocap), mocap, _load)
    return script, S.stream(script)


def _speeds(m) -> np.ndarray:
    return np.linalg.norm(np.diff(m.root_positions[:, :2], axis=0), axis=1) * m.fps


def test_stream_has_no_root_jump_and_no_joint_speed_spike(streamed):
    script, out = streamed
    sources = list(script.clips.values())
    assert out.n_frames == round(7.0 * script.fps)
    assert evaluate.root_jump_m(out, sources) <= 1e-9
    assert evaluate.max_joint_speed_ratio(out, sources) <= 1.5
    # stricter than METRICS' ratio (which a source's own spike can mask): joint by joint
    res = evaluate.joint_angular_speeds(out).max(axis=0)
    src = np.max([evaluate.joint_angular_speeds(s).max(axis=0) for s in sources], axis=0)
    moving = src > 1e-6
    assert np.all(res[moving] <= 1.5 * src[moving])
    assert np.all(res[~moving] < 1e-6)
    # heading never jumps (seed 000 §4.1's time blip turned the character in one frame)
    from mjmotion.blend import yaw_of

    dyaw = np.abs(np.diff(np.unwrap(yaw_of(out.rotations[:, 0]))))
    src_dyaw = max(np.abs(np.diff(np.unwrap(yaw_of(s.rotations[:, 0])))).max() for s in sources)
    assert dyaw.max() <= 1.5 * src_dyaw


def test_stream_follows_its_commands(streamed):
    script, out = streamed
    fps = script.fps
    v = _speeds(out)
    walk, fast, kick = (script.clips[k] for k in ("walk", "fast", "kick"))
    v_walk, v_fast = _speeds(walk).mean(), _speeds(fast).mean()
    early = v[int(0.2 * fps) : int(0.9 * fps)].mean()
    blended = v[int(2.0 * fps) : int(2.9 * fps)].mean()
    assert early == pytest.approx(v_walk, rel=0.15)
    assert early < blended < v_fast * 1.05  # 40/60 walk/fast is faster than the walk
    # the kick is played: the right toe reaches (most of) the kick's peak speed inside its window
    from mjmotion import kinematics

    toe = script.clips["kick"].skeleton.index("rtoes")
    toe_speed = np.linalg.norm(np.diff(kinematics.joint_positions(out)[:, toe], axis=0), axis=1) * fps
    kick_peak = (np.linalg.norm(np.diff(kinematics.joint_positions(kick)[:, toe], axis=0), axis=1) * fps).max()
    in_kick = slice(int(3.0 * fps), int(3.0 * fps) + kick.n_frames)
    assert toe_speed[in_kick].max() > 0.9 * kick_peak
    assert toe_speed[: int(3.0 * fps)].max() < 0.6 * kick_peak
    # back to walking after the kick, at the walk's pace
    late = v[int(5.5 * fps) :].mean()
    assert late == pytest.approx(v_walk, rel=0.2)


def test_return_ends_a_clip_early(mocap):
    """Returning before the kick's peak (≈0.8 s into the excerpt) means the kick never lands."""
    from mjmotion import kinematics

    cmds = [{"time": 0.0, "weights": {"walk": 1}}, {"time": 1.0, "play": "kick", "blend": 0.2}, {"time": 1.4, "return": True, "blend": 0.2}]
    script = S.parse_script(_script(mocap, duration=3.0, commands=cmds), mocap, _load)
    out = S.stream(script)
    kick = script.clips["kick"]
    toe = kick.skeleton.index("rtoes")
    peak = (np.linalg.norm(np.diff(kinematics.joint_positions(kick)[:, toe], axis=0), axis=1) * script.fps).max()
    speed = np.linalg.norm(np.diff(kinematics.joint_positions(out)[:, toe], axis=0), axis=1) * script.fps
    assert speed.max() < 0.6 * peak
    assert evaluate.root_jump_m(out, list(script.clips.values())) <= 1e-9


def test_stream_loops_locomotion_longer_than_its_clips(mocap):
    data = _script(mocap, duration=9.0, commands=[{"time": 0.0, "weights": {"walk": 1}}])
    script = S.parse_script(data, mocap, _load)
    ms = S.MotionStream(script)
    span = (ms.registration.times[-1, 0] - ms.registration.times[0, 0]) / script.fps
    out = ms.run()
    assert out.duration > 2.5 * span  # it had to loop at least twice
    assert evaluate.root_jump_m(out, [script.clips["walk"], script.clips["fast"]]) <= 1e-9
    v = _speeds(out)
    assert v.min() > 0.5 * _speeds(script.clips["walk"]).mean()  # keeps walking through the loops


def test_transition_timing_scales_with_the_locomotion_pace(mocap):
    """Issue 18.1 (seed 000 §3.3): a 0.3 s fade is 36 frames of the walk (the reference); from the
    fast walk it lasts 36·r frames, r the fast walk's pace relative to the walk — which equals
    their cadence ratio (steps per second from the feet, an independent measure) to 2 %. Over the
    fade the kick's clock runs between the window's rate (36 / fade frames) and its own, and it
    reaches its last frame exactly when its fade-out ends."""
    from mjmotion import mjcf
    from mjmotion.experiments.timewarp_blend import steps_per_s

    found = {}
    for name in ("walk", "fast"):
        cmds = [{"time": 0.0, "weights": {name: 1}}, {"time": 1.5, "play": "kick", "blend": 0.3}]
        script = S.parse_script(_script(mocap, duration=4.5, commands=cmds), mocap, _load)
        ms = S.MotionStream(script)
        tracks = ms.tracks()
        (t,) = ms.transitions
        kick = tracks[-1]
        assert kick.motion.name == "kick" and t.start == 180 and t.nominal_fade_in == t.nominal_fade_out == 36
        assert t.fade_in == round(36 * t.rate_in) and t.fade_out == round(36 * t.rate_out)
        w = kick.weights / max(kick.weights.max(), 1e-12)
        assert w[t.start + t.fade_in] == pytest.approx(1.0) and w[t.start + t.fade_in - 1] < 1.0
        assert w[t.end] == pytest.approx(0.0, abs=1e-12) and w[t.end - 1] > 0.0
        a = w[t.start + 1]  # the first step of the fade-in: mostly the window's rate
        assert kick.steps[t.start + 1] == pytest.approx(a + (1 - a) * 36 / t.fade_in, rel=1e-9)
        assert kick.times[t.end] == kick.motion.n_frames - 1 and np.all(kick.steps >= 0)
        np.testing.assert_allclose(np.diff(kick.times), kick.steps[1:], atol=1e-12)  # no hidden jump
        found[name] = (t, script.clips[name])
    walk_t, walk = found["walk"]
    fast_t, fast = found["fast"]
    assert walk_t.rate_in == pytest.approx(1.0) and walk_t.fade_in == 36 and walk_t.fade_out == 36
    cadence = [steps_per_s(evaluate.foot_heights_speeds(mjcf.compile(m.skeleton), m)) for m in (walk, fast)]
    assert fast_t.rate_in == pytest.approx(cadence[1] / cadence[0], rel=0.02)
    assert fast_t.fade_in > walk_t.fade_in + 8 and fast_t.fade_out == fast_t.fade_in  # lengthened (46 frames)


@pytest.mark.parametrize(
    "change,message",
    [
        ({"locomotion": ["walk", "jog"]}, "no clip named 'jog'"),
        ({"commands": [{"time": 0, "weights": {"walk": 0.5, "fast": 0.6}}]}, "sum to 1.1"),
        ({"commands": [{"time": 0, "play": "dance"}]}, r"commands\[0\].play"),
        ({"commands": [{"time": -1, "weights": {"walk": 1}}]}, r"commands\[0\].time"),
        ({"duration": "long"}, "script.duration"),
        ({"speed": 2}, "unknown field"),
        ({"commands": [{"time": 0, "weights": {"walk": 1}}, {"time": 7.0, "play": "kick"}]}, r"commands\[1\].time 7: at or after the stream's end"),
        (
            {"commands": [{"time": 1.0, "return": True}, {"time": 0, "weights": {"walk": 1}}]},
            r"commands\[0\]: a return at 1 s with no play before it",
        ),
        (
            {"commands": [{"time": 3.0, "play": "kick"}, {"time": 3.5, "return": True}, {"time": 4.0, "return": True}]},
            r"commands\[2\]: a return at 4 s with no play",
        ),
        ({"commands": [{"time": 2.0, "play": "kick"}, {"time": 1.0, "return": True}]}, r"commands\[1\]: a return at 1 s"),
    ],
)
def test_script_errors_name_the_field(mocap, change, message):
    with pytest.raises(MjmotionError, match=message):
        S.parse_script(_script(mocap, **change), mocap, _load)


def test_a_clips_frames_error_names_its_field_not_an_option(mocap):
    """The loader's error spoke of --frames, which `stream` has not: the field is clips.NAME.frames."""
    data = _script(mocap)
    data["clips"]["kick"]["frames"] = "900000:900100"
    with pytest.raises(MjmotionError, match=r"^script\.clips\.kick\.frames 900000:900100: selects no frames"):
        S.parse_script(data, mocap, _load)


def test_script_with_another_topology_refused(mocap):
    data = _script(mocap)
    data["clips"]["kick"] = {"file": str(mocap / "cmu_cgspeed_daz" / "09_01.bvh")}
    with pytest.raises(MjmotionError, match="topolog"):
        S.parse_script(data, mocap, _load)


def test_cli_stream(mocap, tmp_path):
    script = tmp_path / "s.json"
    data = _script(mocap, duration=2.0, commands=[{"time": 0.0, "weights": {"walk": 1}}, {"time": 0.5, "play": "kick", "blend": 0.3}])
    script.write_text(json.dumps(data))
    out = tmp_path / "s.bvh"
    cmd = [sys.executable, "-m", "mjmotion.cli", "stream", str(script), "-o", str(out), "--json", str(tmp_path / "r.json")]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert bvh.read(str(out)).n_frames == 240
    report = json.loads((tmp_path / "r.json").read_text())
    (t,) = report["transitions"]  # the kick's start, fades and end, in frames and seconds
    assert t["clip"] == "kick" and t["start_frames"] == 60 and t["start_s"] == pytest.approx(0.5)
    assert t["fade_in_frames"] == t["nominal_fade_in_frames"] == 36 and t["rate_in"] == pytest.approx(1.0)
    assert t["end_frames"] == min(t["fade_out_start_frames"] + t["fade_out_frames"], 239)  # the stream ends first
    assert t["end_s"] == pytest.approx(t["end_frames"] / 120.0) and t["fade_out_s"] == pytest.approx(t["fade_out_frames"] / 120.0)
    assert report["blendability"]["fast"]["blendable"] is True
    (tmp_path / "bad.json").write_text("{not json")
    cmd = [sys.executable, "-m", "mjmotion.cli", "stream", str(tmp_path / "bad.json"), "-o", str(tmp_path / "b.bvh")]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 2 and "not valid JSON" in r.stderr


def test_binary_or_deeply_nested_script_is_refused_naming_the_file(tmp_path):
    binary = tmp_path / "binary.json"
    binary.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(MjmotionError, match=r"binary\.json: not a text file \(invalid UTF-8 at byte 128\)"):
        S.load_script(str(binary), _load)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    with pytest.raises(MjmotionError, match=r"deep\.json: JSON nested too deeply"):
        S.load_script(str(deep), _load)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"duration": 1e9}, "script.duration"),
        ({"loop_blend": 1e12}, "script.loop_blend"),
        ({"fps": 1e7}, "script.fps"),
        ({"commands": [{"time": 1e300, "weights": {"walk": 1}}]}, r"script.commands\[0\].time"),
        ({"commands": [{"time": 0, "weights": {"walk": 1}, "ramp": 1e300}]}, r"script.commands\[0\].ramp"),
        ({"commands": [{"time": 0, "play": "kick", "blend": 1e300}]}, r"script.commands\[0\].blend"),
    ],
)
def test_times_beyond_the_memory_limit_are_refused_before_allocating(mocap, change, field):
    """1e9 s would need terabytes: refused while parsing, with the limit and the reason."""
    with pytest.raises(MjmotionError, match=field + r": .* is more than the limit"):
        S.parse_script(_script(mocap, **change), mocap, _load)
    script = S.parse_script(_script(mocap), mocap, _load)
    j = script.clips["walk"].skeleton.n_joints
    assert S.max_frames(j) * S.BYTES_PER_TRACK_FRAME_JOINT * j <= S.MEMORY_LIMIT_BYTES
    assert S.max_frames(j) / 120 > 600  # at least ten minutes of one track at 120 fps fit


def test_a_stream_whose_loops_outgrow_memory_is_refused_while_looping(mocap, monkeypatch):
    """Every loop adds tracks: with room for two, a 9 s walk that loops twice is refused by
    the loop check (before composing) and names the duration."""
    script = S.parse_script(_script(mocap, duration=9.0, commands=[{"time": 0.0, "weights": {"walk": 1}}]), mocap, _load)
    n_out, j = round(9.0 * script.fps), script.clips["walk"].skeleton.n_joints
    monkeypatch.setattr(S, "MEMORY_LIMIT_BYTES", 2 * n_out * j * S.BYTES_PER_TRACK_FRAME_JOINT)
    with pytest.raises(MjmotionError, match=r"script.duration 9 s: composing it needs over .* GiB \(at least 3 source tracks"):
        S.MotionStream(script).tracks()


def test_stream_returns_the_tracks_it_composed(mocap):
    from mjmotion.blend import compose

    cmds = [{"time": 0.0, "weights": {"walk": 1}}, {"time": 0.3, "weights": {"walk": 0.5, "fast": 0.5}, "ramp": 0.4}, {"time": 0.8, "play": "kick"}]
    script = S.parse_script(_script(mocap, duration=2.0, commands=cmds), mocap, _load)
    out, tracks = S.stream(script, "s", with_tracks=True)
    assert isinstance(tracks, tuple) and {tr.motion.name for tr in tracks} == {"walk", "fast", "kick"}
    total = np.sum([tr.weights for tr in tracks], axis=0)
    assert total.shape == (out.n_frames,) and np.allclose(total, 1.0)
    again = compose(list(tracks), script.fps, "s")
    plain = S.stream(script, "s")
    for m in (again, plain):
        assert np.array_equal(m.rotations, out.rotations) and np.array_equal(m.root_positions, out.root_positions)


def test_a_grid_too_large_is_refused_in_the_scripts_words(tmp_path, monkeypatch, capsys):
    """Registration's remedy named register's --frames and --fps, which stream does not have, and not the
    script: stream words it with the script's "fps" and "frames"."""
    import json

    from mjmotion import bvh, synth
    from mjmotion.cli import main
    from mjmotion.registration import grid, pairs

    monkeypatch.setattr(pairs, "check_grid_size", lambda n_a, n_b, max_cells=0: grid.check_grid_size(n_a, n_b, 1000))
    for gait in ("walk", "run"):
        bvh.write(getattr(synth, gait)(seconds=2.0).motion, tmp_path / f"{gait}.bvh")
    script = tmp_path / "s.json"
    clips = {g: {"file": str(tmp_path / f"{g}.bvh")} for g in ("walk", "run")}
    commands = [{"time": 0, "weights": {"walk": 1}}]
    script.write_text(json.dumps({"fps": 60, "duration": 1, "clips": clips, "locomotion": ["walk", "run"], "commands": commands}))
    assert main(["stream", str(script), "-o", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {script}: registering its locomotion clips at 60 fps needs a") and err.count("\n") == 1, err
    assert 'lower the script\'s "fps" at least 4×' in err and "--fps" not in err and "--frames" not in err
    assert not (tmp_path / "o.bvh").exists()


def test_a_script_made_directly_is_checked_and_its_clips_take_its_rate(tmp_path):
    """The Studio and the experiments make a Script without parse_script: a 60 fps walk in a 30 fps
    Script streamed at half its speed, and a negative duration or an unknown clip were raw errors."""
    import dataclasses

    from mjmotion import synth

    walk = synth.walk(seconds=2.0).motion.replace(name="walk")
    script = S.Script({"walk": walk}, ("walk",), (S.Command(0.0, "weights", np.array([1.0])),), 1.5, walk.fps)
    at_30 = dataclasses.replace(script, fps=30.0)
    assert at_30.clips["walk"].fps == 30.0
    speed = [np.linalg.norm(m.root_positions[-1, :2] - m.root_positions[0, :2]) / m.duration for m in (S.stream(script), S.stream(at_30))]
    assert speed[1] == pytest.approx(speed[0], rel=0.05), speed
    for change, message in (
        (dict(duration=-1.0), "Script.duration -1"),
        (dict(fps=float("nan")), "Script.fps: expected a finite number"),
        (dict(locomotion=("nope",)), r"Script.locomotion \('nope',\): expected clip names"),
        (dict(commands=(S.Command(0.0, "play", clip="kick"),)), r"Script.commands\[0\]: plays 'kick'"),
        (dict(commands=(S.Command(0.0, "weights", np.array([1.0, 0.0])),)), r"Script.commands\[0\].weights: expected 1 finite"),
    ):
        with pytest.raises(MjmotionError, match=message):
            dataclasses.replace(script, **change)
