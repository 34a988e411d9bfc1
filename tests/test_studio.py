"""The Studio's engine without a browser: clips and uploads, the worker, playback, saving, the
geoms it draws, its adapters, and the ``studio`` verb's start, URL, warning and shutdown."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import random_motion, random_skeleton

from mjmotion import bvh, hitpoint, kinematics, mjcf, synth
from mjmotion import rotations as rot
from mjmotion.errors import MjmotionError
from mjmotion.studio import engine
from mjmotion.studio.clips import MAX_CLIP_BYTES, ClipLibrary
from mjmotion.studio.jobs import Worker
from mjmotion.studio.player import Player
from mjmotion.studio.scene import GeomLayout, Kinematics
from mjmotion.studio.session import save_path

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def walk():
    return synth.walk().motion.replace(name="walk")


# --- clips ----------------------------------------------------------------------------------
def test_upload_goes_through_the_bvh_reader_and_a_size_limit(walk):
    lib = ClipLibrary([])
    with pytest.raises(MjmotionError, match=r"bad\.bvh:\d+"):
        lib.with_upload("bad.bvh", b"HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    with pytest.raises(MjmotionError, match="MiB limit"):
        lib.with_upload("big.bvh", b" " * (MAX_CLIP_BYTES + 1))
    lib2, clip = lib.with_upload("../../etc/walk.bvh", bvh.format_motion(walk).encode())
    assert clip.name == "walk" and clip.source is None and lib.names() == [] and lib2.names() == ["walk"]
    _, again = lib2.with_upload("walk.bvh", bvh.format_motion(walk).encode())
    assert again.name == "walk_2"
    np.testing.assert_allclose(clip.motion.root_positions, walk.root_positions, atol=1e-6)


def test_library_reads_only_the_given_files_and_data_folder(tmp_path, walk):
    (tmp_path / "sub").mkdir()
    bvh.write(walk, tmp_path / "a.bvh")
    bvh.write(walk, tmp_path / "sub" / "a.bvh")
    (tmp_path / "notes.txt").write_text("not a clip")
    lib = ClipLibrary.from_paths([], str(tmp_path))
    assert lib.names() == ["a", "a_2"] and {p.name for p in lib.inputs()} == {"a.bvh"}
    assert ClipLibrary.from_paths([]).names() == list(synth.library())
    (tmp_path / "empty").mkdir()
    with pytest.raises(MjmotionError, match="no .bvh files"):
        ClipLibrary.from_paths([], str(tmp_path / "empty"))
    with pytest.raises(MjmotionError, match="not a folder"):
        ClipLibrary.from_paths([], str(tmp_path / "missing"))


def test_library_leaves_out_a_leading_t_pose_as_the_verbs_do(mocap, tmp_path, capsys):
    """A daz clip opens without its T-pose (frames 0-3), so the Evaluate tab reads what `mjmotion evaluate` prints;
    --keep-start keeps it, and an upload is read the same way."""
    import json

    from mjmotion.cli import main

    path = mocap / "cmu_cgspeed_daz" / "07_01.bvh"
    clip = ClipLibrary.from_paths([str(path)]).get("07_01")
    raw = bvh.read(path)
    assert clip.skipped == 4 and clip.motion.n_frames == raw.n_frames - 4
    np.testing.assert_allclose(clip.motion.root_positions, raw.root_positions[4:])
    assert main(["evaluate", str(path), "--json", str(tmp_path / "e.json")]) == 0
    (entry,) = json.loads((tmp_path / "e.json").read_text())
    cli = entry["report"]
    rows = dict(engine.evaluate(clip.motion).rows)
    for key in ("n_frames", "planted_skate_mm_per_s", "max_joint_speed_rad_s", "physics_violation_ratio"):
        assert rows[key] == pytest.approx(cli[key], rel=1e-9), key
    kept = ClipLibrary.from_paths([str(path)], keep_start=True).get("07_01")
    assert kept.skipped == 0 and kept.motion.n_frames == raw.n_frames
    _, up = ClipLibrary([]).with_upload("07_01.bvh", path.read_bytes())
    assert up.skipped == 4 and up.motion.n_frames == clip.motion.n_frames
    assert main(["studio", str(path), "--check"]) == 0
    assert "07_01.bvh: skipped frames 0-3" in capsys.readouterr().err


def test_the_studio_reads_clips_with_units_and_up_as_the_verbs_do(tmp_path, capsys):
    """A clip too small to guess its unit: the Studio's error said "give it with --units", an option it did
    not have. It has --units and --up now, for its files and its uploads, as every verb reads them."""
    from mjmotion import synth
    from mjmotion.cli import main

    walk = synth.walk(seconds=1.0).motion
    bvh.write(walk, tmp_path / "walk.bvh")
    tiny = tmp_path / "tiny.bvh"  # its lengths a thousandth of the walk's centimetres: 0.17 units tall
    assert main(["convert", str(tmp_path / "walk.bvh"), str(tiny), "--scale", "1e-3"]) == 0
    assert main(["studio", str(tiny), "--check"]) == 2
    assert "give it with --units" in capsys.readouterr().err
    assert main(["studio", str(tiny), "--check", "--units", "10"]) == 0
    lib = ClipLibrary.from_paths([str(tiny)], scale=10.0)
    np.testing.assert_allclose(lib.get("tiny").motion.root_positions, walk.root_positions, atol=1e-6)
    _, up = lib.with_upload("again.bvh", tiny.read_bytes())
    np.testing.assert_allclose(up.motion.root_positions, walk.root_positions, atol=1e-6)


def test_studio_check_says_what_the_verbs_say_of_the_same_clips(tmp_path, capsys):
    """--check said "1 clips ready" of a skeleton too deep for any model, printed a name's terminal escape,
    gave no note for a wrong --up or --units, and passed a --host the server then refused."""
    from mjmotion import synth
    from mjmotion.cli import main

    walk = tmp_path / "we\x1b[31mird.bvh"
    bvh.write(synth.walk(seconds=1.0).motion, walk)
    assert main(["studio", str(walk), "--check"]) == 0
    out = capsys.readouterr().out
    assert out.strip() == "mjmotion studio: 1 clip ready: we\\x1b[31mird", out
    assert main(["studio", str(walk), "--check", "--up", "z"]) == 0
    assert "not +Z as --up z reads them" in capsys.readouterr().err
    assert main(["studio", str(walk), "--check", "--units", "m"]) == 0
    assert "stature 1" in capsys.readouterr().err  # (a centimetre walk read in metres: a person 170 m tall)
    n = 300  # deeper than MuJoCo models go here
    text = "HIERARCHY\nROOT J0\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    text += "".join(f"JOINT J{i}\n{{\nOFFSET 0.1 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for i in range(1, n))
    text += "End Site\n{\nOFFSET 0.1 0 0\n}\n" + "}\n" * n + "MOTION\nFrames: 3\nFrame Time: 0.0333333\n" + ("0 0 0 " * (n + 1) + "\n") * 3
    (tmp_path / "deep.bvh").write_text(text)
    assert main(["studio", str(tmp_path / "deep.bvh"), "--check"]) == 2
    assert "joints deep" in capsys.readouterr().err
    assert main(["studio", str(walk), "--check", "--host", "not a host!"]) == 2
    assert "--host not a host!: not an address" in capsys.readouterr().err
    import socket

    with socket.socket() as busy:  # a studio already running there: --check binds nothing, so it checks the clips
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        assert main(["studio", str(walk), "--check", "--port", str(busy.getsockname()[1])]) == 0


def test_the_tabs_first_pair_is_of_one_skeleton(mocap):
    """A folder of two skeletons opens with a pair the Blend and Stream tabs can use (it opened on a walk of one
    skeleton and a run of another: an error before the user did anything)."""
    from mjmotion.studio.tabs import partner

    lib = ClipLibrary.from_paths(
        [str(mocap / p) for p in ("cmu_asfamc_converted/16_15.bvh", "cmu_cgspeed_daz/02_03.bvh", "cmu_asfamc_converted/10_01.bvh")]
    )
    assert partner(lib, "16_15", "run", "turn") == "10_01"  # no run of its skeleton: another of its clips
    assert partner(lib, "16_15", "run", "turn", default="—") == "—"
    assert partner(lib, "02_03", "walk") is None


def test_travel_reads_a_known_root_path():
    """A root moving 1.2 m/s straight reads 1.2 m/s and no turn; one turning a quarter circle, 90°."""
    from mjmotion.studio.tabs import travel

    rng = np.random.default_rng(0)
    m = random_motion(rng, random_skeleton(rng, 4), 241).replace(fps=120.0)
    t = np.arange(241) / m.fps
    straight = m.replace(root_positions=np.column_stack([1.2 * t, 0.3 + 0 * t, 0.9 + 0 * t]))
    speed, turn = travel(straight)
    assert speed == pytest.approx(1.2, rel=1e-6) and turn == pytest.approx(0.0, abs=1e-6)
    a = 0.5 * np.pi * t / t[-1]  # a quarter circle of radius 2 m
    arc = m.replace(root_positions=np.column_stack([2 * np.sin(a), 2 - 2 * np.cos(a), 0.9 + 0 * t]))
    speed, turn = travel(arc)
    assert speed == pytest.approx(np.pi / t[-1], rel=5e-3) and turn == pytest.approx(90.0 - 45.0 / 2, abs=1.0)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a clip shorter than one 0.25 s sample divided 0 by 0
        assert travel(straight[:20]) == (0.0, 180.0) and travel(straight[:1]) == (0.0, 180.0)


def test_numbered_clips_open_on_a_straight_walk_and_a_faster_gait(mocap):
    """CMU trials are numbered, so the Blend and Stream tabs opened on the first two files of a folder (the
    kicks 10_01 and 10_02 of the ASF folder: a kick as the stream's locomotion). By gait: the straight walk
    16_15 (not the kick, nor the veering 16_12) and the fastest clip of its skeleton, 16_24."""
    from types import SimpleNamespace

    from mjmotion.studio.tabs import NONE, faster, walking
    from mjmotion.studio.tabs.blend import BlendTab
    from mjmotion.studio.tabs.stream import StreamTab

    asf = mocap / "cmu_asfamc_converted"
    lib = ClipLibrary.from_paths([str(asf / f"{n}.bvh") for n in ("10_01", "16_12", "16_15", "16_24")])
    assert walking(lib) == "16_15" and faster(lib, "16_15") == "16_24" and faster(lib, "16_24") is None

    class Widget(SimpleNamespace):
        def __getattr__(self, name):  # on_update, on_click, on_trigger: callbacks are not run here
            return lambda *a, **k: None

    def add(*args, initial_value=None, **kw):
        return Widget(value=initial_value, visible=kw.get("visible", True))

    gui = SimpleNamespace(**{f"add_{w}": add for w in ("dropdown", "slider", "button", "markdown", "image", "command", "checkbox", "number", "text")})
    session = SimpleNamespace(client=SimpleNamespace(gui=gui), library=lib, on_library=lambda f: None)
    assert [d.value for d in BlendTab(session).clips] == ["16_15", "16_24", NONE]
    assert [d.value for d in StreamTab(session).loco] == ["16_15", "16_24", NONE]


# --- worker ---------------------------------------------------------------------------------
def test_worker_latest_request_wins_cancel_and_errors_keep_it_running():
    done, errors, started = [], [], threading.Event()
    w = Worker(lambda job, f, t: None, lambda job, msg: errors.append(msg))
    gate = threading.Event()

    def slow(progress):
        started.set()
        while not gate.is_set():
            progress(0.5, "waiting")  # a checkpoint: raises once cancelled
            time.sleep(0.01)
        return "slow"

    w.submit("drag", slow, done.append)
    started.wait(5)
    for k in range(5):  # a drag: only the last request may be delivered
        w.submit("drag", lambda p, k=k: k, done.append)
    gate.set()
    assert w.wait_idle(10)
    assert done == [4]
    w.submit("x", lambda p: (_ for _ in ()).throw(MjmotionError("bad input")), done.append)
    w.submit("y", lambda p: 1 / 0, done.append)
    assert w.wait_idle(10)
    assert errors[0] == "bad input" and "ZeroDivisionError" in errors[1]
    w.submit("z", lambda p: "still serving", done.append)
    assert w.wait_idle(10) and done[-1] == "still serving"
    # keep_running: the running job (a solve that cannot stop part-way) is delivered, the waiting one replaced
    gate.clear()
    started.clear()
    w.submit("drag", slow, done.append)
    started.wait(5)
    w.submit("drag", lambda p: "dropped", done.append, keep_running=True)
    w.submit("drag", lambda p: "latest", done.append, keep_running=True)
    gate.set()
    assert w.wait_idle(10) and done[-2:] == ["slow", "latest"]
    w.stop()


# --- playback and saving --------------------------------------------------------------------
def test_player_plays_loops_steps_and_stops():
    p = Player(10, 10.0)
    assert p.tick(0.55) == 5
    assert p.tick(0.6) == 1  # wrapped
    p.loop = False
    p.playing = True
    assert p.tick(5.0) == 9 and not p.playing
    assert p.step(-3) == 6 and p.seek(99) == 9


def test_save_stays_in_its_folder_and_never_overwrites(tmp_path, walk):
    src = tmp_path / "out" / "walk.bvh"
    src.parent.mkdir()
    bvh.write(walk, src)
    assert save_path(tmp_path / "out", "result.bvh", [src]) == (tmp_path / "out" / "result.bvh").resolve()
    for bad in ("../escape.bvh", "sub/x.bvh", "x.txt", "", ".hidden.bvh"):
        with pytest.raises(MjmotionError, match="plain file name"):
            save_path(tmp_path / "out", bad, [])
    with pytest.raises(MjmotionError, match="is an input"):
        save_path(tmp_path / "out", "walk.bvh", [src])
    (tmp_path / "out" / "taken.bvh").write_text("x")
    with pytest.raises(MjmotionError, match="already exists; the studio never replaces"):
        save_path(tmp_path / "out", "taken.bvh", [])


# --- drawing --------------------------------------------------------------------------------
def test_drawn_primitives_are_the_models_geoms(walk):
    clip = synth.drive()
    compiled = mjcf.compile(clip.motion.skeleton, (clip.prop,))
    q = kinematics.qpos(compiled, clip.motion)[clip.hit_frame]
    pose = Kinematics(compiled).pose(q)
    layout = GeomLayout.of(compiled, (1, 2, 3))
    inst = layout.instances(pose)
    # an independent path: MuJoCo's own geom frames (mj_forward, geom_xmat)
    d = mujoco.MjData(compiled.model)
    d.qpos[:] = q
    mujoco.mj_forward(compiled.model, d)
    m = compiled.model
    caps = np.flatnonzero(m.geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE)
    ends = np.r_[
        d.geom_xpos[caps] + d.geom_xmat[caps].reshape(-1, 3, 3)[:, :, 2] * m.geom_size[caps, 1:2],
        d.geom_xpos[caps] - d.geom_xmat[caps].reshape(-1, 3, 3)[:, :, 2] * m.geom_size[caps, 1:2],
    ]
    np.testing.assert_allclose(inst["sphere"][0][: len(ends)], ends, atol=1e-12)
    np.testing.assert_allclose(rot.to_matrix(inst["box"][1]), d.geom_xmat[layout.boxes].reshape(-1, 3, 3), atol=1e-12)
    np.testing.assert_allclose(inst["cylinder"][0], d.geom_xpos[layout.cylinders], atol=1e-12)
    assert len(inst["box"][0]) == sum(len(g) for g in compiled.foot_geoms.values())
    # every geom but the floor is drawn: capsules (bones, the bat) as cylinders, boxes, spheres
    assert len(layout.cylinders) + len(layout.boxes) + len(layout.balls) == m.ngeom - 1
    np.testing.assert_allclose(layout.scales()["cylinder"][:, 2], 2 * m.geom_size[layout.cylinders, 1])


# --- adapters -------------------------------------------------------------------------------
def test_blend_adapter_two_clips_matches_the_registered_blend(walk):
    from mjmotion import blend

    run = synth.run().motion.replace(name="run")
    res = engine.make_blend([walk, run], [0.5, 0.5], "B-spline timewarp", "dp")
    ref = blend.blend([walk, run], [0.5, 0.5])  # the blend verb's own registration (register_many: DP, B-spline)
    np.testing.assert_allclose(res.motion.root_positions, ref.root_positions, atol=1e-9)
    assert res.grid.shape == (walk.n_frames, run.n_frames) and res.input_frames.shape == (res.motion.n_frames, 2)
    assert np.all(np.diff(res.input_frames, axis=0) > 0)  # both inputs move forward at registered frames
    thr = engine.make_blend([walk, run], [0.5, 0.5], "discrete timewarp", "threshold", threshold=1.0)
    np.testing.assert_array_equal(thr.path, res.path)  # a threshold of 1 prunes nothing: the DP optimum


def test_hit_adapter_reaches_the_ball_and_simulates_its_flight():
    clip = synth.drive()
    s = engine.shot(clip.motion, clip.prop, clip.hit_frame)
    target = s.source_point + np.array([0.0, 0.05, 0.08])
    # a drag's preview: a few frames solved from the shot's set-up, the bat still meets the ball
    seen = []
    pv = engine.adapt(s, target, "dls", preview=True, progress=lambda f, t: seen.append(t))
    assert pv.report["preview_frames"] <= engine.PREVIEW_FRAMES + 3 < int((s.problem.blend > 0).sum())
    assert seen and all("preview" in t for t in seen)
    a = engine.adapt(s, target, "dls")
    for r in (pv, a):
        spot = kinematics.forward(mjcf.compile(r.motion.skeleton, (clip.prop,)), r.motion).site("bat/sweet_spot")[s.hit_frame]
        assert np.linalg.norm(spot - target) < 1e-3
    assert "preview_frames" not in a.report and not np.array_equal(pv.motion.rotations, a.motion.rotations)
    # the release at the spot the drag solved reuses that solve and adds the style error; it is `mjmotion hit --solver dls`'s answer
    released = engine.adapt(s, target, "dls", style=True)
    full = hitpoint.adapt(clip.motion, target=target, frame=s.hit_frame, effector=s.effector, solver="dls", prop=s.prop, style=True)
    assert released.motion is a.motion and a.report["style_rmse"] is None
    np.testing.assert_array_equal(released.motion.rotations, full.motion.rotations)
    drop = lambda r: {k: v for k, v in r.items() if k != "solve_s_per_frame"}
    assert drop(released.report) == drop(full.report)
    f = engine.launch(s, a.motion, target)
    assert f.metrics["contact"] and f.metrics["launch_speed"] > 1.0
    assert f.path[-1, 2] == pytest.approx(0.036, abs=0.01)  # it comes to rest on the floor
    d0 = f.path[1] - f.path[0]
    az = np.degrees(np.arctan2(d0[1], d0[0]))
    assert az == pytest.approx(f.metrics["launch_azimuth_deg"], abs=1.0)


# --- the verb -------------------------------------------------------------------------------
def _default_sigint() -> None:
    # A shell without job control starts a background job (`pytest … &`) with SIGINT ignored, and a
    # child keeps an ignored SIGINT: the studio would then rightly not stop on Ctrl-C. Give it the default.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _studio(*args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    # -X faulthandler: a studio that hangs can be made to print every thread's stack (_stacks)
    return subprocess.Popen(
        [sys.executable, "-X", "faulthandler", "-m", "mjmotion.cli", "studio", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=ROOT,
        preexec_fn=_default_sigint,
    )


def _stacks(p: subprocess.Popen) -> str:
    """A hung studio's thread stacks (SIGABRT makes its fault handler print them), for the failure message."""
    p.send_signal(signal.SIGABRT)
    try:
        return p.communicate(timeout=10)[1][-8000:]
    except subprocess.TimeoutExpired:
        return "(no stacks: the process did not answer SIGABRT)"


def _free_port(host: str) -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def test_studio_verb_serves_its_url_and_stops_cleanly_on_ctrl_c(tmp_path):
    port = _free_port("127.0.0.2")  # the verb takes ports 1-65535 (0 is refused)
    p = _studio("--port", str(port), "--host", "127.0.0.2", "--out", str(tmp_path))
    try:
        line = p.stdout.readline()
        assert line.startswith(f"mjmotion studio: http://127.0.0.2:{port}")
        url = line.split()[2]
        html = urllib.request.urlopen(url, timeout=10).read()
        assert b"<html" in html.lower()
        start = time.perf_counter()
        p.send_signal(signal.SIGINT)
        try:
            code = p.wait(10)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the studio did not stop within 10 s of Ctrl-C; its threads:\n{_stacks(p)}")
        assert code == 0
        assert time.perf_counter() - start < 5.0
        err = p.stderr.read()
        assert err.startswith("warning: listening on 127.0.0.2") and "error" not in err
    finally:
        p.kill()


def test_studio_verb_port_in_use_is_one_error_line():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        p = _studio("--port", str(port))
        out, err = p.communicate(timeout=60)
    assert p.returncode == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: --port {port}:")


@pytest.mark.parametrize(
    ("host", "why"), [("", "expected HOST, not an empty value"), ("999.1.1.1", "not an address"), ("10.99.99.99", "not an address of this machine")]
)
def test_studio_verb_bad_host_is_one_error_line_naming_it(host, why):
    """An empty --host listened on every network (viser's default); a host this machine has not was
    blamed on --port, after a warning that it listened there."""
    p = _studio("--port", str(_free_port("127.0.0.1")), "--host", host)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: --host {host}") and why in err, err


def test_the_evaluate_tabs_marks_measure_from_the_judges_floor():
    """The timeline's penetration marks use the judge's floor, as the report's penetrate_mm does: a
    walk sunk 5 cm on its own has a detected floor 5 cm lower and nothing in it; a 3 cm dip of the
    root over six frames marks those frames (measured from z = 0 the sunk walk was all red)."""
    walk = synth.walk(seconds=2.0).motion
    sunk = walk.replace(root_positions=walk.root_positions - [0.0, 0.0, 0.05])
    e = engine.evaluate(sunk)
    assert not e.penetrating.any() and dict(e.rows)["penetrate_mm"] < 1.0
    root = walk.root_positions.copy()
    root[60:66, 2] -= 0.03
    dipped = engine.evaluate(walk.replace(root_positions=root))
    assert dipped.penetrating[60:66].all() and dipped.penetrating.sum() <= 6
