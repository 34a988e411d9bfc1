"""The foundation verbs end to end: info, convert, compile, fk."""

from __future__ import annotations

import json
import os

import mujoco
import numpy as np
import pytest

from mjmotion import bvh, kinematics, mjcf
from mjmotion.cli import main


@pytest.fixture
def walk(mocap):
    return mocap / "cmu_asfamc_converted" / "16_15.bvh"


def test_info_json_describes_the_clip(walk, capsys):
    assert main(["info", str(walk), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["joints"] == 31 and d["frames"] == 471 and d["fps"] == pytest.approx(120.0, rel=1e-5)
    assert d["scale_m_per_unit"] == 0.01
    assert d["joint_list"][0]["channels"][:3] == ["Xposition", "Yposition", "Zposition"]


def test_info_table_is_readable(walk, capsys):
    assert main(["info", str(walk)]) == 0
    out = capsys.readouterr().out
    assert "471 at 120 fps" in out and "Zrotation Yrotation Xrotation" in out
    # the head, feet and hands found by name, as the README's verb table says
    assert "  head        head\n" in out and "  feet        left lfoot → ltoes, right rfoot → rtoes\n" in out and "  hands       left lwrist" in out


def test_fk_npz_matches_kinematics(walk, tmp_path):
    out = tmp_path / "fk.npz"
    assert main(["fk", str(walk), "-o", str(out), "--keep-start"]) == 0  # every frame of the file
    z = np.load(out)
    m = bvh.read(walk)
    assert list(z["joint_names"]) == list(m.skeleton.names)
    assert z["positions"].shape == (m.n_frames, m.skeleton.n_joints, 3)
    assert np.allclose(z["positions"], kinematics.joint_positions(m))
    assert float(z["fps"]) == pytest.approx(m.fps)


def test_fk_with_prop_exports_sites(walk, tmp_path):
    out = tmp_path / "fk.npz"
    assert main(["fk", str(walk), "--prop", "bat:rwrist", "-o", str(out)]) == 0
    z = np.load(out)
    assert list(z["site_names"]) == ["bat/grip", "bat/sweet_spot", "bat/tip"]
    grip, sweet = z["site_positions"][:, 0], z["site_positions"][:, 1]
    assert np.allclose(np.linalg.norm(sweet - grip, axis=1), mjcf.PROP_PRESETS["bat"]["sweet_spot"])


def test_compile_writes_loadable_model(walk, tmp_path):
    out = tmp_path / "m.xml"
    assert main(["compile", str(walk), "-o", str(out), "--prop", "club:rwrist", "--ball"]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "club/sweet_spot") >= 0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "ball") >= 0


def test_compile_keyframe_skips_a_leading_t_pose(mocap, tmp_path, capsys):
    """The keyframe is the clip's first frame as every verb reads it: daz 07_01's frames 0-3 are a T-pose."""
    src = mocap / "cmu_cgspeed_daz" / "07_01.bvh"
    m = bvh.read(src)
    keys = {}
    for extra in ([], ["--keep-start"]):
        out = tmp_path / f"m{len(extra)}.xml"
        assert main(["compile", str(src), "-o", str(out), *extra]) == 0
        keys[bool(extra)] = mujoco.MjModel.from_xml_path(str(out)).key_qpos[0]
    assert "skipped frames 0-3" in capsys.readouterr().err
    compiled = mjcf.compile(m.skeleton)
    t_pose, fourth = kinematics.qpos(compiled, m[:1])[0], kinematics.qpos(compiled, m[4:5])[0]
    assert np.allclose(keys[True][3:], t_pose[3:]) and np.allclose(keys[False][3:], fourth[3:])  # (the root is moved to stand on the floor)
    assert not np.allclose(keys[False][3:], keys[True][3:], atol=1e-3)


@pytest.mark.parametrize(
    ("prop", "other"),
    [
        # A one-word --prop is the same prop in every verb: evaluate finds the club of `hit`'s result on
        # the ball it was sent to (it attached a club along the right wrist before, 0.55 m from the ball).
        (None, "club:rwrist"),
        # `hit --prop club:JOINT` was refused (hit took a kind alone), though the README gives --prop one
        # meaning in every verb: hit moves the club along lwrist's bone, and evaluate finds it there.
        ("club:lwrist", "club"),
    ],
)
def test_evaluate_measures_the_prop_hit_moved(mocap, tmp_path, capsys, prop, other):
    out, rep = tmp_path / "h.bvh", tmp_path / "h.json"
    given = ["--prop", prop] if prop else []
    swing = str(mocap / "cmu_asfamc_converted" / "64_01.bvh")
    assert main(["hit", swing, *given, "--offset", "0", "0.1", "0", "-o", str(out), "--json", str(rep)]) == 0
    r = json.loads(rep.read_text())
    capsys.readouterr()
    assert r["hit_error_m"] < 1e-4
    ev_json = tmp_path / "e.json"
    args = ["evaluate", str(out), "--ball", *map(str, r["target"]), "--frame", str(r["hit_frame"]), "--json", str(ev_json)]
    assert main([*args, "--prop", prop or "club"]) == 0
    hit = json.loads(ev_json.read_text())[0]["report"]["hit"]
    assert hit["contact"] and abs(hit["hit_error_m"]) < 0.05, hit
    assert main([*args, "--prop", other, "--force"]) == 0  # another club (along a bone, or fitted to both hands)
    assert not json.loads(ev_json.read_text())[0]["report"]["hit"]["contact"]


def test_convert_scale_fps_frames_keep_the_motion(walk, tmp_path):
    out = tmp_path / "c.bvh"
    assert main(["convert", str(walk), str(out), "--scale", "0.01", "--fps", "60", "--frames", "100:300"]) == 0
    a = bvh.read(walk)[100:300]
    b = bvh.read(out)
    assert b.skeleton.scale == 1.0  # written in metres now
    assert b.n_frames == 100 and b.fps == pytest.approx(60.0)
    pa = kinematics.joint_positions(a)[::2]
    pb = kinematics.joint_positions(b)
    # The file's frame time is 0.00833333 s, not 1/120: 60 fps samples drift by < 1e-4 frames.
    assert np.abs(pa - pb).max() < 1e-5
    assert "OFFSET" in out.read_text() and "Frame Time: 0.016666666666666666" in out.read_text()


def test_convert_refuses_a_scale_whose_file_no_units_reads_at_its_size(walk, tmp_path, capsys):
    # --scale 1e6 of a centimetre file wrote 1e-8 m per unit: read back at its size it needs --units 1e-8, below 1e-6.
    unit = bvh.read(walk).skeleton.scale
    out = tmp_path / "big.bvh"
    for scale in (1e6, 1e-6):
        assert main(["convert", str(walk), str(out), "--scale", f"{scale:g}"]) == 2
        errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and errors[0].startswith(f"error: --scale {scale:g}: the written file's unit would be ") and not out.exists()
    assert main(["convert", str(walk), str(out), "--scale", f"{unit / 1e-6:g}"]) == 0  # the largest: read with --units 1e-6
    capsys.readouterr()
    a, b = bvh.read(walk), bvh.read(out, scale=1e-6)
    assert b.skeleton.stature() == pytest.approx(a.skeleton.stature(), rel=1e-6)


def test_outputs_are_protected(walk, tmp_path, capsys):
    out = tmp_path / "o.bvh"
    out.write_text("precious")
    assert main(["convert", str(walk), str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert out.read_text() == "precious"
    assert main(["convert", str(walk), str(walk), "--force"]) == 2
    assert "is an input" in capsys.readouterr().err
    assert main(["convert", str(walk), str(out), "--force"]) == 0
    assert out.read_text().startswith("HIERARCHY")


def test_bad_frames_and_missing_file_are_one_line_errors(walk, tmp_path, capsys):
    assert main(["convert", str(walk), str(tmp_path / "x.bvh"), "--frames", "900:1000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: --frames 900:1000")
    assert main(["info", str(tmp_path / "missing.bvh")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "missing.bvh" in err and "Traceback" not in err


def test_words_no_option_took_point_at_the_verbs_help(walk, tmp_path, capsys):
    """Extra words are reported by the verb's parser; numbers after a comma-list option get its spelling."""
    assert main(["info", str(walk), "extra"]) == 2
    assert capsys.readouterr().err == "error: unrecognized arguments: extra (see 'mjmotion info --help')\n"
    assert main(["blend", str(walk), str(walk), "--weights", "0.5", "0.5", "-o", str(tmp_path / "b.bvh")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--weights takes one comma-separated list (W1,W2[,...])" in err and "'mjmotion blend --help'" in err
    assert main(["--bogus"]) == 2 and "(see 'mjmotion --help')" in capsys.readouterr().err
    assert not (tmp_path / "b.bvh").exists()


#: Libraries a verb loads only when it runs (each costs 0.1–0.5 s of start-up).
HEAVY = ("mujoco", "scipy", "casadi", "matplotlib", "numba")


def _loaded_after(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; it sets ``out`` (a dict) from ``heavy()``, printed as JSON."""
    import subprocess
    import sys

    prelude = f"import json, sys\nHEAVY = {HEAVY!r}\nheavy = lambda: sorted({{m.split('.')[0] for m in sys.modules}} & set(HEAVY))\nout = {{}}\n"
    proc = subprocess.run([sys.executable, "-c", prelude + code + "\nprint(json.dumps(out))"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_listing_the_verbs_and_their_options_loads_no_heavy_library():
    """Every verb module (new ones too) imports light; ``--help`` and the full parser stay light."""
    out = _loaded_after(
        "import contextlib, importlib, io, pkgutil\n"
        "from mjmotion import cli, commands\n"
        "for info in pkgutil.iter_modules(commands.__path__):\n"
        "    importlib.import_module(f'mjmotion.commands.{info.name}')\n"
        "    out[f'import mjmotion.commands.{info.name}'] = heavy()\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n"
        "        cli.main(['--help'])\n"
        "    except SystemExit:\n"
        "        pass\n"
        "out['mjmotion --help'] = heavy()\n"
        "cli.build_parser()\n"
        "out['every verb add_arguments'] = heavy()\n"
    )
    assert len(out) >= 3 + 14, out  # every verb module was imported
    assert {k: v for k, v in out.items() if v} == {}, "move these imports into the verb's run()"


def test_info_loads_only_numpy_even_for_the_largest_clip(mocap):
    """``info`` reads with NumPy alone: no MuJoCo, SciPy, CasADi, Matplotlib, nor Numba for a 3.4 MB clip."""
    small, large = mocap / "cmu_cgspeed_daz" / "09_01.bvh", mocap / "cmu_iclone_ccrig" / "002_07.bvh"
    out = _loaded_after(
        "import contextlib, io\n"
        "from mjmotion.cli import main\n"
        f"for f in ({str(small)!r}, {str(large)!r}):\n"
        "    with contextlib.redirect_stdout(io.StringIO()):\n"
        "        assert main(['info', f]) == 0\n"
        "    out[f] = heavy()\n"
        "out['numpy'] = 'numpy' in sys.modules\n"
    )
    assert out.pop("numpy") is True
    assert out == {str(small): [], str(large): []}


@pytest.mark.parametrize("gl", [None, "egl"])
def test_verbs_that_render_nothing_import_mujoco_without_its_gl_backend(mocap, gl):
    """``evaluate`` imports MuJoCo without the OpenGL backend its package loads at import (glfw or
    EGL through PyOpenGL: 40-50 ms), leaves ``MUJOCO_GL`` as the user set it, and a render context
    still opens in the same process afterwards (mjmotion opens its own)."""
    import subprocess
    import sys

    clip = mocap / "cmu_asfamc_converted" / "16_15.bvh"
    code = (
        "import contextlib, io, json, os, sys\n"
        "from mjmotion.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    assert main(['evaluate', {str(clip)!r}]) == 0\n"
        "out = {'gl': sorted({m.split('.')[0] for m in sys.modules} & {'glfw', 'OpenGL'}), 'env': os.environ.get('MUJOCO_GL')}\n"
        "from mjmotion import render\n"
        "from mjmotion.errors import MjmotionError\n"
        "try:\n"
        "    render.open_gl_context(16, 16).free()\n"
        "    out['render'] = 'ok'\n"
        "except MjmotionError as e:\n"
        "    out['render'] = str(e)\n"
        "print(json.dumps(out))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"} | ({"MUJOCO_GL": gl} if gl else {})
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["gl"] == [] and out["env"] == (gl or "egl")  # (the render verb's module defaults it to egl)
    if "no offscreen OpenGL backend" not in out["render"]:  # (a machine without EGL or OSMesa)
        assert out["render"] == "ok", out


def test_the_judge_loads_no_scipy(mocap):
    """``evaluate`` of a clip of every flavour, and the audit's warm-up (run before local workers
    fork), load MuJoCo but no SciPy: its filters and ground-reaction solves are the judge's own
    (``mjmotion.filters``, ``mjmotion.nnls``); SciPy's optimize and linalg cost 0.3 s a process."""
    clips = [mocap / "cmu_cgspeed_daz" / "09_01.bvh", mocap / "cmu_asfamc_converted" / "16_15.bvh", mocap / "cmu_iclone_ccrig" / "002_03.bvh"]
    out = _loaded_after(
        "import contextlib, io\n"
        "from mjmotion.cli import main\n"
        "from mjmotion import audit\n"
        f"for f in {[str(c) for c in clips]!r}:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):\n"
        "        assert main(['evaluate', f]) == 0\n"
        "    out[f] = heavy()\n"
        "audit.warm_up()\n"
        "out['warm_up'] = heavy()\n"
    )
    assert all(v == ["mujoco"] for v in out.values()), out


def test_frames_that_must_be_inside_the_clip_say_so_in_help_and_error(walk, tmp_path, capsys):
    # The help said "range: from 0", and frame 0 was always refused later ("outside the clip's inner frames").
    for verb, option in (("vary", "--abort-at"), ("hit", "--frame")):
        assert main([verb, "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        assert f"{option} " in text and "inside the clip, not its first or last" in text and "range: from 1 to 999,998" in text, verb
    assert main(["vary", str(walk), "--abort-at", "0", "-o", str(tmp_path / "v.bvh")]) == 2
    assert capsys.readouterr().err.startswith("error: --abort-at 0: expected a frame index inside the clip (not its first or last)")
