"""Offscreen rendering: the pixels show the ball and feet where the camera model says they are."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjmotion import bvh, kinematics, mjcf, render
from mjmotion.cli import main
from mjmotion.errors import MjmotionError

W, H = 480, 270


@pytest.fixture(scope="module")
def walk():
    from conftest import require_data

    return bvh.read(require_data() / "cmu_asfamc_converted" / "16_15.bvh")[:240]


@pytest.fixture(scope="module")
def swing():
    from conftest import require_data

    return bvh.read(require_data() / "cmu_asfamc_converted" / "64_01.bvh")[300:540]


@pytest.fixture(scope="module")
def gl_works():
    """Skip only if no offscreen GL backend exists on this machine (EGL works on Mesa)."""
    try:
        ctx = render.open_gl_context(16, 16)
    except MjmotionError as e:
        pytest.skip(f"no offscreen OpenGL backend: {e}")
    ctx.free()


def _geom_pos(scene: render.Scene, data: mujoco.MjData, name: str) -> np.ndarray:
    return data.geom_xpos[mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, name)].copy()


def _pixel(img: np.ndarray, px: np.ndarray) -> np.ndarray:
    col, row = int(np.floor(px[0])), int(np.floor(px[1]))
    assert 0 <= col < img.shape[1] and 0 <= row < img.shape[0], f"{px} is outside the image"
    return img[row, col].astype(int)


def test_frame_shows_ball_and_feet_at_their_projected_pixels(gl_works, swing):
    ball = mjcf.Ball(position=(0.45, 0.05, 0.1), radius=0.06)
    bat = mjcf.parse_prop_option(swing.skeleton, "bat")
    actor = render.Actor(swing, "golfer", props=(bat,))
    scene = render.build_scene([actor], fps=30, ball=ball)
    i = 3
    with render.Renderer(scene, 640, 360, labels=False) as r:
        img = r.frame(i)
        cam = r.camera
        data = r.pose(i)
        ball_px, ball_z = cam.project(_geom_pos(scene, data, "ball0")[None])
        feet = np.array([_geom_pos(scene, data, f"c0/foot/{s}") for s in ("left", "right")])
        feet_px, feet_z = cam.project(feet)
        bat_px, _ = cam.project(_geom_pos(scene, data, "c0/bat")[None])
        r.option.geomgroup[1] = 0  # hide the character's bones and feet: floor (and bat, ball) only
        empty = r.frame(i)
    assert ball_z[0] > 0 and np.all(feet_z > 0)
    red = _pixel(img, ball_px[0])
    assert red[0] > 110 and red[0] > 2.5 * red[1] and red[0] > 2.5 * red[2], red
    # four ball radii to the side the pixel is not red: the projection is not merely lucky
    side, _ = cam.project(_geom_pos(scene, data, "ball0")[None] + 4 * ball.radius * np.cross(cam.forward, cam.up))
    other = _pixel(img, side[0])
    assert not (other[0] > 2.5 * other[1] and other[0] > 2.5 * other[2]), other
    for px in feet_px:
        with_feet, floor = _pixel(img, px), _pixel(empty, px)
        assert np.abs(with_feet - floor).sum() > 50, (px, with_feet, floor)
        # the foot boxes are the character's blue, darkened: blue dominates
        assert with_feet[2] > with_feet[0], with_feet
    # the bat's centre is drawn (brown) and stays when the body is hidden
    brown = _pixel(empty, bat_px[0])
    assert brown[0] > brown[2] + 20, brown


def test_projection_matches_rendered_ball_centroid(gl_works, walk):
    """The red blob's centroid is the projected ball centre, within a pixel, at two camera distances."""
    ball = mjcf.Ball(position=(1.0, -0.6, 0.4), radius=0.08)
    for distance in (4.0, 7.0):
        scene = render.build_scene([render.Actor(walk)], fps=30, ball=ball, view=render.View(distance=distance))
        with render.Renderer(scene, W, H, labels=False, shadows=False, reflections=False) as r:
            img = r.frame(0).astype(int)
            px, _ = r.camera.project(_geom_pos(scene, r.pose(0), "ball0")[None])
        # red, including the ball's shaded side (a lit-only mask would pull the centroid toward the light)
        mask = (img[:, :, 0] > 40) & (img[:, :, 0] > 1.8 * img[:, :, 1]) & (img[:, :, 0] > 1.8 * img[:, :, 2])
        rows, cols = np.nonzero(mask)
        assert mask.sum() > 20
        centroid = np.array([cols.mean() + 0.5, rows.mean() + 0.5])
        assert np.linalg.norm(centroid - px[0]) < 0.75, (centroid, px[0])


def test_side_by_side_characters_match_their_own_kinematics(walk, swing):
    a = walk[:120]
    b = walk[60:180].replace(name="later")
    scene = render.build_scene([render.Actor(a, "a"), render.Actor(b, "b")], fps=24, spacing=1.5)
    a24, b24 = a.resample(24), b.resample(24)
    assert scene.n_frames == a24.n_frames
    # the row is laid across the travel direction, centred, 1.5 m apart
    fwd, lat = render.travel_axes(a24)
    assert abs(fwd @ lat) < 1e-12
    np.testing.assert_allclose(scene.offsets[1] - scene.offsets[0], 1.5 * lat, atol=1e-12)
    np.testing.assert_allclose(scene.offsets.sum(axis=0), 0, atol=1e-12)
    d = mujoco.MjData(scene.model)
    for k, m in enumerate((a24, b24)):
        ref = kinematics.forward(mjcf.compile(m.skeleton), m).joint_positions
        ids = [mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_BODY, f"c{k}/{n}") for n in m.skeleton.names]
        for i in (0, m.n_frames // 2, m.n_frames - 1):
            d.qpos[:] = scene.qpos[i]
            mujoco.mj_kinematics(scene.model, d)
            np.testing.assert_allclose(d.xpos[ids], ref[i] + scene.offsets[k], atol=1e-9)


def test_camera_track_has_no_lag_on_steady_travel():
    t = np.arange(300) / 30.0
    line = np.column_stack([1.4 * t, 0.2 * t, np.ones_like(t)])
    smooth = render.smooth_track(line, 30.0, 0.5)
    np.testing.assert_allclose(smooth[70:-70], line[70:-70], atol=1e-9)  # a symmetric kernel keeps a line
    rng = np.random.default_rng(0)
    noisy = line + rng.normal(0, 0.05, line.shape)
    assert np.std(render.smooth_track(noisy, 30.0, 0.5)[70:-70] - line[70:-70]) < 0.2 * 0.05


def test_trails_and_labels_draw_something(gl_works, swing):
    bat = mjcf.parse_prop_option(swing.skeleton, "bat")
    plain = render.build_scene([render.Actor(swing, props=(bat,))], fps=30)
    trail = render.build_scene([render.Actor(swing, "GOLF", props=(bat,), trail=bat.site)], fps=30)
    i = 20
    with render.Renderer(plain, W, H) as r:
        a = r.frame(i).astype(int)
    with render.Renderer(trail, W, H) as r:
        b = r.frame(i).astype(int)
        data = r.pose(i - 5)
        past = data.site_xpos[mujoco.mj_name2id(trail.model, mujoco.mjtObj.mjOBJ_SITE, "c0/" + bat.site)]
        px, _ = r.camera.project(past[None])
    np.testing.assert_allclose(trail.trail_points[0][i - 5], past, atol=1e-12)
    changed = np.abs(a - b).sum(axis=2) > 40
    # a ghost sphere sits where the sweet spot was five frames ago
    c, rr = int(px[0, 0]), int(px[0, 1])
    assert changed[max(rr - 2, 0) : rr + 3, max(c - 2, 0) : c + 3].any()
    assert changed.sum() > 100  # the label and the trail


def test_write_video_mp4_and_gif(gl_works, walk, tmp_path):
    import imageio_ffmpeg
    from PIL import Image

    scene = render.build_scene([render.Actor(walk[:60])], fps=20)  # 0.5 s → 10 frames
    out = render.render(scene, tmp_path / "w.mp4", width=160, height=90, progress=False)
    n, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert n == scene.n_frames == 10
    reader = imageio_ffmpeg.read_frames(str(out))
    assert next(reader)["size"] == (160, 90)
    reader.close()
    gif = render.render(scene, tmp_path / "w.gif", width=96, height=54, frames=slice(2, 8), progress=False)
    with Image.open(gif) as im:
        assert im.size == (96, 54) and im.n_frames == 6
    with pytest.raises(MjmotionError, match="even width"):
        render.render(scene, tmp_path / "odd.mp4", width=161, height=90, progress=False)
    assert not (tmp_path / "odd.mp4").exists()


def test_no_backend_is_a_clear_error():
    with pytest.raises(MjmotionError, match="no offscreen OpenGL backend works"):
        render.open_gl_context(16, 16, backends=("nonexistent",))


def test_cli_render(gl_works, mocap, tmp_path, capsys):
    clip = str(mocap / "cmu_asfamc_converted" / "16_15.bvh")
    out = tmp_path / "two.gif"
    args = ["render", clip, clip, "--labels", "a", "b", "--frames", "0:60", "--fps", "10", "-o", str(out)]
    assert main(args + ["--width", "128", "--height", "72", "--ball", "0.5", "0", "0.1", "--trail"]) == 0
    with __import__("PIL.Image").Image.open(out) as im:
        assert im.size == (128, 72) and im.n_frames == 5
    capsys.readouterr()
    assert main(args) == 2  # exists, no --force
    assert "already exists" in capsys.readouterr().err
    assert main(["render", clip, "--labels", "a", "b", "-o", str(tmp_path / "x.mp4")]) == 2
    assert "one per clip" in capsys.readouterr().err
    assert main(["render", clip, "--trail", "nosuchjoint", "--frames", "0:10", "-o", str(tmp_path / "y.mp4")]) == 2
    assert "nosuchjoint" in capsys.readouterr().err


def test_broken_egl_gives_one_error_line_not_a_traceback(mocap, tmp_path):
    """With EGL's vendor library hidden (libglvnd), the verb fails cleanly or falls back to OSMesa."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, __EGL_VENDOR_LIBRARY_FILENAMES=str(tmp_path / "none.json"))
    env.pop("MUJOCO_GL", None)
    env.pop("PYOPENGL_PLATFORM", None)
    out = tmp_path / "x.gif"
    clip = str(mocap / "cmu_asfamc_converted" / "16_15.bvh")
    cmd = [sys.executable, "-m", "mjmotion.cli", "render", clip, "--frames", "0:20", "-o", str(out), "--width", "32", "--height", "18"]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    if p.returncode == 0:  # EGL still found a driver, or OSMesa took over
        assert out.exists()
    else:
        assert p.returncode == 2, p.stderr
        assert "Traceback" not in p.stderr
        last = p.stderr.strip().splitlines()[-1]
        assert last.startswith("error: no offscreen OpenGL backend works") and "egl:" in last
        assert not out.exists()


def test_contact_shadows_darken_the_floor_under_the_feet_and_nothing_else(gl_works, walk):
    scene = render.build_scene([render.Actor(walk)], fps=30)
    i = 10
    with render.Renderer(scene, W, H, labels=False, contact_shadows=False) as r:
        plain = r.frame(i).astype(int)
        data = r.pose(i)
        feet = np.array([_geom_pos(scene, data, f"c0/foot/{s}") for s in ("left", "right")])
        low = feet[np.argmin(feet[:, 2])]  # the planted foot
        ground_px, _ = r.camera.project(np.array([[low[0], low[1], 0.0]]))
        sky_px, _ = r.camera.project(np.array([[low[0], low[1], 3.0 * walk.skeleton.stature()]]))
    with render.Renderer(scene, W, H, labels=False) as r:  # the default: contact shadows on
        shaded = r.frame(i).astype(int)
    darker = plain.sum(axis=-1) - shaded.sum(axis=-1)
    assert darker.min() >= -3  # a shadow only darkens
    row, col = int(ground_px[0, 1]), int(ground_px[0, 0])
    assert darker[max(row - 3, 0) : row + 4, max(col - 6, 0) : col + 7].max() > 15  # under the planted foot
    assert np.abs(darker[: max(int(sky_px[0, 1]), 1)]).max() <= 3  # the sky above the character: unchanged


def test_cli_render_draws_the_floor_the_judge_uses(gl_works, mocap, tmp_path, capsys, monkeypatch):
    """`render` draws the checker floor where `evaluate` finds it on the same frames: a cgspeed daz
    walk's soles stand above z = 0 (detected), --floor 0 draws z = 0, and a copy lifted 5 cm judged
    against its --source keeps the source's floor (its own is higher), so it floats."""
    import json

    from mjmotion.experiments import corruption

    floors = []
    build = render.build_scene

    def spy(*args, **kwargs):
        floors.append(kwargs.get("floor", 0.0))
        return build(*args, **kwargs)

    def judged(*args):
        out = tmp_path / f"e{len(floors)}_{len(args)}.json"
        assert main(["evaluate", *args, "--frames", "0:120", "--json", str(out)]) == 0
        return json.loads(out.read_text())[0]["report"]

    monkeypatch.setattr(render, "build_scene", spy)
    clip = str(mocap / "cmu_cgspeed_daz" / "07_01.bvh")
    small = ["--frames", "0:120", "--fps", "5", "--width", "32", "--height", "18", "--fast"]
    own = judged(clip)
    assert own["floor_from"] == "detected" and own["floor_m"] > 0.01, own["floor_m"]
    capsys.readouterr()
    assert main(["render", clip, *small, "-o", str(tmp_path / "a.gif")]) == 0
    assert floors[-1] == pytest.approx(own["floor_m"], abs=1e-9)
    assert f"floor {own['floor_m']:+.3f} m (detected)" in capsys.readouterr().out
    assert main(["render", clip, *small, "--floor", "0", "-o", str(tmp_path / "b.gif")]) == 0
    assert floors[-1] == 0.0
    lifted = tmp_path / "lifted.bvh"
    bvh.write(corruption.lifted(bvh.read(clip)), lifted)
    against, alone = judged(str(lifted), "--source", clip), judged(str(lifted))
    assert against["floor_from"] == "source" and alone["floor_m"] - against["floor_m"] > 0.02  # the source: all its frames
    assert main(["render", str(lifted), clip, *small, "--source", clip, "-o", str(tmp_path / "c.gif")]) == 0
    assert floors[-1] == pytest.approx(against["floor_m"], abs=1e-9)
    capsys.readouterr()
    assert main(["render", str(lifted), *small, "--source", str(lifted), "-o", str(tmp_path / "d.gif")]) == 2
    assert "--source" in capsys.readouterr().err


def test_a_tilted_floor_is_drawn_level_with_the_ball_turned_along():
    """With the judge's floor (floor=None), a walk on a floor tilted 1.2° is drawn levelled, as the
    judge measures it, and a ball given in the captured frame is turned with the characters."""
    from mjmotion import floor as floors
    from mjmotion import synth
    from mjmotion.feet import judged_floor, level_motion

    phi = -np.radians(1.2)
    tilt = floors.Level((float(np.cos(phi / 2)), 0.0, float(np.sin(phi / 2)), 0.0), (0.0, 0.0, 0.0), 1.2)
    tilted = level_motion(tilt, synth.walk(seconds=4.0).motion)
    judged = judged_floor(tilted)
    assert judged.level.tilt_deg == pytest.approx(1.2, abs=0.1)
    ball = mjcf.Ball(position=(4.0, 0.0, 0.2))
    scene = render.build_scene([render.Actor(tilted)], fps=30.0, ball=ball, floor=None)
    placed = scene.model.body("ball0").pos + [0.0, 0.0, judged.height]
    assert np.allclose(placed, judged.level.positions(np.asarray(ball.position)), atol=1e-9)
    assert abs(placed[2] - ball.position[2]) > 0.02  # 1.4 m from the stance centre along a 1.2° floor: turned, not left where given


def test_the_bundled_walk_is_drawn_with_its_planted_feet_on_the_floor():
    """On the judge's floor (floor=None) the drawn feet are the judge's soles (feet.judged_model), so
    every foot the bundled walk plants (its ground truth) touches the drawn floor (< 0.5 mm) and none
    sinks below it; that floor is z = 0, where the walk was made to stand (humanoid.sole_depth)."""
    from mjmotion import synth

    clip = synth.walk(seconds=3.0)
    scene = render.build_scene([render.Actor(clip.motion)], fps=clip.motion.fps, floor=None)
    assert scene.qpos.shape[0] == clip.motion.n_frames
    data = mujoco.MjData(scene.model)
    low = np.empty((clip.motion.n_frames, 2))
    for t in range(clip.motion.n_frames):
        data.qpos[:] = scene.qpos[t]
        mujoco.mj_kinematics(scene.model, data)
        for f, side in enumerate(("left", "right")):
            g = [mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, f"c0/{part}/{side}") for part in ("foot", "toe")]
            low[t, f] = min(data.geom_xpos[k, 2] - np.abs(data.geom_xmat[k].reshape(3, 3)[2]) @ scene.model.geom_size[k] for k in g)
    assert np.abs(low[clip.contacts]).max() < 5e-4, np.abs(low[clip.contacts]).max()
    assert low.min() > -5e-4


def test_render_settings_that_are_no_setting_are_refused_before_drawing():
    """A NaN camera distance or a zero field of view gave an all-black video, a smoothing of 1e9 s a
    MemoryError, a bad colour or width a raw TypeError/ValueError, samples=-1 MuJoCo's FatalError, and a
    Motion passed for an Actor an AttributeError; 17 characters and 1000 fps were taken."""
    from mjmotion import synth

    walk = synth.walk(seconds=0.5).motion
    nan = float("nan")
    for kwargs, message in (
        (dict(distance=nan), "View distance=nan"),
        (dict(distance=0.0), "View distance=0.0"),
        (dict(fovy=0.0), "View fovy=0.0"),
        (dict(smoothing=1e9), "View smoothing=1000000000.0"),
        (dict(elevation=120.0), "View elevation=120.0"),
    ):
        with pytest.raises(MjmotionError, match=message):
            render.View(**kwargs)
    with pytest.raises(MjmotionError, match="Actor color: expected 3 finite numbers"):
        render.Actor(walk, color=(2.0, 0.0))
    with pytest.raises(MjmotionError, match="Actor color: expected 3 numbers from 0 to 1"):
        render.Actor(walk, color=(2.0, 0.0, 0.0))
    with pytest.raises(MjmotionError, match="expected a list of render.Actor"):
        render.build_scene([walk])
    with pytest.raises(MjmotionError, match="17 characters; at most 16"):
        render.build_scene([render.Actor(walk)] * 17)
    with pytest.raises(MjmotionError, match="fps 1000: expected a video frame rate from 1 to 240"):
        render.build_scene([render.Actor(walk)], fps=1000)
    scene = render.build_scene([render.Actor(walk)], fps=10)
    for kwargs, message in ((dict(width=nan), "width nan"), (dict(samples=-1), "samples -1"), (dict(trail_seconds=nan), "trail_seconds nan")):
        with pytest.raises(MjmotionError, match=message):
            render.Renderer(scene, **kwargs)
